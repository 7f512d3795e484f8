//! How much a fabric calibration ([`garmatnet_model::FabricCalibration`]) helps, measured on a
//! dataset's own drapes: each fabric is calibrated with its drapes at a few reference poses,
//! and the calibrated and uncalibrated predictions are held against its drapes at every
//! other pose.

use garmatnet_core::{Material, Real};
use garmatnet_model::{CalibrationSettings, Detail, Predictor, ReferenceDrape};
use serde::{Deserialize, Serialize};

use crate::data::loader::{SampleKey, TrainingDataset};
use crate::error::{Error, Result};
use garmatnet_core::vertex_errors_mm;

/// One fabric's errors in a [`CalibrationEval`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationRow {
    /// The fabric's name in the dataset.
    pub material: String,
    /// The model's training fabric nearest in normalised ω, and that distance (absent when
    /// the model records none).
    pub nearest_training: Option<(String, Real)>,
    /// How many poses were predicted (the finished test poses).
    pub poses: usize,
    /// Mean per-vertex error of the uncalibrated nets over those poses (mm).
    pub uncalibrated_mm: Real,
    /// The same for the calibrated nets, one per ridge weight of [`CalibrationEval::ridges`].
    pub calibrated_mm: Vec<Real>,
    /// The uncalibrated error at the reference poses (mm).
    pub reference_mm: Real,
    /// The calibrated error at the reference poses, per ridge weight (mm): a fit, not a test.
    pub calibrated_reference_mm: Vec<Real>,
}

/// [`evaluate_calibration`]'s result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CalibrationEval {
    /// The dataset's pose indices each fabric was calibrated at.
    pub reference_poses: Vec<usize>,
    /// The ridge weights tried.
    pub ridges: Vec<Real>,
    /// One row per fabric with every reference drape finished, in the dataset's order.
    pub rows: Vec<CalibrationRow>,
    /// The rows' mean of [`CalibrationRow::uncalibrated_mm`].
    pub mean_uncalibrated_mm: Real,
    /// The rows' mean of [`CalibrationRow::calibrated_mm`], per ridge weight.
    pub mean_calibrated_mm: Vec<Real>,
}

/// Calibrates every fabric of `data` with its drapes at `reference_poses` (once per ridge
/// weight in `ridges`) and measures the mean per-vertex error of the full prediction, before
/// push-out, at the finished poses of `test_poses` (every finished pose but the references
/// when `None`; Table 2's are the held-out frames), calibrated and not. Fabrics without
/// every reference drape finished, or without a finished test pose, are skipped.
///
/// # Errors
/// [`Error::InvalidConfig`] for no ridge weights or reference poses, a reference or test
/// pose past the dataset's poses, a test pose that is also a reference (a fit, not a test),
/// an empty list of test poses, or no fabric with its reference drapes and a test pose
/// finished; the model's errors (e.g. a model that records no training fabrics, or another
/// garment template); unreadable samples.
pub fn evaluate_calibration(
    data: &TrainingDataset,
    predictor: &Predictor,
    reference_poses: &[usize],
    ridges: &[Real],
    test_poses: Option<&[usize]>,
) -> Result<CalibrationEval> {
    if ridges.is_empty() || reference_poses.is_empty() || test_poses.is_some_and(<[_]>::is_empty) {
        return Err(Error::InvalidConfig(
            "give at least one ridge weight, one reference pose and one test pose".into(),
        ));
    }
    let spec = data.spec();
    let given_tests = test_poses.unwrap_or(&[]);
    for (what, poses) in [("reference", reference_poses), ("test", given_tests)] {
        if let Some(&past) = poses.iter().find(|&&p| p >= spec.poses.len()) {
            return Err(Error::InvalidConfig(format!(
                "{what} pose {past} is past the dataset's {} poses",
                spec.poses.len()
            )));
        }
    }
    for (what, poses) in [("reference", reference_poses), ("test", given_tests)] {
        if let Some((i, &twice)) = poses
            .iter()
            .enumerate()
            .find(|(i, p)| poses[..*i].contains(p))
        {
            return Err(Error::InvalidConfig(format!(
                "{what} pose {twice} is listed twice (entry {i}): a pose counted twice would \
                 weigh twice in the fit or the mean; list each once"
            )));
        }
    }
    if let Some(&both) = given_tests.iter().find(|p| reference_poses.contains(p)) {
        return Err(Error::InvalidConfig(format!(
            "pose {both} is both a reference and a test pose: the calibration is fitted there, \
             so measure it at other poses"
        )));
    }
    let mut rows = Vec::new();
    for (m, material) in spec.materials.iter().enumerate() {
        let finished: Vec<usize> = data
            .records()
            .iter()
            .filter(|r| r.material == m)
            .map(|r| r.pose)
            .collect();
        let tested: Vec<usize> = finished
            .iter()
            .copied()
            .filter(|p| {
                !reference_poses.contains(p) && test_poses.is_none_or(|test| test.contains(p))
            })
            .collect();
        if tested.is_empty() || !reference_poses.iter().all(|p| finished.contains(p)) {
            continue;
        }
        let fabric = Material::from_array(material.omega)?;
        let references = reference_poses
            .iter()
            .map(|&pose| {
                let truth = data.truth(SampleKey { material: m, pose })?;
                Ok(ReferenceDrape {
                    pose: spec.poses[pose].clone(),
                    vertices: truth.simulated,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let calibrations = ridges
            .iter()
            .map(|&ridge| {
                predictor.calibrate(
                    &material.name,
                    &fabric,
                    &references,
                    &CalibrationSettings { ridge },
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        let omega = material.omega_normalized;
        let mut uncalibrated = 0.0;
        let mut calibrated = vec![0.0; ridges.len()];
        for &p in &tested {
            let truth = data.truth(SampleKey {
                material: m,
                pose: p,
            })?;
            let pose = &spec.poses[p];
            let plain = predictor.predict_batch(&[(pose.clone(), omega)], Detail::Full)?;
            uncalibrated += mean(&vertex_errors_mm(&plain[0].vertices, &truth.simulated)?);
            for (sum, calibration) in calibrated.iter_mut().zip(&calibrations) {
                let mesh = predictor.predict_calibrated(pose, calibration, Detail::Full)?;
                *sum += mean(&vertex_errors_mm(&mesh.vertices, &truth.simulated)?);
            }
        }
        let count = tested.len() as Real;
        rows.push(CalibrationRow {
            material: material.name.clone(),
            nearest_training: predictor
                .nearest_training_fabric(&fabric)
                .map(|(f, d)| (f.name.clone(), d)),
            poses: tested.len(),
            uncalibrated_mm: uncalibrated / count,
            calibrated_mm: calibrated.iter().map(|s| s / count).collect(),
            reference_mm: calibrations[0].reference_error_mm,
            calibrated_reference_mm: calibrations
                .iter()
                .map(|c| c.calibrated_reference_error_mm)
                .collect(),
        });
    }
    if rows.is_empty() {
        return Err(Error::InvalidConfig(format!(
            "no fabric of the dataset has finished drapes at reference poses \
             {reference_poses:?} and at a test pose"
        )));
    }
    let mean_uncalibrated_mm = mean(&rows.iter().map(|r| r.uncalibrated_mm).collect::<Vec<_>>());
    let mean_calibrated_mm = (0..ridges.len())
        .map(|k| mean(&rows.iter().map(|r| r.calibrated_mm[k]).collect::<Vec<_>>()))
        .collect();
    Ok(CalibrationEval {
        reference_poses: reference_poses.to_vec(),
        ridges: ridges.to_vec(),
        rows,
        mean_uncalibrated_mm,
        mean_calibrated_mm,
    })
}

fn mean(values: &[Real]) -> Real {
    values.iter().sum::<Real>() / values.len().max(1) as Real
}
