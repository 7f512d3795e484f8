//! Run: `cargo run --release --example path_sensitivity [-- --materials A,B --frame 12]`
//!
//! How much a ground-truth drape depends on the path the walk took to it. A static drape is
//! not unique (cloth buckles one way or another), and a walked dataset (revision 2's, or
//! `simulate --protocol walk`) reaches frame `f` by walking from frame `f - 1`. This drapes
//! each material along the built-in motion (brisk, seed 0, default resolution, the walk's
//! default settings) up to `--frame`, then drapes the same frame again by walking straight
//! from frame `f - 2`, and prints how far the two valid drapes lie apart. No model can
//! predict a walked drape from (pose, fabric) more closely than this spread allows; that is
//! why revision 3's canonical protocol drapes every sample from rest along one path.

use anyhow::{Context, Result, ensure};
use clap::Parser;
use garmatnet::core::vertex_errors_mm;
use garmatnet::core::{CapsuleBody, Garment, Material, Resolution};
use garmatnet::sim::{
    MotionGenerator, MotionPace, SequenceResume, SequenceSettings, drape_poses, drape_sequence,
};

/// Command-line arguments.
#[derive(Debug, Parser)]
struct Args {
    /// Preset fabrics, comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "Cotton Poplin,Tulle,Denim Heavy,Wool Crepe,Silk Charmeuse,Cowhide Leather"
    )]
    materials: Vec<String>,
    /// The frame to drape twice (at least 2).
    #[arg(long, default_value_t = 12)]
    frame: usize,
}

fn main() -> Result<()> {
    let args = Args::parse();
    let f = args.frame;
    ensure!(
        f >= 2,
        "--frame must be at least 2 (the detour starts at frame f - 2)"
    );
    let body = CapsuleBody::smpl_neutral();
    let garment = Garment::tshirt(Resolution::Default, &body)?;
    let poses = MotionGenerator::with_pace(0, f + 1, MotionPace::Brisk).generate();
    let settings = SequenceSettings::default();
    // The same frames with frame f in place of frame f - 1: resumed at index f - 1 from the
    // drape of frame f - 2, the walk goes straight to frame f.
    let mut detour = poses[..f - 1].to_vec();
    detour.push(poses[f].clone());
    let mut means = Vec::new();
    for name in &args.materials {
        let material = Material::preset(name).with_context(|| format!("material {name}"))?;
        let walked = drape_poses(&garment, &body, &material, &poses, &settings)?;
        let resume = SequenceResume {
            next: f - 1,
            positions: walked[f - 2].clone(),
        };
        let mut other = Vec::new();
        drape_sequence(
            &garment,
            &body,
            &material,
            &detour,
            &settings,
            Some(resume),
            |_, x, _| {
                other = x.to_vec();
                Ok(())
            },
        )?;
        let mut gaps = vertex_errors_mm(&other, &walked[f])?;
        gaps.sort_by(f64::total_cmp);
        let mean = gaps.iter().sum::<f64>() / gaps.len() as f64;
        println!(
            "{name:20} frame {f}: from frame {} instead of {}: mean {mean:.2} mm, p95 {:.1} mm, max {:.1} mm",
            f - 2,
            f - 1,
            gaps[gaps.len() * 95 / 100],
            gaps[gaps.len() - 1]
        );
        means.push(mean);
    }
    println!(
        "mean over {} fabrics: {:.2} mm",
        means.len(),
        means.iter().sum::<f64>() / means.len().max(1) as f64
    );
    Ok(())
}
