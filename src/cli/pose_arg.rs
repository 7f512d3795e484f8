//! `--pose FRAME|FILE`: a frame of the built-in motion sequence, or a pose file.

use std::path::Path;

use anyhow::{Context, Result, bail};
use garmatnet::core::{Pose, read_poses};
use garmatnet::sim::MotionGenerator;

/// The seed and length of the built-in motion sequence that `--pose FRAME` indexes.
pub const DEFAULT_MOTION_SEED: u64 = 0;
/// The number of frames of the built-in motion sequence.
pub const DEFAULT_MOTION_FRAMES: usize = 240;

/// Resolves `spec` (a frame number of the built-in sequence, or a `.json`/`.npz`/`.npy`
/// pose file) and `frame` (which pose of a file; default 0) to a pose.
pub fn resolve_pose(spec: Option<&str>, frame: Option<usize>) -> Result<Pose> {
    let Some(spec) = spec else {
        return Ok(Pose::zero());
    };
    if let Ok(index) = spec.parse::<usize>() {
        let frames = MotionGenerator::new(DEFAULT_MOTION_SEED, DEFAULT_MOTION_FRAMES).generate();
        return frames.get(index).cloned().with_context(|| {
            format!(
                "--pose {index}: the built-in motion has frames 0..{}",
                frames.len()
            )
        });
    }
    let poses =
        read_poses(Path::new(spec)).with_context(|| format!("reading poses from {spec}"))?;
    let index = frame.unwrap_or(0);
    match poses.get(index) {
        Some(p) => Ok(p.clone()),
        None => bail!(
            "--frame {index}: `{spec}` holds {} poses (frames 0..{})",
            poses.len(),
            poses.len()
        ),
    }
}
