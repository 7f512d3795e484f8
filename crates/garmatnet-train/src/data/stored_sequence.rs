//! One fabric's stored drapes over a run of a dataset's frames, as a sequence to export or
//! to hold a predicted sequence against.

use garmatnet_core::Pose;
use garmatnet_core::TriMesh;
use garmatnet_sim::frame_range;

use crate::data::loader::{SampleKey, TrainingDataset};
use crate::error::{Error, Result};

/// One fabric's stored drapes over a run of a dataset's frames: the ground truth as a
/// sequence ([`stored_sequence`]), for a
/// [`DrapeSequence`](garmatnet_core::DrapeSequence).
#[derive(Debug, Clone, PartialEq)]
pub struct StoredSequence {
    /// The fabric's name, as the dataset spells it.
    pub material: String,
    /// The dataset's pose indices, in order.
    pub frames: Vec<usize>,
    /// The pose of each frame.
    pub poses: Vec<Pose>,
    /// The simulated garment of each frame, as stored (metres).
    pub garments: Vec<TriMesh>,
}

/// The stored drapes of the fabric named `material` (case-insensitive) in `data`, at the
/// frames `frames` names (`START..END`, `START..=END`, `START..` or `all`, as
/// `garmatnet_sim::resolve_frames` reads them, of the dataset's poses) that the dataset's
/// [`SamplePlan`](garmatnet_sim::SamplePlan) holds for that fabric (every one, unless the
/// dataset is strided).
///
/// # Errors
/// [`Error::Dataset`] for a name the dataset does not hold (listing what it holds), frames
/// the plan holds none of for the fabric, or a frame not draped yet (named); the frame
/// parser's errors; unreadable arrays.
pub fn stored_sequence(
    data: &TrainingDataset,
    material: &str,
    frames: &str,
) -> Result<StoredSequence> {
    let spec = data.spec();
    let index = spec
        .materials
        .iter()
        .position(|m| m.name.eq_ignore_ascii_case(material.trim()))
        .ok_or_else(|| {
            let names: Vec<&str> = spec.materials.iter().map(|m| m.name.as_str()).collect();
            Error::Dataset {
                dir: data.dir().to_owned(),
                message: format!(
                    "it holds no fabric named `{material}`; it holds: {}",
                    names.join(", ")
                ),
            }
        })?;
    let range = frame_range(frames, spec.poses.len(), "the dataset's poses")?;
    // A strided dataset drapes this fabric at some poses only: the sequence takes those.
    let held: Vec<usize> = range.filter(|&p| spec.plan.includes(index, p)).collect();
    if held.is_empty() {
        return Err(Error::Dataset {
            dir: data.dir().to_owned(),
            message: format!(
                "its plan ({}) drapes `{}` at none of the frames {frames}: choose frames the \
                 plan holds for it",
                spec.plan, spec.materials[index].name
            ),
        });
    }
    let mut sequence = StoredSequence {
        material: spec.materials[index].name.clone(),
        frames: held.clone(),
        poses: held.iter().map(|&p| spec.poses[p].clone()).collect(),
        garments: Vec::with_capacity(held.len()),
    };
    for pose in held {
        let truth = data.truth(SampleKey {
            material: index,
            pose,
        })?;
        sequence.garments.push(TriMesh::new(
            truth.simulated,
            data.garment().rest.faces.clone(),
        )?);
    }
    Ok(sequence)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fabrics_stored_drapes_come_back_as_a_sequence() -> anyhow::Result<()> {
        let dir = tempfile::tempdir()?;
        crate::test_util::synthetic_dataset(dir.path(), 3, 6);
        let data = TrainingDataset::open(dir.path(), false)?;
        let name = data.spec().materials[1].name.clone();
        let stored = stored_sequence(&data, &name.to_uppercase(), "2..=4")?;
        assert_eq!(stored.material, name);
        assert_eq!(stored.frames, [2, 3, 4]);
        assert_eq!(stored.poses, data.spec().poses[2..=4]);
        for (k, garment) in stored.garments.iter().enumerate() {
            let truth = data.truth(SampleKey {
                material: 1,
                pose: 2 + k,
            })?;
            assert_eq!(garment.vertices, truth.simulated);
            assert_eq!(garment.faces, data.garment().rest.faces);
        }
        assert_eq!(stored_sequence(&data, &name, "all")?.frames.len(), 6);
        let unknown = stored_sequence(&data, "Velvet", "all").expect_err("not in the dataset");
        assert!(unknown.to_string().contains(&name), "{unknown}");
        let past = stored_sequence(&data, &name, "4..7").expect_err("past the poses");
        assert!(past.to_string().contains("5"), "{past}");
        Ok(())
    }
}
