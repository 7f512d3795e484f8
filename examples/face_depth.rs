//! Run: `cargo run --release --example face_depth -- DATASET_DIR ...`
//!
//! How deep the true drapes' triangles reach into the body between their vertices.
//! The solver's contact acts at the vertices; a triangle whose corners lie on the body
//! surface can still cut under it where the surface curves or where two body parts press
//! together. Since ground-truth revision 4 the recorded drape's projection pushes a grid of
//! points across each triangle out too (quarters of its edges,
//! `garmatnet_core::FACE_DIVISIONS`); this checks twice as finely, between those points as
//! well. For every sample it takes the signed distance to the posed body at 43 points of each
//! triangle (the points of barycentric coordinates in eighths other than the corners, and the
//! centroid) and keeps the deepest; it prints, per pose and per dataset, the mean and largest
//! of those depths and how many samples reach deeper than 1 mm.

use std::collections::BTreeMap;

use anyhow::Result;
use clap::Parser;
use garmatnet::core::{FACE_DIVISIONS, deepest_point_inside};
use garmatnet::train::TrainingDataset;

/// Command-line arguments.
#[derive(Debug, Parser)]
struct Args {
    /// Dataset directories (from `garmatnet simulate`).
    #[arg(required = true)]
    datasets: Vec<std::path::PathBuf>,
}

fn main() -> Result<()> {
    let args = Args::parse();
    for dir in &args.datasets {
        let set = TrainingDataset::open(dir, true)?;
        let faces = &set.garment().rest.faces;
        // Per pose: each sample's deepest face point, in mm (positive = inside the body).
        let mut per_pose: BTreeMap<usize, Vec<f64>> = BTreeMap::new();
        for key in set.keys() {
            let x = set.truth(key)?.simulated;
            let posed = set.body().pose(&set.spec().poses[key.pose]);
            let deepest = deepest_point_inside(&x, faces, &posed, 2 * FACE_DIVISIONS);
            per_pose.entry(key.pose).or_default().push(1e3 * deepest);
        }
        println!("{}:", dir.display());
        println!("| pose | samples | mean deepest (mm) | largest (mm) | deeper than 1 mm |");
        println!("|---:|---:|---:|---:|---:|");
        let summary = |depths: &[f64]| {
            let mean = depths.iter().sum::<f64>() / depths.len() as f64;
            let largest = depths.iter().copied().fold(0.0, f64::max);
            let over = depths.iter().filter(|d| **d > 1.0).count();
            (mean, largest, over)
        };
        for (pose, depths) in &per_pose {
            let (mean, largest, over) = summary(depths);
            println!(
                "| {pose} | {} | {mean:.2} | {largest:.2} | {over} |",
                depths.len()
            );
        }
        let all: Vec<f64> = per_pose.values().flatten().copied().collect();
        let (mean, largest, over) = summary(&all);
        println!(
            "| all | {} | {mean:.2} | {largest:.2} | {over} |",
            all.len()
        );
    }
    Ok(())
}
