//! A model's predictions of dataset samples and their per-vertex errors: the numbers behind
//! evaluation's tables, the figures and the bench harness.

use std::path::Path;

use burn::prelude::*;
use garmatnet_core::{DisplacementFrame, MATERIAL_DIM, POSE_DIM, Vec3, decompose};
use garmatnet_model::{GarMatNetModel, OutputNormalizer, Predictor};

use crate::data::files::split_path;
use crate::data::loader::{SampleKey, SampleTruth, TrainingDataset};
use crate::data::split::Split;
use crate::error::{Error, Result};
use crate::evaluation::report::{ErrorStats, PartErrors, spread_mm};

/// Per-vertex errors (metres) of one prediction.
#[derive(Clone)]
pub(crate) struct VertexErrors {
    pub(crate) fitting: Vec<f64>,
    pub(crate) local: Vec<f64>,
    pub(crate) whole: Vec<f64>,
}

impl VertexErrors {
    pub(crate) fn means_mm(&self) -> PartErrors {
        let mean = |v: &[f64]| 1e3 * v.iter().sum::<f64>() / v.len().max(1) as f64;
        PartErrors {
            fitting_mm: mean(&self.fitting),
            local_mm: mean(&self.local),
            whole_mm: mean(&self.whole),
        }
    }
}

/// A prediction: world-frame displacements (metres) per vertex.
pub(crate) struct Prediction {
    pub(crate) d_fitting: Vec<Vec3>,
    pub(crate) d_local: Vec<Vec3>,
}

/// Another sample's true drape, as the displacements a model would predict (core's
/// decomposition of it).
///
/// # Errors
/// As [`garmatnet_core::decompose`]: arrays of different lengths or non-finite values.
pub(crate) fn truth_as_prediction(other: &SampleTruth) -> Result<Prediction> {
    let parts = decompose(&other.simulated, &other.smoothed, &other.body_points)?;
    Ok(Prediction {
        d_fitting: parts.d_fitting,
        d_local: parts.d_local,
    })
}

pub(crate) fn load_model(
    path: &Path,
    data: &TrainingDataset,
    device: &Device,
) -> Result<GarMatNetModel> {
    let model = GarMatNetModel::load(path, device)?;
    model.ensure_template(data.template_hash(), data.vertex_count())?;
    Ok(model)
}

/// [`load_model`], for a model compared against another on `split`'s test samples: its own
/// split (checked as [`Split::read_for_model`] does) must hold out the same samples, or it
/// would be measured on some of its training data. `what` names it in the error.
///
/// # Errors
/// As [`load_model`] and [`Split::read_for_model`]; [`Error::Split`] for another test set.
pub(crate) fn load_with_same_test(
    path: &Path,
    what: &str,
    split: &Split,
    data: &TrainingDataset,
    device: &Device,
) -> Result<GarMatNetModel> {
    let model = load_model(path, data, device)?;
    let theirs = Split::read_for_model(
        path,
        &model.meta.provenance,
        data.spec(),
        data.dataset_hash(),
    )?;
    if theirs.test != split.test {
        return Err(Error::Split {
            path: split_path(path),
            message: format!(
                "{what} was trained with another test set than the model it is compared with, \
                 so some of the compared samples may be its training data; train both with \
                 the same split settings"
            ),
        });
    }
    Ok(model)
}

/// `[B, 72]` and `[B, 6]` input tensors of `keys`, at each sample's pose or, `mirrored`,
/// at its mirror image ([`garmatnet_core::Pose::mirrored`]).
fn input_tensors(
    data: &TrainingDataset,
    keys: &[SampleKey],
    device: &Device,
    mirrored: bool,
) -> (Tensor<2>, Tensor<2>) {
    let mut poses = Vec::with_capacity(keys.len() * POSE_DIM);
    let mut materials = Vec::with_capacity(keys.len() * MATERIAL_DIM);
    for &k in keys {
        let (p, m) = data.row_inputs(k, mirrored);
        poses.extend(p);
        materials.extend(m);
    }
    let b = keys.len();
    (
        Tensor::from_data(TensorData::new(poses, [b, POSE_DIM]), device),
        Tensor::from_data(TensorData::new(materials, [b, MATERIAL_DIM]), device),
    )
}

fn to_f32(t: Tensor<2>) -> Vec<f32> {
    t.into_data()
        .try_into_vec_as::<f32>()
        .unwrap_or_else(|e| panic!("reading a tensor back from the device failed: {e:?}"))
}

/// Denormalised world-frame displacements of each row of `fitting` / `local` (`[B, 3n]`),
/// the nets' output at each key's pose or, `mirrored`, at its mirror image.
fn assemble(
    data: &TrainingDataset,
    keys: &[SampleKey],
    (fitting, local): (&[f32], &[f32]),
    norms: (&OutputNormalizer, &OutputNormalizer),
    frame: DisplacementFrame,
    mirrored: bool,
) -> Vec<Prediction> {
    let n3 = 3 * data.vertex_count();
    keys.iter()
        .enumerate()
        .map(|(b, &key)| {
            let pose = &data.spec().poses[key.pose];
            let transforms = if mirrored {
                data.skeleton().skinning_transforms(&pose.mirrored())
            } else {
                data.skeleton().skinning_transforms(pose)
            };
            let anchors = &data.garment().anchors;
            let field = |raw: &[f32], norm: &OutputNormalizer| -> Vec<Vec3> {
                let d = norm.denormalize(&raw[b * n3..(b + 1) * n3]);
                d.chunks_exact(3)
                    .zip(anchors)
                    .map(|(c, a)| a.from_frame(&Vec3::new(c[0], c[1], c[2]), frame, &transforms))
                    .collect()
            };
            Prediction {
                d_fitting: field(fitting, norms.0),
                d_local: field(local, norms.1),
            }
        })
        .collect()
}

/// Whether predictions are mirror-averaged as [`garmatnet_model::Predictor`]'s are
/// (`Predictor::with_mirror_averaging`): `Some` with the template's mirror twins.
pub(crate) type Mirror<'a> = Option<&'a [u32]>;

/// The mirror twins of `data`'s template when `on`.
pub(crate) fn mirror_of(data: &TrainingDataset, on: bool) -> Mirror<'_> {
    on.then(|| data.garment().mirror_twins())
}

/// A predictor (no body, so no push-out) for `model` on `data`'s template, mirror-averaging
/// when `mirror` holds twins, as eval's own predictions do.
pub(crate) fn predictor_for(
    model: &GarMatNetModel,
    data: &TrainingDataset,
    device: &Device,
    mirror: Mirror<'_>,
) -> Result<Predictor> {
    let predictor = Predictor::new(
        model.clone(),
        data.garment().rest.faces.clone(),
        data.garment().anchors.clone(),
        data.template_hash(),
        data.skeleton().clone(),
        device,
    )?;
    Ok(match mirror {
        Some(twins) => predictor.with_mirror_twins(twins)?,
        None => predictor,
    })
}

/// GarMatNet's predictions of `keys`, mirror-averaged when `mirror` holds twins.
pub(crate) fn predict_garmatnet(
    model: &GarMatNetModel,
    data: &TrainingDataset,
    keys: &[SampleKey],
    device: &Device,
    mirror: Mirror<'_>,
) -> Result<Vec<Prediction>> {
    let run = |mirrored: bool| {
        let (p, m) = input_tensors(data, keys, device, mirrored);
        let fitting = to_f32(model.fitting.forward(p.clone(), m.clone()));
        let local = to_f32(model.local.forward(p, m));
        assemble(
            data,
            keys,
            (&fitting, &local),
            (&model.fitting_norm, &model.local_norm),
            model.displacement_frame(),
            mirrored,
        )
    };
    Ok(mirror_averaged(run(false), mirror, || run(true)))
}

/// The baseline's predictions of `keys`, mirror-averaged when `mirror` holds twins.
pub(crate) fn predict_baseline(
    m: &crate::training::baseline::BaselineMaterial,
    data: &TrainingDataset,
    keys: &[SampleKey],
    device: &Device,
    mirror: Mirror<'_>,
) -> Result<Vec<Prediction>> {
    let run = |mirrored: bool| {
        let (p, _) = input_tensors(data, keys, device, mirrored);
        let fitting = to_f32(m.fitting.forward(p.clone()));
        let local = to_f32(m.local.forward(p));
        assemble(
            data,
            keys,
            (&fitting, &local),
            (&m.fitting_norm, &m.local_norm),
            DisplacementFrame::World,
            mirrored,
        )
    };
    Ok(mirror_averaged(run(false), mirror, || run(true)))
}

/// `own`, or with twins its mean with the mirror image of `mirrored()`, the predictions at
/// the mirrored poses: each vertex's displacement becomes the mean of its own and its twin's
/// reflected (x → −x), as `Predictor::with_mirror_averaging` makes them.
fn mirror_averaged(
    own: Vec<Prediction>,
    mirror: Mirror<'_>,
    mirrored: impl FnOnce() -> Vec<Prediction>,
) -> Vec<Prediction> {
    let Some(twins) = mirror else {
        return own;
    };
    let fold = |d: &[Vec3], other: &[Vec3]| -> Vec<Vec3> {
        d.iter()
            .zip(twins)
            .map(|(di, &t)| {
                let e = other[t as usize];
                0.5 * (di + Vec3::new(-e.x, e.y, e.z))
            })
            .collect()
    };
    own.into_iter()
        .zip(mirrored())
        .map(|(a, b)| Prediction {
            d_fitting: fold(&a.d_fitting, &b.d_fitting),
            d_local: fold(&a.d_local, &b.d_local),
        })
        .collect()
}

/// Per-vertex errors (metres) of a prediction against the truth.
pub(crate) fn vertex_errors(truth: &SampleTruth, pred: &Prediction) -> VertexErrors {
    let n = truth.body_points.len();
    let mut e = VertexErrors {
        fitting: Vec::with_capacity(n),
        local: Vec::with_capacity(n),
        whole: Vec::with_capacity(n),
    };
    for i in 0..n {
        let body = truth.body_points[i];
        let smooth = body + pred.d_fitting[i];
        let garment = body + (pred.d_fitting[i] + pred.d_local[i]);
        let true_local = truth.simulated[i] - truth.smoothed[i];
        e.fitting.push((smooth - truth.smoothed[i]).norm());
        e.local.push((pred.d_local[i] - true_local).norm());
        e.whole.push((garment - truth.simulated[i]).norm());
    }
    e
}

pub(crate) fn error_stats<'a>(errors: impl Iterator<Item = &'a VertexErrors>) -> ErrorStats {
    let (mut fitting, mut local, mut whole) = (0.0, 0.0, Vec::new());
    let mut samples = 0;
    let mut vertices = 0usize;
    for e in errors {
        samples += 1;
        vertices += e.whole.len();
        fitting += e.fitting.iter().sum::<f64>();
        local += e.local.iter().sum::<f64>();
        whole.extend_from_slice(&e.whole);
    }
    let (whole_mm, whole_p95_mm, whole_max_mm) = spread_mm(&mut whole);
    let v = vertices.max(1) as f64;
    ErrorStats {
        fitting_mm: 1e3 * fitting / v,
        local_mm: 1e3 * local / v,
        whole_mm,
        whole_max_mm,
        whole_p95_mm,
        samples,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::synthetic_dataset;
    use garmatnet_core::TemplateInfo;
    use garmatnet_model::{Detail, GarMatNetConfig, select_device};

    #[test]
    fn eval_averages_the_mirror_as_the_predictor_does() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("data");
        synthetic_dataset(&path, 2, 3);
        let data = TrainingDataset::open(&path, false).unwrap();
        let device = select_device("cpu").unwrap();
        let keys = data.keys();
        for frame in [DisplacementFrame::World, DisplacementFrame::Canonical] {
            let mut config = GarMatNetConfig::new(data.vertex_count(), 8, 4, 8);
            config.displacement_frame = frame;
            let model =
                GarMatNetModel::untrained(&config, TemplateInfo::of(data.garment()), &device);
            let predictor = predictor_for(&model, &data, &device, mirror_of(&data, true)).unwrap();
            let averaged = predict_garmatnet(&model, &data, &keys, &device, mirror_of(&data, true));
            let raw = predict_garmatnet(&model, &data, &keys, &device, mirror_of(&data, false));
            let (averaged, raw) = (averaged.unwrap(), raw.unwrap());
            for ((key, pred), raw) in keys.iter().zip(&averaged).zip(&raw) {
                let pose = &data.spec().poses[key.pose];
                let omega = data.spec().materials[key.material].omega_normalized;
                let mesh = predictor
                    .predict_normalized(pose, &omega, Detail::Full)
                    .unwrap();
                let body = predictor.body_points(pose);
                let garment = |p: &Prediction, i: usize| body[i] + p.d_fitting[i] + p.d_local[i];
                let mut moved = 0.0f64;
                for (i, v) in mesh.vertices.iter().enumerate() {
                    let gap = (garment(pred, i) - v).norm();
                    assert!(
                        gap < 1e-5 * v.norm().max(1.0),
                        "{frame:?} {key:?} {i}: {gap}"
                    );
                    moved = moved.max((garment(raw, i) - v).norm());
                }
                assert!(
                    moved > 1e-3,
                    "{frame:?}: averaging changed nothing ({moved} m)"
                );
            }
        }
    }
}
