//! `garmatnet dataset check|merge`: validate a dataset directory and print its statistics;
//! merge shard outputs (full or slim) into one dataset.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Subcommand;

/// Dataset tools.
#[derive(Debug, Subcommand)]
pub enum DatasetCommand {
    /// Validate a dataset (every array's shape and finiteness) and print its statistics:
    /// residuals, penetration, strain, Newton iterations and the solver time it took.
    Check {
        /// The dataset directory.
        dir: PathBuf,
    },
    /// Merge shard outputs (`simulate --shard i/k`) into one dataset. A source sample may be
    /// slim (only `simulated.npy` and `stats.json`): its smoothed garment and body points are
    /// recomputed, byte for byte as `simulate` writes them.
    Merge {
        /// The merged dataset (created, or added to when it holds the same spec).
        #[arg(long)]
        into: PathBuf,
        /// The shard directories, each with its `manifest.json`.
        #[arg(required = true)]
        sources: Vec<PathBuf>,
    },
}

/// Runs the command.
pub fn run(command: &DatasetCommand) -> Result<()> {
    match command {
        DatasetCommand::Check { dir } => {
            let report = garmatnet::sim::check(dir)?;
            println!("{report}");
            if !report.is_ok() {
                bail!("{} has problems (listed above)", dir.display());
            }
            Ok(())
        }
        DatasetCommand::Merge { into, sources } => {
            let spec = garmatnet::sim::Manifest::read(&sources[0])
                .with_context(|| format!("reading the first source, {}", sources[0].display()))?
                .spec;
            let report = garmatnet::sim::merge_shards(into, sources, spec)?;
            let merged = garmatnet::sim::Manifest::read(into)?;
            println!(
                "merged {} samples into {} ({} copied, {} completed from slim samples); it holds \
                 {} of {} materials x {} poses",
                report.copied + report.derived,
                into.display(),
                report.copied,
                report.derived,
                merged.samples.len(),
                merged.spec.materials.len(),
                merged.spec.poses.len()
            );
            Ok(())
        }
    }
}
