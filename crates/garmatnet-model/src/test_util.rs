//! Shared helpers for this crate's unit tests: the CPU device, random inputs, a small model.

use burn::prelude::*;
use garmatnet_core::{BodyAnchor, POSE_DIM, SplitMix64, Vec3};

use crate::garmatnet_net::{GarMatNetConfig, MATERIAL_DIM};
use crate::model_file::{GarMatNetModel, ModelMeta, TemplateInfo};
use crate::output_normalizer::OutputNormalizer;
use crate::predictor::Predictor;
use crate::tensor_util::matrix;

/// Tests run on the pure-Rust CPU backend, whatever features are compiled in.
pub(crate) fn cpu() -> Device {
    Device::flex()
}

pub(crate) fn to_vec<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    crate::tensor_util::to_f32(t)
}

/// `b` random poses (±0.5 rad) and materials in [0, 1].
pub(crate) fn random_inputs(b: usize, seed: u64, dev: &Device) -> (Tensor<2>, Tensor<2>) {
    let mut rng = SplitMix64::new(seed);
    let p = (0..b * POSE_DIM)
        .map(|_| rng.uniform(-0.5, 0.5) as f32)
        .collect();
    let m = (0..b * MATERIAL_DIM)
        .map(|_| rng.next_f64() as f32)
        .collect();
    (matrix(p, b, POSE_DIM, dev), matrix(m, b, MATERIAL_DIM, dev))
}

pub(crate) const TEST_VERTICES: usize = 50;

/// A small untrained model (n = 50, hidden 32) with non-trivial normalisers.
pub(crate) fn small_model(seed: u64, rank: Option<usize>, dev: &Device) -> GarMatNetModel {
    dev.seed(seed);
    let cfg = GarMatNetConfig::new(TEST_VERTICES, 32, 16, 32).with_output_rank(rank);
    let mut rng = SplitMix64::new(seed);
    let mut norm = || {
        let mean = (0..3 * TEST_VERTICES)
            .map(|_| rng.uniform(-0.05, 0.05))
            .collect();
        let std = (0..3 * TEST_VERTICES)
            .map(|_| rng.uniform(0.001, 0.02))
            .collect();
        OutputNormalizer::from_parts(mean, std).unwrap()
    };
    let (fitting_norm, local_norm) = (norm(), norm());
    GarMatNetModel {
        fitting: cfg.init(dev),
        local: cfg.init(dev),
        fitting_norm,
        local_norm,
        meta: ModelMeta {
            template: TemplateInfo {
                hash: "test-template".into(),
                resolution: garmatnet_core::Resolution::Coarse,
                vertex_count: TEST_VERTICES,
            },
            provenance: Default::default(),
        },
    }
}

/// Anchors on a ring around the spine, skinned to the spine and shoulders.
pub(crate) fn test_anchors() -> Vec<BodyAnchor> {
    (0..TEST_VERTICES)
        .map(|i| {
            let a = i as f64 / TEST_VERTICES as f64 * std::f64::consts::TAU;
            BodyAnchor {
                rest_point: Vec3::new(0.15 * a.cos(), 0.2 + 0.1 * (i % 5) as f64, 0.1 * a.sin()),
                weights: vec![
                    (3, 0.5),
                    (6, 0.3),
                    (if a.cos() > 0.0 { 16 } else { 17 }, 0.2),
                ],
            }
        })
        .collect()
}

/// Faces over consecutive anchor triples (valid indices, enough for mesh checks).
pub(crate) fn test_faces() -> Vec<[u32; 3]> {
    (0..TEST_VERTICES as u32 - 2)
        .map(|i| [i, i + 1, i + 2])
        .collect()
}

/// A predictor over `model` with the test template's faces and anchors on SMPL's skeleton.
pub(crate) fn test_predictor(model: GarMatNetModel, dev: &Device) -> Predictor {
    Predictor::new(
        model,
        test_faces(),
        test_anchors(),
        "test-template",
        garmatnet_core::Skeleton::smpl_neutral(),
        dev,
    )
    .unwrap()
}
