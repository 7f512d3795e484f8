//! Run: `cargo run --release --example pose_coverage -- NAME=SOURCE ...`
//!
//! Where each set's arms are: every `NAME=SOURCE` is a dataset directory (its manifest's
//! poses) or a pose file. For each set it prints, as a Markdown table, the share of upper
//! arms in each band of elevation in the chest's frame (the frame the pose sampler's
//! `--arm-bands` are drawn in: −88° … −60° hanging, −60° … 45° between, 45° … 85° raised),
//! the share of elbows bent past 45°, and the largest tilt of the whole body at the pelvis.
//! It compares a model's training poses with poses it is measured on.

use std::path::PathBuf;

use anyhow::{Context, Result, ensure};
use clap::Parser;
use garmatnet::core::Skeleton;
use garmatnet::sim::read_poses_or_dataset;

/// Command-line arguments.
#[derive(Debug, Parser)]
struct Args {
    /// `NAME=SOURCE`: a set's name and its dataset directory or pose file.
    #[arg(required = true, value_parser = parse_set)]
    sets: Vec<(String, PathBuf)>,
}

/// Parses `NAME=SOURCE`.
fn parse_set(s: &str) -> Result<(String, PathBuf)> {
    let (name, source) = s
        .split_once('=')
        .with_context(|| format!("{s:?}: expected NAME=SOURCE"))?;
    Ok((name.to_owned(), PathBuf::from(source)))
}

/// The band edges, degrees of elevation in the chest's frame.
const EDGES: [f64; 7] = [-90.0, -60.0, -30.0, 0.0, 30.0, 60.0, 90.0];

fn main() -> Result<()> {
    let args = Args::parse();
    let skeleton = Skeleton::smpl_neutral();
    let bands: Vec<String> = EDGES
        .windows(2)
        .map(|w| format!("{:.0}° … {:.0}°", w[0], w[1]))
        .collect();
    println!(
        "| set | poses | {} | elbows bent > 45° | largest pelvis tilt (rad) |",
        bands.join(" | ")
    );
    println!("|---|---:|{}---:|---:|", "---:|".repeat(bands.len()));
    for (name, source) in &args.sets {
        let poses = read_poses_or_dataset(source)
            .with_context(|| format!("{name}: reading the poses of {}", source.display()))?;
        ensure!(
            !poses.is_empty(),
            "{name}: {} holds no poses",
            source.display()
        );
        let mut counts = [0usize; EDGES.len() - 1];
        let (mut bent, mut tilt) = (0usize, 0.0_f64);
        for pose in &poses {
            let world = skeleton.world_transforms(pose);
            for (shoulder, elbow) in [(16, 18), (17, 19)] {
                let arm = (world[elbow].translation.vector - world[shoulder].translation.vector)
                    .normalize();
                let local = world[9].rotation.inverse() * arm;
                let elevation = local.y.clamp(-1.0, 1.0).asin().to_degrees();
                let band = EDGES[1..]
                    .iter()
                    .position(|&edge| elevation < edge)
                    .unwrap_or(counts.len() - 1);
                counts[band] += 1;
                bent += usize::from(pose.joint(elbow).norm() > 45f64.to_radians());
            }
            let pelvis = pose.joint(0);
            tilt = tilt.max(pelvis.x.hypot(pelvis.z));
        }
        let arms = (2 * poses.len()) as f64;
        let shares: Vec<String> = counts
            .iter()
            .map(|&c| format!("{:.0} %", 100.0 * c as f64 / arms))
            .collect();
        println!(
            "| {name} | {} | {} | {:.0} % | {tilt:.2} |",
            poses.len(),
            shares.join(" | "),
            100.0 * bent as f64 / arms
        );
    }
    Ok(())
}
