//! Poses named on a command line: a frame of the built-in motion, the everyday suite or one
//! of its poses, or a pose file, and ranges of their frames (`START..END`, `all`).

use std::ops::Range;
use std::path::Path;

use garmatnet_core::{Error as CoreError, Pose, Real, read_poses};

use crate::error::{Error, Result};
use crate::motion::everyday_poses::{everyday_pose, everyday_poses};
use crate::motion::generator::MotionGenerator;

/// The seed of the built-in motion sequence that `--pose FRAME` indexes.
pub const DEFAULT_MOTION_SEED: u64 = 0;
/// The number of frames of the built-in motion sequence that `--pose FRAME` indexes.
pub const DEFAULT_MOTION_FRAMES: usize = 240;

/// The `--pose` value that names the everyday suite ([`crate::everyday_poses`]);
/// `everyday:NAME` names one of its poses.
pub const EVERYDAY_POSES: &str = "everyday";

/// Resolves a `--pose` argument: a frame number of the built-in motion sequence
/// ([`DEFAULT_MOTION_SEED`], [`DEFAULT_MOTION_FRAMES`]), `everyday` (the everyday suite, of
/// which `frame` picks one pose), `everyday:NAME` (its pose called NAME) or a pose file
/// (`.json`, `.npz`, `.npy`), of which `frame` picks one pose (default the first). No
/// argument is the T-pose.
///
/// # Errors
/// [`CoreError::OutOfRange`] for a frame past the sequence or the file;
/// [`Error::FrameWithoutPoseFile`] for a `frame` without a pose file to pick from (no
/// `spec`, or a frame number of the built-in motion); [`Error::UnknownEverydayPose`] for an
/// unknown pose name; the pose file reader's errors (missing file, malformed content, NaN)
/// otherwise.
pub fn resolve_pose(spec: Option<&str>, frame: Option<usize>) -> Result<Pose> {
    let no_file = |reason: &str| Error::FrameWithoutPoseFile {
        reason: reason.to_owned(),
    };
    let Some(spec) = spec else {
        return match frame {
            Some(_) => Err(no_file("no --pose was given")),
            None => Ok(Pose::zero()),
        };
    };
    let out_of_range = |what: &str, index: usize, count: usize| CoreError::OutOfRange {
        what: what.into(),
        value: index as Real,
        min: 0.0,
        max: count.saturating_sub(1) as Real,
        hint: String::new(),
    };
    if let Ok(index) = spec.trim().parse::<usize>() {
        if frame.is_some() {
            return Err(no_file(&format!(
                "--pose {index} is a frame of the built-in motion"
            )));
        }
        let frames = MotionGenerator::new(DEFAULT_MOTION_SEED, DEFAULT_MOTION_FRAMES).generate();
        return frames.get(index).cloned().ok_or_else(|| {
            out_of_range("frame of the built-in motion (--pose)", index, frames.len()).into()
        });
    }
    if let Some(name) = everyday_name(spec) {
        if frame.is_some() {
            return Err(no_file(&format!("--pose {spec} names one pose")));
        }
        return everyday_pose(name);
    }
    let poses = pose_list(spec)?;
    let index = frame.unwrap_or(0);
    poses.get(index).cloned().ok_or_else(|| {
        out_of_range(
            &format!("pose index into `{spec}` (--frame)"),
            index,
            poses.len(),
        )
        .into()
    })
}

/// Resolves a `--frames` argument: which poses of a pose file (`pose_file`, `.json`, `.npz`,
/// `.npy`) or of the everyday suite (`pose_file` = `everyday`), or of the built-in motion
/// sequence ([`DEFAULT_MOTION_SEED`], [`DEFAULT_MOTION_FRAMES`]) when there is none, to
/// predict in order. `frames` is `START..END` (END excluded), `START..=END`, `START..` (to
/// the last pose) or `all`; returns each pose with its index.
///
/// # Errors
/// [`Error::MalformedFrames`] for another form; [`Error::EmptyFrames`] for an empty range;
/// [`CoreError::OutOfRange`] for a range past the poses there are; the pose file reader's
/// errors (missing file, malformed content, NaN) otherwise.
pub fn resolve_frames(pose_file: Option<&str>, frames: &str) -> Result<Vec<(usize, Pose)>> {
    let (poses, source) = match pose_file {
        Some(file) => (pose_list(file)?, format!("`{file}`")),
        None => (
            MotionGenerator::new(DEFAULT_MOTION_SEED, DEFAULT_MOTION_FRAMES).generate(),
            "the built-in motion".to_owned(),
        ),
    };
    picked_frames(poses, frames, &source)
}

/// `NAME` of an `everyday:NAME` pose argument.
fn everyday_name(spec: &str) -> Option<&str> {
    let (head, name) = spec.trim().split_once(':')?;
    head.eq_ignore_ascii_case(EVERYDAY_POSES).then_some(name)
}

/// The poses of a pose file, or the everyday suite for [`EVERYDAY_POSES`].
fn pose_list(spec: &str) -> Result<Vec<Pose>> {
    if spec.trim().eq_ignore_ascii_case(EVERYDAY_POSES) {
        return Ok(everyday_poses().into_iter().map(|p| p.pose).collect());
    }
    Ok(read_poses(Path::new(spec))?)
}

/// The frames of the revision-2 model's training walk (the model shipped up to version 0.3):
/// [`DEFAULT_MOTION_SEED`], [`SHIPPED_TRAINING_FRAMES`] frames at the default pace and arm
/// clearance, the poses of `garmatnet simulate --poses 200 --seed 0 --motion brisk` (the
/// default before independent poses). The model shipped now (revisions 3 and 4) was trained on
/// independent poses of the sampler, not on these frames. `frames` as in [`resolve_frames`].
///
/// # Errors
/// As [`resolve_frames`].
pub fn training_motion_frames(frames: &str) -> Result<Vec<(usize, Pose)>> {
    let poses = MotionGenerator::new(DEFAULT_MOTION_SEED, SHIPPED_TRAINING_FRAMES).generate();
    picked_frames(poses, frames, "the revision-2 model's training walk")
}

/// The poses of `poses` (from `source`) that `frames` picks ([`frame_range`]), each with its
/// index.
fn picked_frames(poses: Vec<Pose>, frames: &str, source: &str) -> Result<Vec<(usize, Pose)>> {
    let range = frame_range(frames, poses.len(), source)?;
    Ok(poses
        .into_iter()
        .enumerate()
        .skip(range.start)
        .take(range.len())
        .collect())
}

/// The number of frames of the walk the revision-2 model (shipped up to version 0.3) was
/// trained on ([`training_motion_frames`]). The name is older than revision 3: the model
/// shipped now was trained on independent poses, not on this walk.
pub const SHIPPED_TRAINING_FRAMES: usize = 200;

/// The poses `text` (`START..END`, `START..=END`, `START..` or `all`) picks of `count`, from
/// `source` (named in the error for a range past the end).
///
/// # Errors
/// [`Error::MalformedFrames`] for another form; [`Error::EmptyFrames`] for an empty range;
/// [`CoreError::OutOfRange`] for a range past `count`.
pub fn frame_range(text: &str, count: usize, source: &str) -> Result<Range<usize>> {
    let text = text.trim();
    let malformed = || Error::MalformedFrames {
        text: text.to_owned(),
    };
    let number = |t: &str| t.trim().parse::<usize>().map_err(|_| malformed());
    let range = if text.eq_ignore_ascii_case("all") {
        0..count
    } else if let Some((start, end)) = text.split_once("..=") {
        number(start)?..number(end)?.checked_add(1).ok_or_else(malformed)?
    } else if let Some((start, end)) = text.split_once("..") {
        let end = if end.trim().is_empty() {
            count
        } else {
            number(end)?
        };
        number(start)?..end
    } else {
        return Err(malformed());
    };
    if range.is_empty() {
        return Err(Error::EmptyFrames {
            text: text.to_owned(),
        });
    }
    if range.end > count {
        return Err(CoreError::OutOfRange {
            what: format!("last frame of `{text}` in {source} (--frames)"),
            value: (range.end - 1) as Real,
            min: 0.0,
            max: count.saturating_sub(1) as Real,
            hint: String::new(),
        }
        .into());
    }
    Ok(range)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn poses_resolve_from_frames_and_files() -> anyhow::Result<()> {
        assert_eq!(resolve_pose(None, None)?, Pose::zero());
        let frames = MotionGenerator::new(DEFAULT_MOTION_SEED, DEFAULT_MOTION_FRAMES).generate();
        assert_eq!(resolve_pose(Some("7"), None)?, frames[7]);
        let err = resolve_pose(Some("240"), None).expect_err("past the end");
        assert!(err.to_string().contains("239"), "{err}");
        let dir = tempfile::tempdir()?;
        let file = dir.path().join("p.json");
        garmatnet_core::write_poses_json(&file, &frames[..2])?;
        let file = file.to_str().expect("utf-8 path");
        assert_eq!(resolve_pose(Some(file), Some(1))?, frames[1]);
        assert!(resolve_pose(Some(file), Some(2)).is_err());
        assert!(resolve_pose(Some("/no/such/poses.json"), None).is_err());
        // A --frame with nothing to pick from is refused, not ignored.
        for (spec, frame) in [(None, Some(3)), (Some("5"), Some(3))] {
            let err = resolve_pose(spec, frame).expect_err("--frame without a file");
            assert!(matches!(err, Error::FrameWithoutPoseFile { .. }), "{err}");
        }
        Ok(())
    }

    #[test]
    fn everyday_poses_resolve_by_index_name_and_range() -> anyhow::Result<()> {
        let suite = everyday_poses();
        assert_eq!(resolve_pose(Some("everyday"), None)?, suite[0].pose);
        assert_eq!(resolve_pose(Some("everyday"), Some(3))?, suite[3].pose);
        assert_eq!(
            resolve_pose(Some("everyday:arms-at-sides"), None)?,
            everyday_pose("arms-at-sides")?
        );
        let unknown = resolve_pose(Some("everyday:cartwheel"), None).expect_err("no such pose");
        assert!(unknown.to_string().contains("hands-on-hips"), "{unknown}");
        assert!(resolve_pose(Some("everyday"), Some(suite.len())).is_err());
        let all = resolve_frames(Some("everyday"), "all")?;
        assert_eq!(all.len(), suite.len());
        assert_eq!(all[5].1, suite[5].pose);
        Ok(())
    }

    #[test]
    fn frames_resolve_as_ranges_of_a_file_or_the_motion() -> anyhow::Result<()> {
        let motion = MotionGenerator::new(DEFAULT_MOTION_SEED, DEFAULT_MOTION_FRAMES).generate();
        let picked = resolve_frames(None, "10..13")?;
        assert_eq!(
            picked.iter().map(|(f, _)| *f).collect::<Vec<_>>(),
            vec![10, 11, 12]
        );
        assert_eq!(picked[2].1, motion[12]);
        assert_eq!(resolve_frames(None, "10..=12")?.len(), 3);
        assert_eq!(resolve_frames(None, "230..")?.len(), 10);
        assert_eq!(resolve_frames(None, "all")?.len(), DEFAULT_MOTION_FRAMES);
        let dir = tempfile::tempdir()?;
        let file = dir.path().join("p.json");
        garmatnet_core::write_poses_json(&file, &motion[..5])?;
        let file = file.to_str().expect("utf-8 path");
        let all = resolve_frames(Some(file), "all")?;
        assert_eq!(all.len(), 5);
        assert_eq!(all[4], (4, motion[4].clone()));
        for (bad, hint) in [
            ("3..9", "4"), // past the file's last pose, which is named
            ("3..3", "END must lie past START"),
            ("4..=2", "END must lie past START"),
            ("a..3", "START..END"),
            ("7", "START..END"),
            ("-1..3", "START..END"),
        ] {
            let err = resolve_frames(Some(file), bad).expect_err(bad);
            assert!(err.to_string().contains(hint), "{bad}: {err}");
        }
        assert!(resolve_frames(Some("/no/such/poses.json"), "all").is_err());
        Ok(())
    }
}
