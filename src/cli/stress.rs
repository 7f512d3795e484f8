//! `garmatnet stress`: random valid (pose, material) pairs through a model; fails on NaN or
//! a vertex a metre from the body.

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Args;
use garmatnet::model::{Predictor, default_model_path, select_device};
use garmatnet::train::{FAR_FROM_BODY, stress_predictor};

/// Predict many random valid (pose, material) pairs and check every output.
#[derive(Debug, Args)]
pub struct StressArgs {
    /// Model file (default: the shipped model, or $GARMATNET_MODEL).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// How many pairs.
    #[arg(long, default_value_t = 10_000)]
    pub count: usize,
    /// Seed of the random pairs.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Batch size.
    #[arg(long, default_value_t = 64)]
    pub batch: usize,
    /// Compute device: cpu, gpu or auto.
    #[arg(long, default_value = "cpu")]
    pub device: String,
}

/// Runs the command.
pub fn run(args: &StressArgs) -> Result<()> {
    let device = select_device(&args.device)?;
    let path = args.model.clone().unwrap_or_else(default_model_path);
    let predictor = Predictor::from_file(&path, &device)?;
    let report = stress_predictor(&predictor, args.count, args.seed, args.batch)?;
    outln!(
        "{} predictions in {:.1} s: all finite; farthest vertex {:.3} m from the body",
        report.predictions,
        report.seconds,
        report.max_body_distance_m
    )?;
    if !report.passed() {
        bail!(
            "{} predictions put a vertex more than {FAR_FROM_BODY} m from the body; the first: \
             pose {:?}, ω {:?}",
            report.far_predictions,
            report.first_far.as_ref().map(|(p, _)| p.to_vec()),
            report.first_far.as_ref().map(|(_, m)| m),
        );
    }
    Ok(())
}
