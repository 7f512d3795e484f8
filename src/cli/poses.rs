//! `garmatnet poses`: write the poses `simulate --poses N` drapes as a pose file, to look
//! at, to drape elsewhere, or to join with another dataset's poses.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use garmatnet::core::write_poses_json;
use garmatnet::sim::read_poses_or_dataset;

use super::simulate::{MAX_GENERATED_POSES, PoseDrawArgs};

/// Write N poses as `simulate --poses N` draws them (independent poses by default) as a
/// JSON pose file, after the poses of another file or dataset if asked.
#[derive(Debug, Args)]
pub struct PosesArgs {
    /// How many poses to draw.
    #[arg(long)]
    pub count: usize,
    /// How they are drawn, as `simulate` draws them.
    #[command(flatten)]
    pub draw: PoseDrawArgs,
    /// Poses to put first: a pose file (.json, .npz, .npy) or a dataset directory (its
    /// manifest's poses, in order). `simulate --poses OUT --reuse DIR` then drapes only the
    /// new poses and copies the dataset's samples in.
    #[arg(long, value_name = "FILE|DIR")]
    pub after: Option<PathBuf>,
    /// The pose file to write (.json: a list of 72-vectors).
    #[arg(long)]
    pub out: PathBuf,
}

/// Runs the command.
pub fn run(args: &PosesArgs) -> Result<()> {
    if args.out.extension().and_then(|e| e.to_str()) != Some("json") {
        bail!(
            "--out {}: poses are written as JSON; give a name ending in .json",
            args.out.display()
        );
    }
    if args.count == 0 || args.count > MAX_GENERATED_POSES {
        bail!("--count {}: give 1 to {MAX_GENERATED_POSES}", args.count);
    }
    let mut poses = match &args.after {
        None => Vec::new(),
        Some(path) => read_poses_or_dataset(path)
            .with_context(|| format!("--after: reading the poses of {}", path.display()))?,
    };
    let first = poses.len();
    poses.extend(args.draw.poses(args.count)?);
    write_poses_json(&args.out, &poses)
        .with_context(|| format!("writing {}", args.out.display()))?;
    outln!(
        "wrote {} poses to {} ({first} from --after, then {} {} poses of seed {})",
        poses.len(),
        args.out.display(),
        args.count,
        args.draw.motion,
        args.draw.seed
    )?;
    Ok(())
}
