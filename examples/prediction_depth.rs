//! Run: `cargo run --release --example prediction_depth -- [PRESET ...]`
//!
//! How deep the shipped model's predictions cut under the body between their vertices at
//! the everyday suite. The predictor's push-out moves every vertex at least 2 mm out of the
//! posed body; a triangle between such vertices can still cut under it where the surface is
//! convex. For each preset (default: Cashmere, Denim Heavy, Silk Chiffon, Trim Fusible Rigid,
//! Cotton Jersey) and each everyday pose this prints the deepest vertex and the deepest of 43
//! points across every triangle (`garmatnet_core::deepest_point_inside`, eighths) inside the body, and
//! in the end the largest and how many predictions reach deeper than 1 mm, and the mean time
//! of a prediction; then the same with `PushOut::faces` (the triangles pushed out too).

use std::time::Instant;

use anyhow::{Context, Result};
use garmatnet::Material;
use garmatnet::core::{SignedDistance, deepest_point_inside};
use garmatnet::model::{Detail, Predictor, PushOut, default_model_path, select_device};
use garmatnet::sim::everyday_poses;

fn main() -> Result<()> {
    let mut presets: Vec<String> = std::env::args().skip(1).collect();
    if presets.is_empty() {
        presets = [
            "Cashmere",
            "Denim Heavy",
            "Silk Chiffon",
            "Trim Fusible Rigid",
            "Cotton Jersey",
        ]
        .map(String::from)
        .to_vec();
    }
    let device = select_device("cpu")?;
    let vertices_only = Predictor::from_file(default_model_path(), &device)?;
    let faces = Predictor::from_file(default_model_path(), &device)?.with_push_out(PushOut {
        faces: true,
        ..PushOut::default()
    })?;
    for (label, predictor) in [("vertices", &vertices_only), ("faces too", &faces)] {
        measure(label, predictor, &presets)?;
    }
    Ok(())
}

/// Prints the table and summary for `predictor`, whose push-out is `label`.
fn measure(label: &str, predictor: &Predictor, presets: &[String]) -> Result<()> {
    let body = predictor
        .body()
        .context("the shipped model's predictor knows its body")?
        .clone();
    let (mut depths, mut seconds) = (Vec::new(), 0.0);
    println!("push-out at the {label}:");
    println!("| preset | pose | deepest vertex (mm) | deepest between vertices (mm) |");
    println!("|---|---|---:|---:|");
    for name in presets {
        let material = Material::preset(name)?;
        for pose in everyday_poses() {
            let start = Instant::now();
            let mesh = predictor.predict(&pose.pose, &material, Detail::Full)?;
            seconds += start.elapsed().as_secs_f64();
            let posed = body.pose(&pose.pose);
            let depth = |p: &garmatnet::core::Vec3| -posed.distance(p) * 1e3;
            let vertices = mesh.vertices.iter().map(depth).fold(0.0, f64::max);
            let between = 1e3 * deepest_point_inside(&mesh.vertices, &mesh.faces, &posed, 8);
            println!("| {name} | {} | {vertices:.2} | {between:.2} |", pose.name);
            depths.push(between);
        }
    }
    let over = depths.iter().filter(|d| **d > 1.0).count();
    let largest = depths.iter().copied().fold(0.0, f64::max);
    println!(
        "push-out at the {label}: largest {largest:.2} mm between the vertices; {over} of {} \
         predictions past 1 mm; {:.2} ms a prediction",
        depths.len(),
        1e3 * seconds / depths.len() as f64
    );
    Ok(())
}
