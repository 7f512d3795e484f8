//! `garmatnet poses`: write the poses `simulate --poses N` drapes as a pose file, to look
//! at, to drape elsewhere, or to join with another dataset's poses.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use garmatnet::core::{read_poses, write_poses_json};
use garmatnet::sim::{DEFAULT_ARM_CLEARANCE, Manifest, manifest_path};

use super::simulate::{MAX_GENERATED_POSES, MotionKind, drawn_poses};

/// Write N poses as `simulate --poses N` draws them (independent poses by default) as a
/// JSON pose file, after the poses of another file or dataset if asked.
#[derive(Debug, Args)]
pub struct PosesArgs {
    /// How many poses to draw.
    #[arg(long)]
    pub count: usize,
    /// Seed, as `simulate --seed`: the same seed and settings give the same poses.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// `independent` (default) or a walk (`brisk`, `gentle`), as `simulate --motion`.
    #[arg(long, default_value = "independent")]
    pub motion: MotionKind,
    /// The share of hanging and raised arms of independent poses, `H,R`, as `simulate
    /// --arm-bands` (default 0.5,0.2).
    #[arg(long, value_name = "H,R")]
    pub arm_bands: Option<String>,
    /// A walk's gap between the arms and the torso (metres), as `simulate --arm-clearance`.
    #[arg(long, default_value_t = DEFAULT_ARM_CLEARANCE)]
    pub arm_clearance: f64,
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
        Some(dir) if manifest_path(dir).exists() => {
            Manifest::read(dir)
                .with_context(|| format!("reading the dataset in {}", dir.display()))?
                .spec
                .poses
        }
        Some(file) => {
            read_poses(file).with_context(|| format!("reading poses from {}", file.display()))?
        }
    };
    let first = poses.len();
    poses.extend(drawn_poses(
        args.count,
        args.seed,
        args.motion,
        args.arm_bands.as_deref(),
        args.arm_clearance,
    )?);
    write_poses_json(&args.out, &poses)
        .with_context(|| format!("writing {}", args.out.display()))?;
    outln!(
        "wrote {} poses to {} ({first} from --after, then {} {} poses of seed {})",
        poses.len(),
        args.out.display(),
        args.count,
        args.motion,
        args.seed
    )?;
    Ok(())
}
