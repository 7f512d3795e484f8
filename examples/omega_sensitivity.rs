//! Run: `cargo run --release --example omega_sensitivity [-- --materials A,B --frames 20
//! --deltas 0,0.005,0.02]`
//!
//! How far a ground-truth drape moves when the fabric changes a little. Each material is
//! draped along the built-in motion (the 200 brisk frames of seed 0 that the revision-2
//! datasets walked, book/src/experiments/r2-shipped-model.md; default resolution, the walk's
//! default settings) up to `--frames`, once as given and once per `--deltas` entry with its
//! normalised ω moved that far along one fixed direction (unit length in the normalised
//! cube). The mean per-vertex distance between
//! the two drapes, over the second half of the frames, is what any model must resolve to
//! tell the two fabrics apart; if it does not fall towards zero with the step, the drape is
//! not a smooth function of the fabric and no regressor on (pose, fabric) can beat that
//! floor. The whole-shirt shift (the length of the mean displacement) tells a shirt that
//! slid on the body from one that folded differently.

use anyhow::{Context, Result, ensure};
use clap::Parser;
use garmatnet::core::{CapsuleBody, Garment, Material, Resolution, Vec3};
use garmatnet::sim::{MotionGenerator, MotionPace, SequenceSettings, drape_sequence};

/// Command-line arguments.
#[derive(Debug, Parser)]
struct Args {
    /// Preset fabrics, comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "Cotton Poplin,Wool Crepe,Silk Charmeuse"
    )]
    materials: Vec<String>,
    /// The last frame of the motion to drape (2 to 199).
    #[arg(long, default_value_t = 20)]
    frames: usize,
    /// Steps in the normalised ω cube, comma-separated (0 re-runs the fabric as given).
    #[arg(long, value_delimiter = ',', default_value = "0,0.005,0.02,0.06")]
    deltas: Vec<f64>,
    /// Coulomb friction coefficient of the drapes (default: the solver's, 0.3, with the
    /// cloth carried with the body between steps; 0 walks frictionless, not carried, as
    /// datasets made before friction were).
    #[arg(long)]
    friction: Option<f64>,
}

/// Frames of the motion the revision-2 datasets walked.
const MOTION_FRAMES: usize = 200;

/// The fixed direction of the steps: every component moves, none dominates.
const DIRECTION: [f64; 6] = [0.47, -0.31, 0.52, -0.38, 0.29, -0.43];

fn main() -> Result<()> {
    let args = Args::parse();
    ensure!(
        (2..MOTION_FRAMES).contains(&args.frames),
        "--frames must be 2 to {}",
        MOTION_FRAMES - 1
    );
    let body = CapsuleBody::smpl_neutral();
    let garment = Garment::tshirt(Resolution::Default, &body)?;
    // The sequence depends on its length, so generate the revision-2 datasets' 200 frames
    // and walk the first ones: the drapes as given are then the samples of a walked dataset
    // (`simulate --motion brisk --protocol walk`) made with the same solver settings.
    let mut poses = MotionGenerator::with_pace(0, MOTION_FRAMES, MotionPace::Brisk).generate();
    poses.truncate(args.frames + 1);
    let measured: Vec<usize> = (args.frames.div_ceil(2)..=args.frames).collect();
    let mut settings = SequenceSettings::default();
    if let Some(mu) = args.friction {
        settings.drape.friction = mu;
        settings.follow_body = mu > 0.0;
    }
    let norm = DIRECTION.iter().map(|d| d * d).sum::<f64>().sqrt();
    let drapes = |material: &Material| -> Result<Vec<Vec<Vec3>>> {
        let mut kept = Vec::new();
        drape_sequence(
            &garment,
            &body,
            material,
            &poses,
            &settings,
            None,
            |frame, x, _| {
                if measured.contains(&frame) {
                    kept.push(x.to_vec());
                }
                Ok(())
            },
        )?;
        Ok(kept)
    };
    println!(
        "frames {}..={} of the brisk motion, walked in sequence; friction {}",
        measured[0], args.frames, settings.drape.friction
    );
    for name in &args.materials {
        let material = Material::preset(name).with_context(|| format!("material {name}"))?;
        let base = drapes(&material)?;
        let omega = material.to_normalized();
        for &delta in &args.deltas {
            let moved: [f64; 6] =
                std::array::from_fn(|i| (omega[i] + delta * DIRECTION[i] / norm).clamp(0.0, 1.0));
            let other = drapes(&Material::from_normalized(moved)?)?;
            let gaps: Vec<Gap> = base.iter().zip(&other).map(|(a, b)| gap(a, b)).collect();
            let mut per_frame: Vec<f64> = gaps.iter().map(|g| g.mean_mm).collect();
            let mean = per_frame.iter().sum::<f64>() / per_frame.len() as f64;
            let shift = gaps.iter().map(|g| g.shift_mm).sum::<f64>() / gaps.len() as f64;
            per_frame.sort_by(f64::total_cmp);
            let median = per_frame[per_frame.len() / 2];
            let max = per_frame[per_frame.len() - 1];
            let far = per_frame.iter().filter(|&&d| d > FAR_MM).count();
            println!(
                "{name:16} delta {delta:6.3}: mean {mean:6.2} mm per vertex, median frame \
                 {median:6.2}, worst {max:6.2}, {far:2} of {} frames beyond {FAR_MM} mm; \
                 whole-shirt shift {shift:6.2} mm",
                per_frame.len()
            );
        }
    }
    Ok(())
}

/// A frame's drape counted as far from the other one beyond this mean distance (mm).
const FAR_MM: f64 = 15.0;

/// How two drapes of one frame differ.
struct Gap {
    /// Mean per-vertex distance (mm).
    mean_mm: f64,
    /// Length of the mean displacement (mm): the part of the gap that moves the whole shirt.
    shift_mm: f64,
}

fn gap(a: &[Vec3], b: &[Vec3]) -> Gap {
    let n = a.len() as f64;
    let mean_mm = a.iter().zip(b).map(|(p, q)| (p - q).norm()).sum::<f64>() / n * 1e3;
    let shift = a.iter().zip(b).fold(Vec3::zeros(), |s, (p, q)| s + (p - q)) / n;
    Gap {
        mean_mm,
        shift_mm: shift.norm() * 1e3,
    }
}
