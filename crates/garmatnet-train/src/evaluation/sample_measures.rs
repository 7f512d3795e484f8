//! What one evaluated sample adds to a report: its row, the garment a prediction makes, its
//! fabric's errors, and the running sums of mirror asymmetry and push-out.

use garmatnet_core::{SignedDistance, Vec3};
use garmatnet_model::material_range::{TrainingFabric, nearest};
use garmatnet_model::push_out;
use garmatnet_sim::{DatasetSpec, MaterialEntry, MirrorMap};

use crate::data::loader::{SampleKey, TrainingDataset};
use crate::evaluation::prediction_errors::{Prediction, VertexErrors, error_stats};
use crate::evaluation::report::{
    MaterialErrors, MirrorSymmetry, NearestTraining, PenetrationStats, SampleErrors,
};

/// One sample's row of a report: its material, pose and GarMatNet's mean errors (no
/// baseline).
pub(super) fn sample_errors(
    spec: &DatasetSpec,
    key: SampleKey,
    errors: &VertexErrors,
    pose_name: Option<String>,
) -> SampleErrors {
    SampleErrors {
        material: spec.materials[key.material].name.clone(),
        pose: key.pose,
        frame: spec.frames[key.pose],
        pose_name,
        garmatnet: errors.means_mm(),
        baseline: None,
    }
}

/// Sums [`MirrorSymmetry`] over the samples at symmetric poses.
#[derive(Default)]
pub(super) struct SymmetryAccumulator {
    samples: usize,
    prediction: (f64, f64),
    truth: (f64, f64),
}

impl SymmetryAccumulator {
    /// Adds one sample's prediction and truth (a garment that is not finite is skipped).
    pub(super) fn add(&mut self, map: &MirrorMap, prediction: &[Vec3], truth: &[Vec3]) {
        let (Ok(p), Ok(t)) = (map.asymmetry(prediction), map.asymmetry(truth)) else {
            return;
        };
        let add = |(sum, max): &mut (f64, f64), metres: f64| {
            *sum += 1e3 * metres;
            *max = max.max(1e3 * metres);
        };
        add(&mut self.prediction, p);
        add(&mut self.truth, t);
        self.samples += 1;
    }

    pub(super) fn finish(self) -> Option<MirrorSymmetry> {
        (self.samples > 0).then(|| {
            let n = self.samples as f64;
            MirrorSymmetry {
                samples: self.samples,
                prediction_mean_mm: self.prediction.0 / n,
                prediction_max_mm: self.prediction.1,
                truth_mean_mm: self.truth.0 / n,
                truth_max_mm: self.truth.1,
            }
        })
    }
}

/// One fabric's error over its samples; a fabric the model never trained on (`unseen`) names
/// the training fabric nearest to it in normalised ω.
pub(super) fn material_errors<'a>(
    material: &MaterialEntry,
    unseen: bool,
    training: &[TrainingFabric],
    errors: impl Iterator<Item = &'a VertexErrors>,
) -> MaterialErrors {
    let nearest_training = unseen
        .then(|| {
            nearest(
                &material.omega_normalized,
                training.iter().map(|f| (f, f.omega)),
            )
        })
        .flatten()
        .map(|(f, distance)| NearestTraining {
            material: f.name.clone(),
            distance,
        });
    MaterialErrors {
        material: material.name.clone(),
        unseen,
        garmatnet: error_stats(errors),
        nearest_training,
    }
}

/// The garment a prediction makes: the body points plus both displacements (no push-out).
pub(super) fn assemble(body_points: &[Vec3], pred: &Prediction) -> Vec<Vec3> {
    body_points
        .iter()
        .zip(pred.d_fitting.iter().zip(&pred.d_local))
        .map(|(b, (f, l))| b + (f + l))
        .collect()
}

/// Every how many samples of `len` to polish so that at most `wanted` are; `None` for none.
pub(super) fn polish_stride(len: usize, wanted: usize) -> Option<usize> {
    (wanted > 0 && len > 0).then(|| len.div_ceil(wanted))
}

/// The Newton iterations the ground truth's solver recorded for `key` (0 if unrecorded).
pub(super) fn truth_iterations(data: &TrainingDataset, key: SampleKey) -> u64 {
    let records = data.records();
    records
        .binary_search_by_key(&(key.material, key.pose), |r| (r.material, r.pose))
        .map_or(0, |i| records[i].stats.iterations)
}

/// Push-out statistics, accumulated sample by sample.
#[derive(Default)]
pub(super) struct PenetrationAccumulator {
    samples: usize,
    inside_before: f64,
    inside_after: f64,
    max_before: f64,
    max_after: f64,
    error_after: f64,
    vertices: usize,
}

impl PenetrationAccumulator {
    pub(super) fn add(
        &mut self,
        garment: &mut [Vec3],
        simulated: &[Vec3],
        body: &(dyn SignedDistance + Sync),
        epsilon: f64,
    ) {
        let depths = |g: &[Vec3]| -> (usize, f64) {
            g.iter().fold((0, 0.0f64), |(count, deepest), v| {
                let d = body.distance(v);
                if d < 0.0 {
                    (count + 1, deepest.max(-d))
                } else {
                    (count, deepest)
                }
            })
        };
        let n = garment.len().max(1) as f64;
        let (inside, deepest) = depths(garment);
        self.inside_before += inside as f64 / n;
        self.max_before = self.max_before.max(deepest);
        let _ = push_out(garment, body, epsilon);
        let (inside, deepest) = depths(garment);
        self.inside_after += inside as f64 / n;
        self.max_after = self.max_after.max(deepest);
        self.error_after += garment
            .iter()
            .zip(simulated)
            .map(|(g, s)| (g - s).norm())
            .sum::<f64>();
        self.vertices += garment.len();
        self.samples += 1;
    }

    pub(super) fn finish(&self, epsilon: f64) -> PenetrationStats {
        let s = self.samples.max(1) as f64;
        PenetrationStats {
            epsilon_mm: epsilon * 1e3,
            inside_fraction_before: self.inside_before / s,
            inside_fraction_after: self.inside_after / s,
            max_depth_before_mm: self.max_before * 1e3,
            max_depth_after_mm: self.max_after * 1e3,
            whole_mm_after: 1e3 * self.error_after / self.vertices.max(1) as f64,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mirror_asymmetry_is_zero_for_a_mirror_image_and_twice_a_sideways_shift() {
        // Two vertices, each other's twin, mirror images of each other.
        let twins = MirrorMap::from_twins(&[1, 0]).unwrap();
        let symmetric = [Vec3::new(-0.1, 1.0, 0.05), Vec3::new(0.1, 1.0, 0.05)];
        let shifted: Vec<Vec3> = symmetric
            .iter()
            .map(|p| p + Vec3::new(0.003, 0.0, 0.0))
            .collect();
        let mut acc = SymmetryAccumulator::default();
        assert!(SymmetryAccumulator::default().finish().is_none());
        acc.add(&twins, &shifted, &symmetric);
        acc.add(&twins, &symmetric, &symmetric);
        let m = acc.finish().unwrap();
        assert_eq!(m.samples, 2);
        assert!((m.prediction_max_mm - 6.0).abs() < 1e-9, "{m:?}");
        assert!((m.prediction_mean_mm - 3.0).abs() < 1e-9, "{m:?}");
        assert!(m.truth_mean_mm.abs() < 1e-12 && m.truth_max_mm.abs() < 1e-12);
    }
}
