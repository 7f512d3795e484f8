//! Run: `cargo run --release --example net_reference [-- --model FILE --out DIR]`
//!
//! Writes reference inputs and outputs of a model's two nets for cross-checks in other
//! frameworks (`benches/pytorch_crosscheck.py` loads the same safetensors file into PyTorch
//! and compares): `pose.npy` [B, 72] and `material.npy` [B, 6] (random valid poses and
//! normalised materials, float32 values stored as float64), `fitting.npy` and `local.npy` [B, 3n] (float64, the
//! de-normalised displacements in metres, the model's frame), and `timing.json` with this
//! build's CPU time per forward pass of both nets at batch 1 and batch B.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use burn::prelude::*;
use clap::Parser;
use garmatnet::core::{JointLimits, SplitMix64};
use garmatnet::model::{GarMatNetModel, default_model_path, select_device};
use npyz::WriterBuilder;

/// Command-line arguments.
#[derive(Debug, Parser)]
struct Args {
    /// Model file (default: the shipped model).
    #[arg(long)]
    model: Option<PathBuf>,
    /// Output folder.
    #[arg(long, default_value = "out/net_reference")]
    out: PathBuf,
    /// Batch size B.
    #[arg(long, default_value_t = 64)]
    batch: usize,
    /// Seed of the random inputs.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

fn write_npy(path: &Path, shape: &[u64], values: &[f64]) -> Result<()> {
    let mut bytes = Vec::new();
    let mut w = npyz::WriteOptions::<f64>::new()
        .default_dtype()
        .shape(shape)
        .writer(&mut bytes)
        .begin_nd()?;
    w.extend(values.iter().copied())?;
    w.finish()?;
    garmatnet::core::write_bytes_atomic(path, &bytes)?;
    Ok(())
}

fn median_ms(mut f: impl FnMut(), repeats: usize) -> f64 {
    let mut times: Vec<f64> = (0..repeats)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

fn main() -> Result<()> {
    let args = Args::parse();
    let device = select_device("cpu")?;
    let path = args.model.clone().unwrap_or_else(default_model_path);
    let model = GarMatNetModel::load(&path, &device)
        .with_context(|| format!("loading {}", path.display()))?;
    std::fs::create_dir_all(&args.out)?;
    let b = args.batch.max(1);
    let mut rng = SplitMix64::new(args.seed);
    let limits = JointLimits::default();
    let mut poses = Vec::with_capacity(b * 72);
    let mut materials = Vec::with_capacity(b * 6);
    for _ in 0..b {
        poses.extend(
            limits
                .sample(&mut rng, 1.0)
                .to_vec()
                .iter()
                .map(|&v| v as f32),
        );
        materials.extend((0..6).map(|_| rng.next_f64() as f32));
    }
    let inputs = |rows: usize| {
        (
            Tensor::<2>::from_data(
                TensorData::new(poses[..rows * 72].to_vec(), [rows, 72]),
                &device,
            ),
            Tensor::<2>::from_data(
                TensorData::new(materials[..rows * 6].to_vec(), [rows, 6]),
                &device,
            ),
        )
    };
    let run = |rows: usize| -> (Vec<f32>, Vec<f32>) {
        let (p, m) = inputs(rows);
        let f = model.fitting.forward(p.clone(), m.clone());
        let l = model.local.forward(p, m);
        (
            f.into_data().try_into_vec_as::<f32>().expect("f32 output"),
            l.into_data().try_into_vec_as::<f32>().expect("f32 output"),
        )
    };
    let (fitting, local) = run(b);
    let n3 = 3 * model.vertex_count();
    let denorm = |raw: &[f32], norm: &garmatnet::model::OutputNormalizer| -> Vec<f64> {
        raw.chunks_exact(n3)
            .flat_map(|row| norm.denormalize(row))
            .collect()
    };
    let widen = |v: &[f32]| v.iter().map(|&x| f64::from(x)).collect::<Vec<f64>>();
    write_npy(&args.out.join("pose.npy"), &[b as u64, 72], &widen(&poses))?;
    write_npy(
        &args.out.join("material.npy"),
        &[b as u64, 6],
        &widen(&materials),
    )?;
    write_npy(
        &args.out.join("fitting.npy"),
        &[b as u64, n3 as u64],
        &denorm(&fitting, &model.fitting_norm),
    )?;
    write_npy(
        &args.out.join("local.npy"),
        &[b as u64, n3 as u64],
        &denorm(&local, &model.local_norm),
    )?;

    let _ = run(1);
    let batch1 = median_ms(|| drop(run(1)), 50);
    let batched = median_ms(|| drop(run(b)), 10) / b as f64;
    let timing = serde_json::json!({
        "backend": "burn flex (CPU)",
        "threads": std::thread::available_parallelism().map_or(1, usize::from),
        "batch": b,
        "batch1_ms": batch1,
        "batched_ms_per_frame": batched,
        "model": path,
    });
    garmatnet::core::write_bytes_atomic(
        args.out.join("timing.json"),
        serde_json::to_string_pretty(&timing)?.as_bytes(),
    )?;
    println!(
        "wrote {}: both nets {batch1:.3} ms at batch 1, {batched:.3} ms/frame at batch {b}",
        args.out.display()
    );
    Ok(())
}
