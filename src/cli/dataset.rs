//! `garmatnet dataset check|merge|animate`: validate a dataset directory and print its
//! statistics; merge shard outputs (full or slim) into one dataset; write a fabric's stored
//! drapes as an animation to look at.

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
    /// recomputed, byte for byte as `simulate` writes them. Datasets of different fabrics
    /// (same poses and settings) join with `simulate --materials reused --reuse A --reuse B`.
    Merge {
        /// The merged dataset (created, or added to when it holds the same spec).
        #[arg(long)]
        into: PathBuf,
        /// The shard directories, each with its `manifest.json`.
        #[arg(required = true)]
        sources: Vec<PathBuf>,
    },
    /// Write one fabric's stored drapes over a run of frames, to look at the ground truth:
    /// `.glb` as one animation (garment and skinned body), `.obj`, `.ply` and `.png` as one
    /// numbered file a frame. Works on a dataset still being made, for the frames it has.
    Animate {
        /// The dataset directory.
        dir: PathBuf,
        /// The fabric, by its name in the dataset (case-insensitive).
        #[arg(long)]
        material: String,
        /// Which of its poses: `START..END` (END excluded), `START..=END`, `START..` or `all`.
        #[arg(long, default_value = "all")]
        frames: String,
        /// Frames per second of a `.glb` animation.
        #[arg(long, default_value_t = 30.0)]
        fps: f64,
        /// Output file(s), by extension; repeat for several.
        #[arg(long, required = true)]
        out: Vec<PathBuf>,
    },
}

/// Runs the command.
pub fn run(command: &DatasetCommand) -> Result<()> {
    match command {
        DatasetCommand::Check { dir } => {
            let report = garmatnet::sim::check(dir)?;
            outln!("{report}")?;
            if !report.is_ok() {
                bail!("{} has problems (listed above)", dir.display());
            }
            if !report.is_sound() {
                outln!(
                    "not sound: {} samples past the sound stretch (torn or snagged drapes), {} \
                     deeper than 1 mm into the body and {} asymmetric at a symmetric pose \
                     (listed above): not fit to learn from",
                    report.over_stretched.len(),
                    report.penetrating.len(),
                    report.asymmetric.len()
                )?;
            }
            Ok(())
        }
        DatasetCommand::Animate {
            dir,
            material,
            frames,
            fps,
            out,
        } => {
            for path in out {
                garmatnet::core::OutputFormat::from_path(path)?;
            }
            let data = garmatnet::train::TrainingDataset::open(dir, true)?;
            let stored = garmatnet::train::stored_sequence(&data, material, frames)?;
            let view = garmatnet::core::DrapeSequence {
                frames: &stored.frames,
                body: data.body(),
                poses: &stored.poses,
                garments: &stored.garments,
                simulated: None,
                fps: *fps,
            };
            let (first, last) = (stored.frames[0], stored.frames[stored.frames.len() - 1]);
            super::write_sequence_outputs(
                &view,
                out,
                &format!("{}, frames {first}..={last}", stored.material),
            )?;
            Ok(())
        }
        DatasetCommand::Merge { into, sources } => {
            let spec = garmatnet::sim::Manifest::read(&sources[0])
                .with_context(|| format!("reading the first source, {}", sources[0].display()))?
                .spec;
            let report = garmatnet::sim::merge_shards(into, sources, spec)?;
            let merged = garmatnet::sim::Manifest::read(into)?;
            outln!(
                "merged {} samples into {} ({} copied, {} completed from slim samples); it holds \
                 {} of {} samples ({} materials, {} poses: {})",
                report.copied + report.derived,
                into.display(),
                report.copied,
                report.derived,
                merged.samples.len(),
                merged
                    .spec
                    .plan
                    .sample_count(merged.spec.materials.len(), merged.spec.poses.len()),
                merged.spec.materials.len(),
                merged.spec.poses.len(),
                merged.spec.plan
            )?;
            Ok(())
        }
    }
}
