//! Run: `cargo run --release --example drape [-- --out DIR --resolution default --poses 3]`
//!
//! Today this shows what the library can already do without a trained model: it poses the
//! body and the T-shirt template (linear blend skinning of the template with its body
//! anchors), splits the garment into its smooth part and its details with the paper's
//! Laplacian smoothing (λ = 0.15, 80 iterations), and writes OBJs and PNG renders.
//! Once the trained model ships, this example predicts drapes for several fabrics instead.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Parser;
use garmatnet::core::render::{
    BODY_COLOR, Camera, GARMENT_COLOR, RenderItem, RenderSettings, Shading, render, save_png,
    side_by_side,
};
use garmatnet::core::{LaplacianSmoother, SmoothingSettings, write_obj};
use garmatnet::sim::MotionGenerator;
use garmatnet::{CapsuleBody, Garment, Resolution, TriMesh};

/// Command-line arguments.
#[derive(Debug, Parser)]
struct Args {
    /// Output folder (created if missing).
    #[arg(long, default_value = "out/drape")]
    out: PathBuf,
    /// Template resolution: coarse, default or paper.
    #[arg(long, default_value = "default")]
    resolution: Resolution,
    /// How many poses of the built-in motion to show.
    #[arg(long, default_value_t = 3)]
    poses: usize,
}

fn main() -> Result<()> {
    let args = Args::parse();
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let body = CapsuleBody::smpl_neutral();
    let shirt = Garment::tshirt(args.resolution, &body)?;
    let smoother = LaplacianSmoother::new(&shirt.rest, SmoothingSettings::default())?;
    println!(
        "T-shirt template: {} vertices, {} springs ({} resolution)",
        shirt.vertex_count(),
        shirt.springs.len(),
        args.resolution
    );

    let motion = MotionGenerator::new(0, 240).generate();
    let step = (motion.len() / args.poses.max(1)).max(1);
    for (k, pose) in motion.iter().step_by(step).take(args.poses).enumerate() {
        let started = Instant::now();
        let posed_body = body.pose(pose);
        let garment = TriMesh::new(
            shirt.posed_rest_guess(posed_body.skinning_transforms()),
            shirt.rest.faces.clone(),
        )?;
        let smooth = TriMesh::new(
            smoother.smooth(&garment.vertices)?,
            shirt.rest.faces.clone(),
        )?;
        let elapsed = started.elapsed();
        let body_mesh = posed_body.mesh();

        let stem = format!("pose{:03}", k * step);
        write_obj(args.out.join(format!("{stem}_garment.obj")), &garment)?;
        write_obj(args.out.join(format!("{stem}_smooth.obj")), &smooth)?;
        write_obj(args.out.join(format!("{stem}_body.obj")), &body_mesh)?;
        let b = body_mesh.bounds().context("empty body mesh")?;
        let camera = Camera::framing(b.min, b.max, 0.35);
        let settings = RenderSettings::default();
        let view = |g: &TriMesh| {
            render(
                &[
                    RenderItem {
                        mesh: &body_mesh,
                        shading: Shading::Uniform(BODY_COLOR),
                    },
                    RenderItem {
                        mesh: g,
                        shading: Shading::Uniform(GARMENT_COLOR),
                    },
                ],
                &camera,
                &settings,
            )
        };
        let png = args.out.join(format!("{stem}.png"));
        save_png(
            &png,
            &side_by_side(&[view(&garment)?, view(&smooth)?], settings.background),
        )?;
        println!(
            "frame {:>3}: skinned + smoothed in {:.1} ms -> {} (left: skinned template, right: smooth part)",
            k * step,
            elapsed.as_secs_f64() * 1e3,
            png.display()
        );
    }
    println!("wrote OBJs and PNGs to {}", args.out.display());
    Ok(())
}
