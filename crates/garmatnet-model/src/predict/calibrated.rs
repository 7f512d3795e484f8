//! Predictions for a calibrated fabric: fitting a [`FabricCalibration`]'s weights to the
//! simulator's drapes ([`Predictor::calibrate`]) and predicting from the blend of the nets'
//! hidden activations ([`Predictor::predict_calibrated`]). The method, and why a blend of
//! hidden activations is the blend of the predictions, is in the `calibration` module's docs.

use burn::prelude::*;
use garmatnet_core::{Material, Pose, Real, Vec3, error::ensure_finite};
use nalgebra::{DMatrix, DVector};

use crate::error::{Error, Result};
use crate::net::garmatnet_net::{GarMatNet, MATERIAL_DIM};
use crate::net::tensor_util::{matrix, to_f32};
use crate::predict::calibration::{
    CALIBRATION_VERSION, CalibrationSettings, FabricCalibration, MAX_ABSOLUTE_WEIGHT_SUM,
    ReferenceDrape, WeightedFabric, mean_distance_mm,
};
use crate::predict::predictor::{Detail, GarmentMesh, Predictor, validate_inputs, validate_poses};

impl Predictor {
    /// Calibrates `material` (called `name` in the result) with `references`, the
    /// simulator's drapes of it at one or more poses: the weights of the `calibration`
    /// module's docs, fitted to every reference drape at once.
    ///
    /// Choose reference poses at which the nets are accurate, such as poses they were trained
    /// on: the weights fit the whole gap between prediction and drape there, and a gap
    /// the nets would have for any fabric (at an unusual pose) is then carried to every pose
    /// as if the fabric made it (book/src/experiments/calibration.md).
    ///
    /// # Errors
    /// [`Error::Calibration`] if the model file records no training fabrics (models trained
    /// before they were recorded) or the fitted weights' absolute values sum to more than
    /// [`MAX_ABSOLUTE_WEIGHT_SUM`] (raise the ridge weight); [`Error::EmptyInput`] for an
    /// empty name or no references; [`Error::Core`] for an invalid material, pose or
    /// settings, or a drape with the wrong vertex count or a non-finite coordinate;
    /// [`Error::NonFiniteOutput`] if the nets produce NaN.
    pub fn calibrate(
        &self,
        name: &str,
        material: &Material,
        references: &[ReferenceDrape],
        settings: &CalibrationSettings,
    ) -> Result<FabricCalibration> {
        settings.validate()?;
        material.validate()?;
        if name.trim().is_empty() {
            return Err(Error::EmptyInput {
                what: "a calibration",
                needs: "a name (the fabric's, for people); give a non-empty one",
            });
        }
        if references.is_empty() {
            return Err(Error::EmptyInput {
                what: "a calibration",
                needs: "at least one reference drape",
            });
        }
        let omega = material.to_normalized();
        let n = self.vertex_count();
        for (k, reference) in references.iter().enumerate() {
            validate_inputs(&reference.pose, &omega)?;
            if reference.vertices.len() != n {
                return Err(garmatnet_core::Error::Mismatch {
                    what: format!("reference drape {k} (one position per garment vertex)"),
                    expected: format!("{n} vertices"),
                    got: format!("{} vertices", reference.vertices.len()),
                }
                .into());
            }
            ensure_finite(
                &format!("reference drape {k}"),
                reference.vertices.iter().flat_map(|v| [v.x, v.y, v.z]),
            )?;
        }
        let fabrics = self.training_fabrics();
        if fabrics.is_empty() {
            return Err(Error::Calibration(
                "the model file records no training fabrics to blend; use a model trained \
                 with this version of garmatnet"
                    .into(),
            ));
        }
        let columns = fabrics.len();
        // Per reference: the nets' garment for the fabric's own ω, then for each training
        // fabric.
        let predicted = references
            .iter()
            .map(|reference| {
                let items: Vec<_> = std::iter::once(omega)
                    .chain(fabrics.iter().map(|f| f.omega))
                    .map(|m| (reference.pose.clone(), m))
                    .collect();
                self.predict_batch(&items, Detail::Full)
            })
            .collect::<Result<Vec<_>>>()?;
        let rows = 3 * n;
        let at = |k: usize, f: usize, row: usize| predicted[k][f].vertices[row / 3][row % 3];
        let a = DMatrix::from_fn(rows * references.len(), columns, |row, f| {
            let (k, row) = (row / rows, row % rows);
            at(k, f + 1, row) - at(k, 0, row)
        });
        let r = DVector::from_fn(rows * references.len(), |row, _| {
            let (k, row) = (row / rows, row % rows);
            references[k].vertices[row / 3][row % 3] - at(k, 0, row)
        });
        let mut gram = a.transpose() * &a;
        let scale = gram.trace() / columns as Real;
        // Training fabrics that all predict the same garment as the fabric itself leave
        // nothing to fit: keep the nets' own prediction.
        let v = if scale > 0.0 {
            for i in 0..columns {
                gram[(i, i)] += settings.ridge * scale;
            }
            let rhs = a.transpose() * r;
            gram.cholesky().map(|c| c.solve(&rhs)).ok_or_else(|| {
                Error::Calibration(
                    "the blend's normal equations are not positive definite; raise the ridge \
                     weight"
                        .into(),
                )
            })?
        } else {
            DVector::zeros(columns)
        };
        let own_weight = 1.0 - v.sum();
        let absolute = own_weight.abs() + v.iter().map(|w| w.abs()).sum::<Real>();
        // `check_for` would refuse such weights in every use of the calibration.
        if !absolute.is_finite() || absolute > MAX_ABSOLUTE_WEIGHT_SUM {
            return Err(Error::Calibration(format!(
                "the fitted weights' absolute values sum to {absolute}, above \
                 {MAX_ABSOLUTE_WEIGHT_SUM}: the blend cancels large multiples of nearly equal \
                 predictions; raise the ridge weight (now {})",
                settings.ridge
            )));
        }
        let mut before = 0.0;
        let mut after = 0.0;
        for (reference, predicted) in references.iter().zip(&predicted) {
            let own = &predicted[0].vertices;
            let blended: Vec<Vec3> = (0..n)
                .map(|i| {
                    let mut x = own[i];
                    for (f, p) in predicted[1..].iter().enumerate() {
                        x += v[f] * (p.vertices[i] - own[i]);
                    }
                    x
                })
                .collect();
            before += mean_distance_mm(own, &reference.vertices);
            after += mean_distance_mm(&blended, &reference.vertices);
        }
        let count = references.len() as Real;
        let training = fabrics
            .iter()
            .zip(v.iter())
            .map(|(fabric, &weight)| WeightedFabric {
                fabric: fabric.clone(),
                weight,
            })
            .collect();
        Ok(FabricCalibration {
            version: CALIBRATION_VERSION,
            name: name.to_owned(),
            omega,
            own_weight,
            training,
            template_hash: self.model().meta.template.hash.clone(),
            model_fingerprint: Some(self.model_fingerprint().to_owned()),
            mirror_averaging: self.mirror_averaging(),
            settings: *settings,
            references: references.len(),
            reference_error_mm: before / count,
            calibrated_reference_error_mm: after / count,
        })
    }

    /// Predicts the garment at `pose` for a calibrated fabric, pushed out of the body as
    /// [`Predictor::predict`] does.
    ///
    /// # Errors
    /// [`Error::Calibration`] for a calibration made for another model
    /// ([`FabricCalibration::check_for`]); [`Error::Core`] for a non-finite pose;
    /// [`Error::NonFiniteOutput`] if the nets produce NaN.
    pub fn predict_calibrated(
        &self,
        pose: &Pose,
        calibration: &FabricCalibration,
        detail: Detail,
    ) -> Result<GarmentMesh> {
        calibration.check_for(self)?;
        pose.validate()?;
        let mut meshes = self.calibrated_meshes(std::slice::from_ref(pose), calibration, detail)?;
        Ok(meshes.remove(0))
    }

    /// Predicts the garments at each of `poses` for a calibrated fabric, each pushed out of
    /// its posed body as [`Predictor::predict`] does.
    ///
    /// # Errors
    /// As [`Predictor::predict_calibrated`], except that the first unusable pose is
    /// [`Error::InvalidPose`] (with its index), refused before any prediction.
    pub fn predict_calibrated_sequence(
        &self,
        poses: &[Pose],
        calibration: &FabricCalibration,
        detail: Detail,
    ) -> Result<Vec<GarmentMesh>> {
        calibration.check_for(self)?;
        validate_poses(poses)?;
        self.calibrated_meshes(poses, calibration, detail)
    }

    /// [`Predictor::predict_calibrated_sequence`] for a checked calibration and validated
    /// poses, a batch at a time.
    fn calibrated_meshes(
        &self,
        poses: &[Pose],
        calibration: &FabricCalibration,
        detail: Detail,
    ) -> Result<Vec<GarmentMesh>> {
        let mut out = Vec::with_capacity(poses.len());
        for chunk in poses.chunks(crate::predict::sequence::SEQUENCE_BATCH) {
            let meshes = self.calibrated_batch(chunk, calibration, detail)?;
            out.extend(self.pushed_out(meshes, chunk));
        }
        Ok(out)
    }

    /// The blended prediction of the `calibration` module's docs for a batch of poses,
    /// before push-out; the caller has validated the poses and the calibration.
    pub(crate) fn calibrated_batch(
        &self,
        poses: &[Pose],
        calibration: &FabricCalibration,
        detail: Detail,
    ) -> Result<Vec<GarmentMesh>> {
        // Fabrics with no weight add nothing; leaving them out saves their rows.
        let (omegas, weights): (Vec<_>, Vec<_>) = calibration
            .weights()
            .filter(|(_, w)| *w != 0.0)
            .map(|(m, w)| (*m, w))
            .unzip();
        let f = omegas.len();
        let device = self.device();
        let poses: Vec<&Pose> = poses.iter().collect();
        let mirrored = self.mirrored_poses(&poses);
        let rows: Vec<_> = poses
            .iter()
            .copied()
            .chain(&mirrored)
            .map(|p| (p, &calibration.omega))
            .collect();
        let (pose_t, _) = self.input_tensors(rows.into_iter());
        let materials = matrix(
            omegas.iter().flatten().map(|&v| v as f32).collect(),
            f,
            MATERIAL_DIM,
            device,
        );
        let weights = matrix(weights.iter().map(|&w| w as f32).collect(), f, 1, device);
        let model = self.model();
        let run = |net: &GarMatNet| {
            to_f32(blended_forward(
                net,
                pose_t.clone(),
                materials.clone(),
                weights.clone(),
            ))
        };
        let fitting = run(&model.fitting);
        let local = match detail {
            Detail::Full => Some(run(&model.local)),
            Detail::Smooth => None,
        };
        self.garments_from_rows(
            &poses,
            &mirrored,
            (&fitting, local.as_deref()),
            "calibrated pose",
        )
    }
}

/// `net`'s normalised output for each of `B` poses from the `weights`-blend of its hidden
/// activations over `F` materials.
///
/// # Shapes
/// `pose`: `[B, 72]`, `materials`: `[F, 6]`, `weights`: `[F, 1]`; output `[B, out]`.
fn blended_forward(
    net: &GarMatNet,
    pose: Tensor<2>,
    materials: Tensor<2>,
    weights: Tensor<2>,
) -> Tensor<2> {
    let [b, _] = pose.dims();
    let [f, _] = materials.dims();
    let pose_features = net.pose_features(pose);
    let material_features = net.material_features(materials);
    let [_, p] = pose_features.dims();
    let [_, m] = material_features.dims();
    // Row (i, j) pairs pose i with material j.
    let poses = pose_features
        .reshape([b, 1, p])
        .repeat_dim(1, f)
        .reshape([b * f, p]);
    let materials = material_features
        .reshape([1, f, m])
        .repeat_dim(0, b)
        .reshape([b * f, m]);
    let hidden = net.hidden(poses, materials);
    let [_, h] = hidden.dims();
    let blended = (hidden.reshape([b, f, h]) * weights.reshape([1, f, 1]))
        .sum_dim(1)
        .reshape([b, h]);
    net.forward_all(blended)
}
