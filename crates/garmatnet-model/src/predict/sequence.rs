//! Sequences: the garments of many poses (a motion's frames) in one material, the nets run
//! a batch of poses at a time and each mesh pushed out of its posed body.

use garmatnet_core::{Material, Pose, Real};

use crate::error::Result;
use crate::net::garmatnet_net::MATERIAL_DIM;
use crate::predict::predictor::{
    Detail, GarmentMesh, Predictor, validate_material, validate_poses,
};

/// How many poses [`Predictor::predict_sequence`] runs through the nets at once: enough to
/// amortise a pass, few enough that a long sequence never holds all its activations at once.
pub const SEQUENCE_BATCH: usize = 64;

/// The garments of a pose sequence, predicted a batch at a time ([`Predictor::sequence`]).
///
/// Yields one mesh per pose, in order. An error (a batch the nets could not predict, e.g.
/// a damaged model that emits a non-finite value) is yielded once, in place of that batch's
/// first mesh, and the iterator ends after it.
#[derive(Debug)]
pub struct SequencePredictions<'a> {
    predictor: &'a Predictor,
    batches: std::slice::Chunks<'a, Pose>,
    material: [Real; MATERIAL_DIM],
    detail: Detail,
    ready: std::vec::IntoIter<GarmentMesh>,
    failed: bool,
}

impl Iterator for SequencePredictions<'_> {
    type Item = Result<GarmentMesh>;

    fn next(&mut self) -> Option<Self::Item> {
        if let Some(mesh) = self.ready.next() {
            return Some(Ok(mesh));
        }
        if self.failed {
            return None;
        }
        let batch = self.batches.next()?;
        match self
            .predictor
            .predict_sequence_batch(batch, &self.material, self.detail)
        {
            Ok(meshes) => {
                self.ready = meshes.into_iter();
                self.ready.next().map(Ok)
            }
            Err(e) => {
                self.failed = true;
                Some(Err(e))
            }
        }
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let ready = self.ready.len();
        if self.failed {
            return (ready, Some(ready));
        }
        let rest: usize = self.batches.clone().map(<[Pose]>::len).sum();
        // The next batch yields at least one item: its first mesh, or the error that ends
        // the sequence.
        (ready + usize::from(rest > 0), Some(ready + rest))
    }
}

impl std::iter::FusedIterator for SequencePredictions<'_> {}

impl Predictor {
    /// Predicts the garment at each of `poses` (e.g. the frames of a motion) in one
    /// `material`: the nets run in batches of [`SEQUENCE_BATCH`] poses, and each mesh is
    /// pushed out of its posed body as [`Predictor::predict`] pushes one. The same meshes as
    /// one `predict` call per pose (to float rounding), with the nets' share of the time cut
    /// by batching, so the push-out is most of what a frame costs (`garmatnet drape
    /// --frames` uses it; figures in book/src/cli.md). Holds every mesh at once;
    /// [`Predictor::sequence`] yields the same meshes one at a time, for captures too long
    /// to keep in memory.
    ///
    /// # Errors
    /// As [`Predictor::predict`], for the material or the first bad pose.
    pub fn predict_sequence(
        &self,
        poses: &[Pose],
        material: &Material,
        detail: Detail,
    ) -> Result<Vec<GarmentMesh>> {
        self.sequence(poses, material, detail)?.collect()
    }

    /// The meshes of [`Predictor::predict_sequence`], predicted a batch of
    /// [`SEQUENCE_BATCH`] poses at a time as the iterator is advanced, so at most one
    /// batch's meshes are held: a capture of any length streams in bounded memory (to
    /// files, or to an engine frame by frame).
    ///
    /// ```no_run
    /// # fn main() -> Result<(), Box<dyn std::error::Error>> {
    /// use garmatnet_core::{Material, read_poses, write_obj};
    /// use garmatnet_model::{Detail, Predictor, select_device};
    ///
    /// let predictor = Predictor::default_tshirt(&select_device("cpu")?)?;
    /// let motion = read_poses("long_capture.npz")?;
    /// let denim = Material::preset("denim heavy")?;
    /// for (frame, mesh) in predictor.sequence(&motion, &denim, Detail::Full)?.enumerate() {
    ///     let mesh = mesh?;
    ///     write_obj(format!("frame{frame:05}.obj"), &mesh.into_tri_mesh()?)?;
    /// }
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// # Errors
    /// As [`Predictor::predict`], at once, for the material;
    /// [`Error::InvalidPose`](crate::Error::InvalidPose), at once, for the first unusable pose
    /// (with its index). A batch that fails later is an error item ([`SequencePredictions`]).
    pub fn sequence<'a>(
        &'a self,
        poses: &'a [Pose],
        material: &Material,
        detail: Detail,
    ) -> Result<SequencePredictions<'a>> {
        material.validate()?;
        self.sequence_normalized(poses, &material.to_normalized(), detail)
    }

    /// [`Predictor::predict_sequence`] for a normalised material ω (as
    /// [`Predictor::predict_normalized`] takes it), without a round trip through physical
    /// units.
    ///
    /// # Errors
    /// As [`Predictor::sequence_normalized`].
    pub fn predict_sequence_normalized(
        &self,
        poses: &[Pose],
        material: &[Real; MATERIAL_DIM],
        detail: Detail,
    ) -> Result<Vec<GarmentMesh>> {
        self.sequence_normalized(poses, material, detail)?.collect()
    }

    /// [`Predictor::sequence`] for a normalised material ω: the meshes predicted a batch of
    /// [`SEQUENCE_BATCH`] poses at a time as the iterator is advanced.
    ///
    /// # Errors
    /// As [`Predictor::predict_normalized`], at once, for ω outside [0, 1] or not finite;
    /// [`Error::InvalidPose`](crate::Error::InvalidPose), at once, for the first unusable pose
    /// (with its index). A batch that fails later is an error item ([`SequencePredictions`]).
    pub fn sequence_normalized<'a>(
        &'a self,
        poses: &'a [Pose],
        material: &[Real; MATERIAL_DIM],
        detail: Detail,
    ) -> Result<SequencePredictions<'a>> {
        validate_material(material)?;
        validate_poses(poses)?;
        Ok(SequencePredictions {
            predictor: self,
            batches: poses.chunks(SEQUENCE_BATCH),
            material: *material,
            detail,
            ready: Vec::new().into_iter(),
            failed: false,
        })
    }

    /// The meshes of one batch of a sequence, each pushed out of its posed body.
    fn predict_sequence_batch(
        &self,
        poses: &[Pose],
        material: &[Real; MATERIAL_DIM],
        detail: Detail,
    ) -> Result<Vec<GarmentMesh>> {
        let items: Vec<_> = poses.iter().map(|p| (p.clone(), *material)).collect();
        let meshes = self.predict_batch(&items, detail)?;
        Ok(self.pushed_out(meshes, poses))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Error;
    use crate::test_util::small_predictor as predictor;
    use approx::assert_relative_eq;
    use garmatnet_core::{CapsuleBody, DisplacementFrame, JointLimits, SplitMix64, Vec3};
    use std::sync::Arc;

    #[test]
    fn a_sequence_is_each_pose_predicted_and_pushed_out_alone() {
        let mut p = predictor(3, DisplacementFrame::World);
        p.set_test_body(CapsuleBody::smpl_neutral());
        let mut rng = SplitMix64::new(5);
        let limits = JointLimits::default();
        // More poses than one batch, so the chunking is crossed.
        let poses: Vec<Pose> = (0..SEQUENCE_BATCH + 3)
            .map(|_| limits.sample(&mut rng, 1.0))
            .collect();
        let silk = Material::preset("Silk Chiffon").unwrap();
        let sequence = p.predict_sequence(&poses, &silk, Detail::Full).unwrap();
        assert_eq!(sequence.len(), poses.len());
        let mut pushed = 0;
        for (pose, mesh) in poses.iter().zip(&sequence) {
            let alone = p.predict(pose, &silk, Detail::Full).unwrap();
            for (a, b) in alone.vertices.iter().zip(&mesh.vertices) {
                assert_relative_eq!(a, b, epsilon = 1e-5);
            }
            let raw = p
                .predict_normalized(pose, &silk.to_normalized(), Detail::Full)
                .unwrap();
            if raw.vertices != mesh.vertices {
                pushed += 1;
            }
        }
        assert!(pushed > 0, "no frame was pushed out of the body");
        assert!(
            sequence
                .iter()
                .all(|mesh| Arc::ptr_eq(&mesh.faces, &sequence[0].faces)
                    && *mesh.faces == *p.faces()),
            "every frame shares the template's one copy of the faces"
        );
        assert!(
            p.predict_sequence(&[], &silk, Detail::Full)
                .unwrap()
                .is_empty()
        );
        // ω given directly predicts the same sequence, and out-of-range ω is refused.
        let direct = p
            .predict_sequence_normalized(&poses, &silk.to_normalized(), Detail::Full)
            .unwrap();
        assert_eq!(direct, sequence);
        let mut bad = silk.to_normalized();
        bad[2] = 1.5;
        for poses in [&poses[..], &[]] {
            let Err(err) = p.sequence_normalized(poses, &bad, Detail::Full) else {
                panic!("ω out of range was accepted");
            };
            assert!(
                matches!(err, Error::Core(garmatnet_core::Error::OutOfRange { .. })),
                "{err}"
            );
        }
    }

    #[test]
    fn a_streamed_sequence_yields_the_collected_meshes_a_batch_at_a_time() {
        let mut p = predictor(3, DisplacementFrame::World);
        p.set_test_body(CapsuleBody::smpl_neutral());
        let mut rng = SplitMix64::new(6);
        let limits = JointLimits::default();
        let n = 2 * SEQUENCE_BATCH + 5;
        let poses: Vec<Pose> = (0..n).map(|_| limits.sample(&mut rng, 1.0)).collect();
        let denim = Material::preset("Denim Heavy").unwrap();
        let all = p.predict_sequence(&poses, &denim, Detail::Full).unwrap();
        let mut stream = p.sequence(&poses, &denim, Detail::Full).unwrap();
        assert_eq!(stream.size_hint(), (1, Some(n)));
        let first = stream.next().unwrap().unwrap();
        assert_eq!(first, all[0]);
        // One batch predicted, its other meshes waiting: no more than a batch is held.
        assert_eq!(stream.ready.len(), SEQUENCE_BATCH - 1);
        assert_eq!(stream.size_hint(), (SEQUENCE_BATCH - 1 + 1, Some(n - 1)));
        let rest: Vec<GarmentMesh> = stream.by_ref().map(Result::unwrap).collect();
        assert_eq!(rest.as_slice(), &all[1..]);
        assert_eq!(stream.size_hint(), (0, Some(0)));
        assert!(stream.next().is_none(), "fused");
        assert!(
            p.sequence(&[], &denim, Detail::Smooth)
                .unwrap()
                .next()
                .is_none()
        );
        let mut bad = denim;
        bad.density = f64::NAN;
        assert!(matches!(
            p.sequence(&poses, &bad, Detail::Full),
            Err(Error::Core(_))
        ));
        // A bad pose anywhere is refused before any work, by its index.
        let mut poses = poses;
        poses[SEQUENCE_BATCH + 2].set_joint(4, Vec3::new(0.0, f64::INFINITY, 0.0));
        let err = p.sequence(&poses, &denim, Detail::Full).unwrap_err();
        assert!(
            matches!(err, Error::InvalidPose { index, .. } if index == SEQUENCE_BATCH + 2),
            "{err}"
        );
        assert!(
            err.to_string()
                .contains(&format!("pose {} of the sequence", SEQUENCE_BATCH + 2)),
            "{err}"
        );
    }
}
