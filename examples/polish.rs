//! Run: `cargo run --release --example polish [-- --materials A,B --frames 10,20 --budgets 0,2,4,8,16]`
//!
//! The network's prediction as the simulator's starting point. Drapes each fabric along the
//! built-in walk the way the revision-2 datasets did (brisk, seed 0, 200 frames, default
//! resolution, the walk's default settings) up to the last requested frame; at each
//! requested frame predicts the shirt with the shipped model (or `$GARMATNET_MODEL`) and
//! gives that prediction a budget of Newton iterations on the posed body ([`FrameStepper`],
//! friction measured from the prediction). Prints the time and the mean per-vertex distance
//! (mm) to the walked drape for each budget. The shipped model (revisions 3 and 4) trained on
//! independent poses, not on this walk; the revision-1 and revision-2 models trained on it
//! with every 10th frame held out (book/src/experiments/polish.md measured the first).

use std::time::Instant;

use anyhow::{Context, Result, ensure};
use clap::Parser;
use garmatnet::core::vertex_errors_mm;
use garmatnet::core::{CapsuleBody, Garment, Material, Resolution};
use garmatnet::sim::{DrapeSettings, FrameStepper, MotionGenerator, SequenceSettings, drape_poses};
use garmatnet::{Detail, Predictor};

/// Command-line arguments.
#[derive(Debug, Parser)]
struct Args {
    /// Preset fabrics, comma-separated.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "Cotton Poplin,Denim Heavy,Silk Chiffon"
    )]
    materials: Vec<String>,
    /// Frames of the 200-frame motion to predict and polish.
    #[arg(long, value_delimiter = ',', default_value = "10,20")]
    frames: Vec<usize>,
    /// Newton budgets to polish with (0: the prediction as it is).
    #[arg(long, value_delimiter = ',', default_value = "0,2,4,8,16,32")]
    budgets: Vec<usize>,
}

fn main() -> Result<()> {
    let args = Args::parse();
    let last = *args.frames.iter().max().context("--frames is empty")?;
    ensure!(last < 200, "frames are of the 200-frame motion: 0 to 199");
    let device = garmatnet::select_device("cpu")?;
    let predictor = Predictor::default_tshirt(&device)?;
    let body = CapsuleBody::smpl_neutral();
    let garment = Garment::tshirt(Resolution::Default, &body)?;
    ensure!(
        predictor.vertex_count() == garment.vertex_count(),
        "the model is not for the default-resolution shirt"
    );
    // The first frames of the revision-2 datasets' 200-frame walk (a sequence's frames
    // depend on its length).
    let poses = MotionGenerator::new(0, 200).generate();
    let settings = SequenceSettings::default();
    let mut totals = vec![(0.0, 0.0); args.budgets.len()];
    let mut count = 0;
    for name in &args.materials {
        let material = Material::preset(name).with_context(|| format!("material {name}"))?;
        let walked = drape_poses(&garment, &body, &material, &poses[..=last], &settings)?;
        for &f in &args.frames {
            let predicted = predictor.predict(&poses[f], &material, Detail::Full)?;
            let mut line = format!("{name}, frame {f}:");
            for (b, &budget) in args.budgets.iter().enumerate() {
                let start = Instant::now();
                let mut shirt = FrameStepper::new(
                    &garment,
                    &body,
                    &material,
                    &DrapeSettings {
                        max_iterations: budget.max(1),
                        ..settings.drape.clone()
                    },
                    &poses[f],
                    predicted.vertices.clone(),
                )?;
                if budget > 0 {
                    shirt.step(&poses[f])?;
                }
                let ms = start.elapsed().as_secs_f64() * 1e3;
                let errors = vertex_errors_mm(shirt.positions(), &walked[f])?;
                let mm = errors.iter().sum::<f64>() / errors.len() as f64;
                totals[b].0 += ms;
                totals[b].1 += mm;
                line += &format!("  {budget} it {mm:.2} mm ({ms:.0} ms)");
            }
            println!("{line}");
            count += 1;
        }
    }
    for (budget, (ms, mm)) in args.budgets.iter().zip(&totals) {
        println!(
            "budget {budget}: mean {:.2} mm, {:.0} ms (solver made per frame included)",
            mm / f64::from(count),
            ms / f64::from(count)
        );
    }
    Ok(())
}
