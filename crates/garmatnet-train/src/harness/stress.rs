//! Numerical stress of a trained predictor: many random valid (pose, material) pairs, each
//! checked for non-finite output and for vertices far from the body. `garmatnet stress`
//! runs it on a model file; the test suite runs it on small and shipped models.

use std::time::Instant;

use garmatnet_core::{JointLimits, MATERIAL_DIM, Pose, Real, SignedDistance, SplitMix64};
use garmatnet_model::{Detail, Predictor};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// The distance from the body surface beyond which a predicted vertex counts as broken
/// (metres): a T-shirt never hangs a metre away from its wearer.
pub const FAR_FROM_BODY: Real = 1.0;

/// What [`stress_predictor`] found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StressReport {
    /// Predictions made.
    pub predictions: usize,
    /// The largest distance of any vertex from the posed body surface (metres).
    pub max_body_distance_m: Real,
    /// Predictions with a vertex farther than [`FAR_FROM_BODY`] from the body.
    pub far_predictions: usize,
    /// The first such prediction: its pose and normalised material, to reproduce it.
    pub first_far: Option<(Pose, [Real; MATERIAL_DIM])>,
    /// Wall-clock seconds.
    pub seconds: Real,
}

impl StressReport {
    /// Whether every prediction was finite and near the body.
    #[must_use]
    pub fn passed(&self) -> bool {
        self.far_predictions == 0
    }
}

/// The largest batch [`stress_predictor`] takes: 4,096 garments, ~200 MB at paper resolution
/// (twice the nets' activations with mirror averaging on).
pub const MAX_STRESS_BATCH: usize = 4096;

/// Predicts `count` random pairs, seeded: poses uniformly within the joint limits (the whole
/// admissible range, [`JointLimits::sample`] at amplitude 1), materials uniform in the
/// normalised ω cube, both nets (`Detail::Full`), in batches of `batch`.
///
/// # Errors
/// [`Error::InvalidConfig`] for a batch outside 1 to [`MAX_STRESS_BATCH`]; [`garmatnet_model::Error::NonFiniteOutput`]
/// (naming the batch item) at the first NaN or infinite output; `predictor` must have been
/// built with a body ([`Predictor::for_garment`]), or [`Error::InvalidConfig`].
pub fn stress_predictor(
    predictor: &Predictor,
    count: usize,
    seed: u64,
    batch: usize,
) -> Result<StressReport> {
    if !(1..=MAX_STRESS_BATCH).contains(&batch) {
        return Err(Error::InvalidConfig(format!(
            "stress batch = {batch} must lie in [1, {MAX_STRESS_BATCH}] (a batch's garments \
             are held at once; throughput stops growing long before)"
        )));
    }
    let body = predictor.body().ok_or_else(|| {
        Error::InvalidConfig(
            "the stress test needs a predictor built with a body (Predictor::for_garment)".into(),
        )
    })?;
    let started = Instant::now();
    let limits = JointLimits::default();
    let mut rng = SplitMix64::new(seed);
    let mut report = StressReport {
        predictions: 0,
        max_body_distance_m: 0.0,
        far_predictions: 0,
        first_far: None,
        seconds: 0.0,
    };
    let mut done = 0;
    while done < count {
        let size = batch.min(count - done);
        let items: Vec<(Pose, [Real; MATERIAL_DIM])> = (0..size)
            .map(|_| {
                let pose = limits.sample(&mut rng, 1.0);
                let omega = std::array::from_fn(|_| rng.next_f64());
                (pose, omega)
            })
            .collect();
        let meshes = predictor.predict_batch(&items, Detail::Full)?;
        for ((pose, omega), mesh) in items.iter().zip(&meshes) {
            let posed = body.pose(pose);
            let far = mesh
                .vertices
                .iter()
                .map(|v| posed.distance(v))
                .fold(0.0, Real::max);
            report.max_body_distance_m = report.max_body_distance_m.max(far);
            if far > FAR_FROM_BODY {
                report.far_predictions += 1;
                report
                    .first_far
                    .get_or_insert_with(|| (pose.clone(), *omega));
            }
        }
        done += size;
        report.predictions = done;
    }
    report.seconds = started.elapsed().as_secs_f64();
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use garmatnet_core::{CapsuleBody, Garment, Resolution, TemplateInfo};
    use garmatnet_model::{GarMatNetConfig, GarMatNetModel, OutputNormalizer, select_device};

    /// An untrained coarse model whose outputs are scaled to `std_m` metres.
    fn predictor(std_m: Real) -> Predictor {
        let device = select_device("cpu").unwrap();
        let body = CapsuleBody::smpl_neutral();
        let garment = Garment::tshirt(Resolution::Coarse, &body).unwrap();
        let config = GarMatNetConfig::new(garment.vertex_count(), 16, 8, 16);
        let mut model = GarMatNetModel::untrained(&config, TemplateInfo::of(&garment), &device);
        let dim = 3 * garment.vertex_count();
        let norm = OutputNormalizer::from_parts(vec![0.0; dim], vec![std_m; dim]).unwrap();
        model.fitting_norm = norm.clone();
        model.local_norm = norm;
        Predictor::for_garment(model, &garment, body, &device).unwrap()
    }

    #[test]
    fn displacements_of_trained_magnitude_stay_near_the_body() {
        // Untrained nets draw their weights from Burn's global random state at first use.
        let _serial = crate::test_util::training_lock();
        // Trained displacements spread by centimetres around the body.
        let report = stress_predictor(&predictor(0.02), 100, 7, 32).unwrap();
        assert_eq!(report.predictions, 100);
        assert!(report.passed(), "{report:?}");
        assert!(report.max_body_distance_m > 0.0);
        assert!(stress_predictor(&predictor(0.02), 1, 7, 0).is_err());
    }

    #[test]
    fn a_model_that_throws_vertices_away_is_caught() {
        let _serial = crate::test_util::training_lock();
        let report = stress_predictor(&predictor(5.0), 10, 7, 4).unwrap();
        assert!(!report.passed());
        assert!(report.first_far.is_some() && report.max_body_distance_m > FAR_FROM_BODY);
    }
}
