//! `garmatnet eval`: the paper's evaluation (Table 2, Figures 7–8 and 11–12).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use garmatnet::train::{EvalConfig, EvalInputs, evaluate};

/// Evaluate a model (and optionally the baseline) on its held-out test split.
#[derive(Debug, Args)]
pub struct EvalArgs {
    /// The dataset directory the model was trained on.
    #[arg(long)]
    pub data: PathBuf,
    /// The model file (its `.split.json` must lie next to it).
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
    let inputs = EvalInputs {
        data_dir: args.data.clone(),
        model: args.model.clone(),
        baseline: args.baseline.clone(),
        compare_model: args.compare.clone(),
        out_dir: args.report.clone(),
        held_out: args.held_out.clone(),
    };
    let config = EvalConfig {
        device: args.device.clone(),
        figures: !args.no_figures,
        ..EvalConfig::default()
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
    for set in &report.held_out_sets {
        outln!(
            "GarMatNet ({}, {} samples): fitting {:.2} mm, local {:.2} mm, whole {:.2} mm",
            set.name,
            set.all.samples,
            set.all.fitting_mm,
            set.all.local_mm,
            set.all.whole_mm
        )?;
    }
    outln!("report written to {}", args.report.display())?;
    Ok(())
}
