//! `garmatnet ensemble`: several trained models averaged into one model file.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use garmatnet::model::{GarMatNetModel, select_device};
use garmatnet::train::{Split, split_path};

/// Average models trained with different seeds into one model (the mean of their
/// predictions; one wider net of the same architecture and file format).
#[derive(Debug, Args)]
pub struct EnsembleArgs {
    /// The member models (two or more `.safetensors` files from `garmatnet train` with the
    /// same data and options except `--seed`).
    #[arg(required = true, num_args = 2..)]
    pub models: Vec<PathBuf>,
    /// The model file to write; the members' common split file is written next to it.
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs the command.
pub fn run(args: &EnsembleArgs) -> Result<()> {
    let device = select_device("cpu")?;
    let members = args
        .models
        .iter()
        .map(|p| {
            GarMatNetModel::load(p, &device).with_context(|| format!("loading {}", p.display()))
        })
        .collect::<Result<Vec<_>>>()?;
    // Evaluation reads the split next to the model to keep its test samples out of training:
    // the members must share one, or the ensemble's development or test set could hold
    // samples one member trained on.
    let dataset_hash = &members[0].meta.provenance.dataset_hash;
    let splits = args
        .models
        .iter()
        .zip(&members)
        .map(|(path, member)| -> Result<Option<Split>> {
            let file = split_path(path);
            if !file.exists() {
                return Ok(None);
            }
            let split = Split::read(&file, dataset_hash)?;
            // A member records the split it trained with; a file next to it that is another
            // run's would hand the ensemble the wrong held-out samples.
            split.check_model(&file, path, &member.meta.provenance)?;
            Ok(Some(split))
        })
        .collect::<Result<Vec<_>>>()?;
    if let Some(i) = splits.iter().position(|s| *s != splits[0]) {
        bail!(
            "{} and {} were trained on different splits (or only one has a split file), so \
             the ensemble's held-out samples could include some a member trained on; train \
             the members with the same split options (`--seed` changes only the weights and \
             shuffles)",
            args.models[0].display(),
            args.models[i].display()
        );
    }
    let split = splits.into_iter().next().flatten();
    let mut model = GarMatNetModel::average(&members, &device)?;
    model.meta.provenance.command = std::env::args().collect::<Vec<_>>().join(" ");
    if let (Some(split), Some(extra)) = (&split, model.meta.provenance.extra.as_object_mut()) {
        // The ensemble is evaluated with its members' split, written next to it below.
        extra.insert(
            garmatnet::model::TrainingProvenance::SPLIT_FINGERPRINT_KEY.into(),
            split.fingerprint().into(),
        );
    }
    model.save(&args.out)?;
    let out_split = split_path(&args.out);
    let split_note = match split {
        Some(split) => {
            split.write(&out_split)?;
            format!(" and {}", out_split.display())
        }
        None => {
            // A split file left by the model this one replaces would describe other nets.
            if out_split.exists() {
                std::fs::remove_file(&out_split)
                    .with_context(|| format!("removing the stale {}", out_split.display()))?;
            }
            " (the members have no split file, so neither has the ensemble)".to_owned()
        }
    };
    let size = std::fs::metadata(&args.out).map(|m| m.len()).unwrap_or(0);
    outln!(
        "wrote {} ({} members, {:.1} MB){split_note}",
        args.out.display(),
        members.len(),
        size as f64 / 1e6,
    )?;
    Ok(())
}
