//! Shared helpers for this crate's unit tests: the CPU device, random inputs, a small model.

use burn::module::{ModuleMapper, Param};
use burn::prelude::*;
use garmatnet_core::{BodyAnchor, POSE_DIM, SplitMix64, Vec3};

use crate::file::model_file::{GarMatNetModel, ModelMeta};
use crate::net::garmatnet_net::{GarMatNetConfig, MATERIAL_DIM};
use crate::net::output_normalizer::OutputNormalizer;
use crate::net::tensor_util::matrix;
use crate::predict::predictor::Predictor;
use garmatnet_core::TemplateInfo;

/// Tests run on the pure-Rust CPU backend, whatever features are compiled in.
pub(crate) fn cpu() -> Device {
    Device::flex()
}

pub(crate) fn to_vec<const D: usize>(t: Tensor<D>) -> Vec<f32> {
    crate::net::tensor_util::to_f32(t)
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

/// A small untrained model (n = 50, hidden 32) with non-trivial normalisers. Its weights
/// depend on `seed` alone: Burn's random state is global to the process and parallel tests
/// draw from it (lazily, at a parameter's first use), so the same seed would not always give
/// the same net if the weights came from it. Drawn here instead ([`Reseed`]) with the
/// distributions [`GarMatNetConfig::init`] uses.
pub(crate) fn small_model(seed: u64, rank: Option<usize>, dev: &Device) -> GarMatNetModel {
    let cfg = GarMatNetConfig::new(TEST_VERTICES, 32, 16, 32).with_output_rank(rank);
    let mut weights = Reseed::new(seed, cfg.init_gain);
    let fitting = cfg.init(dev).map(&mut weights);
    let local = cfg.init(dev).map(&mut weights);
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
        fitting,
        local,
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

/// Replaces every matrix of a module with draws from its own seeded generator: He-normal
/// (`gain / sqrt(fan_in)`, `fan_in` the first dimension) with the hidden layers' gain, and
/// gain 1 for the output layer and the low-rank basis, as [`GarMatNetConfig::init`] draws
/// them. Vectors (biases, the basis mean) stay as initialised: zeros.
pub(crate) struct Reseed {
    rng: SplitMix64,
    hidden_gain: f64,
    module: String,
}

impl Reseed {
    pub(crate) fn new(seed: u64, hidden_gain: f64) -> Self {
        Self {
            rng: SplitMix64::new(seed ^ 0x5eed),
            hidden_gain,
            module: String::new(),
        }
    }
}

impl ModuleMapper for Reseed {
    fn enter_module(&mut self, name: &str, _container_type: &str) {
        self.module = name.to_owned();
    }

    fn exit_module(&mut self, _name: &str, _container_type: &str) {
        self.module.clear();
    }

    fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
        if D != 2 {
            return param;
        }
        let gain = match self.module.as_str() {
            "pose_in" | "material_in" | "merge" => self.hidden_gain,
            _ => 1.0,
        };
        param.map(|t| {
            let (shape, device) = (t.shape(), t.device());
            let std = gain / (shape[0] as f64).sqrt();
            let values: Vec<f32> = (0..shape.num_elements())
                .map(|_| (std * self.rng.normal()) as f32)
                .collect();
            Tensor::from_data(TensorData::new(values, shape), &device)
        })
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

/// Mirror twins for the test template: vertices 2k and 2k + 1 are each other's twins (the
/// anchors are not mirror images, but averaging needs only a pairing).
pub(crate) fn test_twins() -> Vec<u32> {
    (0..TEST_VERTICES as u32).map(|i| i ^ 1).collect()
}

/// A predictor over [`small_model`] of `seed`, both nets predicting in `frame`.
pub(crate) fn small_predictor(seed: u64, frame: garmatnet_core::DisplacementFrame) -> Predictor {
    let dev = cpu();
    let mut model = small_model(seed, None, &dev);
    for net in [&mut model.fitting, &mut model.local] {
        net.config.displacement_frame = frame;
    }
    test_predictor(model, &dev)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_seed_gives_the_same_small_model_while_other_threads_draw_from_burn() {
        let dev = cpu();
        let stop = std::sync::atomic::AtomicBool::new(false);
        let (pose, material) = random_inputs(4, 1, &dev);
        let outputs =
            |m: &GarMatNetModel| to_vec(m.fitting.forward(pose.clone(), material.clone()));
        let pairs = std::thread::scope(|scope| {
            // Another test, say, initialising nets as fast as it can.
            scope.spawn(|| {
                while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                    let net = GarMatNetConfig::new(TEST_VERTICES, 8, 4, 8).init(&cpu());
                    let (p, m) = random_inputs(1, 2, &cpu());
                    let _ = net.forward(p, m);
                }
            });
            let pairs: Vec<_> = (1..=8)
                .map(|seed| {
                    let a = outputs(&small_model(seed, None, &dev));
                    (a, outputs(&small_model(seed, None, &dev)))
                })
                .collect();
            stop.store(true, std::sync::atomic::Ordering::Relaxed);
            pairs
        });
        for (a, b) in pairs {
            assert_eq!(a, b);
        }
        assert_ne!(
            outputs(&small_model(3, Some(8), &dev)),
            outputs(&small_model(4, Some(8), &dev))
        );
    }
}
