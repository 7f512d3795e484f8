//! `garmatnet eval`: the paper's evaluation (Table 2, Figures 7–8 and 11–12).

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::Args;
use garmatnet::train::{EvalConfig, EvalInputs, HeldOutInputs, evaluate, evaluate_held_out};

/// Evaluate a model (and optionally the baseline) on its held-out test split, or on
/// held-out sets alone.
#[derive(Debug, Args)]
pub struct EvalArgs {
    /// The dataset directory the model was trained on. Without it, only the `--held-out`
    /// sets are evaluated (no split file needed: e.g. the shipped model, whose training data
    /// is not shipped).
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// The model file (with `--data`, its `.split.json` must lie next to it).
    #[arg(long)]
    pub model: PathBuf,
    /// A baseline directory from `garmatnet train-baseline`.
    #[arg(long)]
    pub baseline: Option<PathBuf>,
    /// A second model on the same split (e.g. the other displacement frame) to compare.
    #[arg(long)]
    pub compare: Option<PathBuf>,
    /// Output directory: report.json, report.md, plots, heat maps, PLY.
    #[arg(long)]
    pub report: PathBuf,
    /// Compute device: cpu, gpu or auto.
    #[arg(long, default_value = "cpu")]
    pub device: String,
    /// Skip the figures (plots, heat maps, PLY).
    #[arg(long)]
    pub no_figures: bool,
    /// A held-out dataset to report on whole, as `NAME=DIR` (repeat for several): poses the
    /// model never came near, e.g. `everyday=ds/everyday` (`simulate --poses everyday`) and
    /// `held-out-motion=ds/walk7` (`simulate --motion brisk --seed 7`), draped by the
    /// canonical protocol with the model's template.
    #[arg(long, value_name = "NAME=DIR", value_parser = parse_held_out)]
    pub held_out: Vec<(String, PathBuf)>,
    /// Run the solver from the prediction to convergence on this many samples of each set
    /// (spread evenly) and report the Newton iterations it took beside the ground truth's
    /// (seconds a sample); default 0: skip.
    #[arg(long, default_value_t = 0)]
    pub newton_samples: usize,
    /// Evaluate the nets' own predictions, without the mirror averaging the predictor
    /// applies by default (`Predictor::with_mirror_averaging`).
    #[arg(long)]
    pub no_mirror_averaging: bool,
}

fn parse_held_out(value: &str) -> Result<(String, PathBuf), String> {
    match value.split_once('=') {
        Some((name, dir)) if !name.trim().is_empty() && !dir.is_empty() => {
            Ok((name.trim().to_owned(), PathBuf::from(dir)))
        }
        _ => Err(format!(
            "`{value}` is not NAME=DIR: name the held-out set, e.g. everyday=ds/everyday"
        )),
    }
}

/// Runs the command.
pub fn run(args: &EvalArgs) -> Result<()> {
    let config = EvalConfig {
        device: args.device.clone(),
        figures: !args.no_figures,
        newton_samples: args.newton_samples,
        mirror_averaging: !args.no_mirror_averaging,
        ..EvalConfig::default()
    };
    let Some(data) = &args.data else {
        return run_held_out(args, &config);
    };
    let inputs = EvalInputs {
        data_dir: data.clone(),
        model: args.model.clone(),
        baseline: args.baseline.clone(),
        compare_model: args.compare.clone(),
        out_dir: args.report.clone(),
        held_out: args.held_out.clone(),
    };
    let report = evaluate(&inputs, &config)?;
    let g = &report.garmatnet;
    let set = if report.test_materials.is_empty() {
        "every fabric x held-out poses"
    } else {
        "target materials x held-out poses"
    };
    outln!(
        "GarMatNet ({set}): fitting {:.2} mm, local {:.2} mm, whole {:.2} mm",
        g.fitting_mm,
        g.local_mm,
        g.whole_mm
    )?;
    if let Some(b) = &report.baseline {
        outln!(
            "baseline:                                      fitting {:.2} mm, local {:.2} mm, whole {:.2} mm",
            b.fitting_mm,
            b.local_mm,
            b.whole_mm
        )?;
    }
    if let Some(q) = &report.physical_quality {
        physical_line("test set", q)?;
    }
    held_out_lines(&report.held_out_sets)?;
    outln!("report written to {}", args.report.display())?;
    Ok(())
}

/// `eval` without `--data`: the held-out sets alone.
fn run_held_out(args: &EvalArgs, config: &EvalConfig) -> Result<()> {
    if args.baseline.is_some() || args.compare.is_some() {
        bail!(
            "--baseline and --compare are measured on the model's test split: give the dataset \
             it was trained on with --data"
        );
    }
    if args.held_out.is_empty() {
        bail!(
            "without --data, give at least one held-out set to evaluate on, e.g. \
             --held-out everyday=ds/everyday (garmatnet simulate --poses everyday)"
        );
    }
    let inputs = HeldOutInputs {
        model: args.model.clone(),
        out_dir: args.report.clone(),
        held_out: args.held_out.clone(),
    };
    let report = evaluate_held_out(&inputs, config)?;
    held_out_lines(&report.held_out_sets)?;
    outln!("report written to {}", args.report.display())?;
    Ok(())
}

/// The console lines of the held-out sets.
fn held_out_lines(sets: &[garmatnet::train::HeldOutSet]) -> Result<()> {
    for set in sets {
        outln!(
            "GarMatNet ({}, {} samples): fitting {:.2} mm, local {:.2} mm, whole {:.2} mm",
            set.name,
            set.all.samples,
            set.all.fitting_mm,
            set.all.local_mm,
            set.all.whole_mm
        )?;
        if let Some(q) = &set.physical_quality {
            physical_line(&set.name, q)?;
        }
        if let Some(m) = &set.symmetry {
            outln!(
                "  mirror asymmetry at {} symmetric samples (before push-out [ground truth]): \
                 mean {:.2} mm [{:.2}], max {:.2} mm [{:.2}]",
                m.samples,
                m.prediction_mean_mm,
                m.truth_mean_mm,
                m.prediction_max_mm,
                m.truth_max_mm
            )?;
        }
    }
    Ok(())
}

/// One line of a set's physical quality (raw predictions, ground truth in brackets).
fn physical_line(name: &str, q: &garmatnet::train::PhysicalQuality) -> Result<()> {
    outln!(
        "  physical ({name}, raw predictions [ground truth]): median residual {:.1} [{:.1}], deepest {:.1} mm [{:.1}], \
         {} of {} past the sound stretch, energy above the truth {:.1} mm median",
        q.median_residual,
        q.truth_median_residual,
        q.worst_depth_mm,
        q.truth_worst_depth_mm,
        q.past_sound_stretch,
        q.samples,
        q.median_energy_above_truth_mm
    )?;
    if let Some(n) = &q.newton {
        outln!(
            "  Newton from the prediction ({} samples): {:.0} iterations [{:.0}], {} converged, {:.2} mm from the truth",
            n.samples,
            n.mean_iterations,
            n.truth_mean_iterations,
            n.converged,
            n.mean_distance_to_truth_mm
        )?;
    }
    Ok(())
}
