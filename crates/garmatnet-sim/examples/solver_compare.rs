//! Run: `cargo run -p garmatnet-sim --release --example solver_compare -- RESOLUTION FRAMES
//! PRESET SETTINGS_A SETTINGS_B`
//!
//! Walks the T-shirt in fabric PRESET through the first FRAMES frames of the datasets' built-in
//! brisk motion (seed 0, as `simulate` draws it for that many frames) twice, with two solver
//! settings, and prints per frame the settle iterations of each and how far apart the two
//! drapes lie (mean and largest per-vertex distance, mm), and the wall time of each walk
//! (one after the other, on one thread). A setting is `default` or a JSON
//! object of the `SequenceSettings` fields to change, e.g.
//! `'{"drape": {"residual_tolerance": 0.01, "max_residual_tolerance": 0.5}}'`: what a solver
//! change costs in drape accuracy, measured the way book/src/solver.md's "measured and not adopted"
//! figures are.

use garmatnet_core::{CapsuleBody, Garment, Material, Resolution, Vec3};
use garmatnet_sim::{MotionGenerator, SequenceSettings, drape_sequence};

/// The default settings with the fields `json` names replaced (`default`: none); the
/// settings deserialise with defaults for every missing field, as `simulate --solver` reads them.
fn settings(json: &str) -> anyhow::Result<SequenceSettings> {
    if json == "default" {
        return Ok(SequenceSettings::default());
    }
    Ok(serde_json::from_str(json)?)
}

/// A walk: every frame's drape and settle iterations, and the seconds it took.
type Walk = (Vec<(Vec<Vec3>, usize)>, f64);

/// The walk through `frames` frames of seed 0's motion under `settings`.
fn walk(
    garment: &Garment,
    body: &CapsuleBody,
    material: &Material,
    frames: usize,
    settings: &SequenceSettings,
) -> anyhow::Result<Walk> {
    let poses = MotionGenerator::new(0, frames).generate();
    let start = std::time::Instant::now();
    let mut drapes = Vec::new();
    drape_sequence(
        garment,
        body,
        material,
        &poses,
        settings,
        None,
        |_, x, s| {
            drapes.push((x.to_vec(), s.iterations));
            Ok(())
        },
    )?;
    Ok((drapes, start.elapsed().as_secs_f64()))
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    anyhow::ensure!(
        args.len() == 5,
        "usage: solver_compare RESOLUTION FRAMES PRESET SETTINGS_A SETTINGS_B"
    );
    let resolution: Resolution = args[0].parse()?;
    let frames: usize = args[1].parse()?;
    let material = Material::preset(&args[2])?;
    let (a, b) = (settings(&args[3])?, settings(&args[4])?);
    let body = CapsuleBody::smpl_neutral();
    let garment = Garment::tshirt(resolution, &body)?;
    let (walk_a, seconds_a) = walk(&garment, &body, &material, frames, &a)?;
    let (walk_b, seconds_b) = walk(&garment, &body, &material, frames, &b)?;
    println!("frame  iterations A  iterations B  mean mm  max mm");
    let (mut its_a, mut its_b, mut sum, mut worst) = (0, 0, 0.0, 0.0_f64);
    for (frame, ((xa, ia), (xb, ib))) in walk_a.iter().zip(&walk_b).enumerate() {
        let d: Vec<f64> = xa
            .iter()
            .zip(xb)
            .map(|(p, q)| (p - q).norm() * 1e3)
            .collect();
        let mean = d.iter().sum::<f64>() / d.len() as f64;
        let max = d.iter().copied().fold(0.0, f64::max);
        println!("{frame:5}  {ia:12}  {ib:12}  {mean:7.2}  {max:6.1}");
        (its_a, its_b, sum, worst) = (its_a + ia, its_b + ib, sum + mean, worst.max(max));
    }
    println!(
        "all {frames} frames: {its_a} vs {its_b} settle iterations ({:.2}x), drapes {:.2} mm apart \
         on average, worst vertex {worst:.1} mm; walks took {seconds_a:.1} s vs {seconds_b:.1} s \
         ({:.2}x)",
        its_b as f64 / its_a.max(1) as f64,
        sum / frames.max(1) as f64,
        seconds_b / seconds_a
    );
    Ok(())
}
