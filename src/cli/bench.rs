//! `garmatnet bench`: run time against error for the simulator, GarMatNet variants and the
//! baseline on the same held-out samples.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use garmatnet::train::{BenchConfig, BenchInputs, run_bench};

/// Measure ms/frame against mean per-vertex error (mm) on a model's held-out samples.
#[derive(Debug, Args)]
pub struct BenchArgs {
    /// The dataset directory the model was trained on.
    #[arg(long)]
    pub data: PathBuf,
    /// The main model (its `.split.json` picks the held-out samples).
    #[arg(long)]
    pub model: PathBuf,
    /// More models to measure, `NAME=FILE` (e.g. `hidden-256=m256.safetensors`); repeatable.
    #[arg(long)]
    pub variant: Vec<String>,
    /// A baseline directory from `garmatnet train-baseline`.
    #[arg(long)]
    pub baseline: Option<PathBuf>,
    /// Output directory: bench.json, bench.md, pareto.png.
    #[arg(long)]
    pub out: PathBuf,
    /// Devices for the networks, comma-separated (cpu, gpu); unavailable ones are skipped.
    #[arg(long, default_value = "cpu")]
    pub devices: String,
    /// Held-out samples for the networks.
    #[arg(long, default_value_t = 16)]
    pub samples: usize,
    /// How many of them the simulator runs on.
    #[arg(long, default_value_t = 3)]
    pub sim_samples: usize,
    /// Newton-iteration budgets of the simulator, comma-separated (the dataset's own cap,
    /// the converged reference, is always added).
    #[arg(long, default_value = "4,10,25,50,100")]
    pub sim_budgets: String,
    /// Newton-iteration budgets of the simulator stepped as an application steps it (the
    /// previous frame carried with the skin in one step, then at most this many iterations),
    /// comma-separated; empty for none.
    #[arg(long, default_value = "8")]
    pub sim_frame_budgets: String,
    /// Newton-iteration budgets to polish the main model's prediction with (the prediction
    /// handed to the simulator on the posed body, then at most this many iterations; timed
    /// whole), comma-separated; empty (the default) for none.
    #[arg(long, default_value = "")]
    pub polish_budgets: String,
    /// Batch size of the batched rows.
    #[arg(long, default_value_t = 64)]
    pub batch: usize,
    /// Timed repetitions per batch-1 prediction (median reported).
    #[arg(long, default_value_t = 5)]
    pub repeats: usize,
}

/// Runs the command.
pub fn run(args: &BenchArgs) -> Result<()> {
    let variants = args
        .variant
        .iter()
        .map(|v| match v.split_once('=') {
            Some((name, path)) if !name.is_empty() && !path.is_empty() => {
                Ok((name.to_owned(), PathBuf::from(path)))
            }
            _ => bail!("--variant `{v}`: write NAME=FILE, e.g. hidden-256=m256.safetensors"),
        })
        .collect::<Result<Vec<_>>>()?;
    let sim_budgets = whole_numbers("--sim-budgets", &args.sim_budgets)?;
    let sim_frame_budgets = whole_numbers("--sim-frame-budgets", &args.sim_frame_budgets)?;
    let polish_budgets = whole_numbers("--polish-budgets", &args.polish_budgets)?;
    let config = BenchConfig {
        devices: args
            .devices
            .split(',')
            .map(|d| d.trim().to_owned())
            .collect(),
        samples: args.samples,
        sim_samples: args.sim_samples,
        sim_budgets,
        sim_frame_budgets,
        polish_budgets,
        batch: args.batch,
        repeats: args.repeats,
    };
    let inputs = BenchInputs {
        data_dir: args.data.clone(),
        model: args.model.clone(),
        variants,
        baseline: args.baseline.clone(),
        out_dir: args.out.clone(),
    };
    let report = run_bench(&inputs, &config)?;
    crate::cli::write_stdout(format_args!("{}", report.to_markdown()))?;
    outln!(
        "wrote {0}/bench.json, {0}/bench.md and {0}/pareto.png",
        args.out.display()
    )?;
    Ok(())
}

/// A comma-separated list of whole numbers given to `flag` (empty entries skipped).
fn whole_numbers(flag: &str, list: &str) -> Result<Vec<usize>> {
    list.split(',')
        .filter(|s| !s.trim().is_empty())
        .map(|s| {
            s.trim()
                .parse::<usize>()
                .with_context(|| format!("{flag}: `{s}` is not a whole number"))
        })
        .collect()
}
