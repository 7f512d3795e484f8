//! The physics-informed loss of GarMatNet's two nets at a [`PhysicsBatch`]: the normalised
//! drape energy of their full prediction, and the decomposition term that keeps the
//! fitting net the Laplacian-smoothed part of it.

use burn::nn::loss::{MseLoss, Reduction};
use burn::prelude::*;
use garmatnet_core::{Garment, LaplacianSmoother, Real, Vec3};
use garmatnet_model::{GarMatNet, OutputNormalizer};

use crate::error::Result;
use crate::physics::batch::PhysicsBatch;

/// An [`OutputNormalizer`] as tensors, to turn a net's normalised outputs into
/// displacements (metres) and back inside the graph.
#[derive(Debug, Clone)]
pub struct NormalizerTensors {
    /// `[1, 3n]` (metres).
    mean: Tensor<2>,
    /// `[1, 3n]` (metres).
    std: Tensor<2>,
}

impl NormalizerTensors {
    /// `norm`'s mean and std on `device` (f32).
    #[must_use]
    pub fn new(norm: &OutputNormalizer, device: &Device) -> Self {
        let row = |v: &[f64]| {
            let v: Vec<f32> = v.iter().map(|&x| x as f32).collect();
            let len = v.len();
            Tensor::<2>::from_data(TensorData::new(v, [1, len]), device)
        };
        Self {
            mean: row(norm.mean()),
            std: row(norm.std()),
        }
    }

    /// Displacements (metres) from normalised outputs.
    ///
    /// # Shapes
    /// `[B, 3n]` → `[B, 3n]`.
    #[must_use]
    pub fn denormalize(&self, outputs: Tensor<2>) -> Tensor<2> {
        outputs * self.std.clone() + self.mean.clone()
    }

    /// Normalised outputs from displacements (metres).
    ///
    /// # Shapes
    /// `[B, 3n]` → `[B, 3n]`.
    #[must_use]
    pub fn normalize(&self, displacements: Tensor<2>) -> Tensor<2> {
        (displacements - self.mean.clone()) / self.std.clone()
    }
}

/// Output normalisers for nets trained without a dataset (physics-only): the fitting net's
/// mean is the rest shirt's offset from its body anchors (in the canonical frame, the
/// posed rest shirt at every pose; in the world frame, the rest shirt at the rest pose)
/// and its std `fitting_std`
/// (metres) everywhere; the local net's mean is zero and its std `local_std` (metres).
/// A net's unit output then moves a vertex by about the scale its part of a drape moves.
///
/// # Errors
/// As [`OutputNormalizer::from_parts`] for a std that is not positive and finite.
pub fn rest_offset_normalizers(
    garment: &Garment,
    fitting_std: Real,
    local_std: Real,
) -> Result<(OutputNormalizer, OutputNormalizer)> {
    let mean: Vec<Real> = garment
        .anchors
        .iter()
        .zip(&garment.rest.vertices)
        .flat_map(|(a, v)| {
            let d = v - a.rest_point;
            [d.x, d.y, d.z]
        })
        .collect();
    let dim = mean.len();
    Ok((
        OutputNormalizer::from_parts(mean, vec![fitting_std; dim])?,
        OutputNormalizer::from_parts(vec![0.0; dim], vec![local_std; dim])?,
    ))
}

/// The two nets' physics-informed loss at one batch.
#[derive(Debug, Clone)]
pub struct TwoNetPhysicsLoss {
    /// The mean normalised energy of the full prediction (metres; [`PhysicsBatch::
    /// normalised_energy`]), differentiable in both nets, `[1]`.
    pub energy: Tensor<1>,
    /// The fitting net's MSE (normalised outputs) to the Laplacian-smoothed full prediction,
    /// detached, `[1]`.
    pub decomposition: Tensor<1>,
}

impl TwoNetPhysicsLoss {
    /// The nets' physics-informed loss at `batch`: `fitting` and `local` predict (their
    /// outputs denormalised by `fitting_norm` and `local_norm`) and their sum is the full
    /// displacement; its garment's normalised energy is the physics term. The decomposition
    /// term asks the fitting net for `smoother`'s smoothing of the full garment, detached,
    /// so the fitting net stays the smooth part and the local net the detail, as the
    /// supervised labels (eqs. 4–5) split them.
    ///
    /// # Errors
    /// As [`PhysicsBatch::normalised_energy`]; as [`LaplacianSmoother::smooth`] for a
    /// non-finite prediction.
    ///
    /// # Panics
    /// If the device cannot read a tensor back (a broken device, not bad input).
    pub fn new(
        fitting: &GarMatNet,
        local: &GarMatNet,
        fitting_norm: &NormalizerTensors,
        local_norm: &NormalizerTensors,
        batch: &PhysicsBatch,
        smoother: &LaplacianSmoother,
    ) -> Result<Self> {
        let fitting_out = fitting.forward(batch.poses.clone(), batch.materials.clone());
        let local_out = local.forward(batch.poses.clone(), batch.materials.clone());
        let full =
            fitting_norm.denormalize(fitting_out.clone()) + local_norm.denormalize(local_out);
        let positions = batch.positions(full);
        let energy = batch.normalised_energy(positions.clone())?.mean();
        let [b, n, _] = positions.dims();
        let device = positions.device();
        let flat: Vec<f32> = positions
            .detach()
            .into_data()
            .try_into_vec_as::<f32>()
            .unwrap_or_else(|e| panic!("reading a tensor back from the device failed: {e:?}"));
        let mut smoothed = Vec::with_capacity(flat.len());
        for sample in flat.chunks_exact(3 * n) {
            let shape: Vec<Vec3> = sample
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0].into(), p[1].into(), p[2].into()))
                .collect();
            for v in smoother.smooth(&shape)? {
                smoothed.extend([v.x as f32, v.y as f32, v.z as f32]);
            }
        }
        let smoothed = Tensor::<3>::from_data(TensorData::new(smoothed, [b, n, 3]), &device);
        let target = fitting_norm
            .normalize(batch.displacements(smoothed))
            .detach();
        let decomposition = MseLoss::new().forward(fitting_out, target, Reduction::Mean);
        Ok(Self {
            energy,
            decomposition,
        })
    }

    /// `energy + decomposition`: the physics-only loss (a hybrid adds it, times its weight,
    /// to the supervised one).
    ///
    /// # Shapes
    /// `[1]`.
    #[must_use]
    pub fn total(&self) -> Tensor<1> {
        self.energy.clone() + self.decomposition.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer};
    use garmatnet_core::{
        CapsuleBody, DisplacementFrame, Resolution, SmoothingSettings, SplitMix64,
    };
    use garmatnet_model::GarMatNetConfig;
    use garmatnet_sim::DrapeSettings;
    use std::time::Instant;

    use crate::physics::batch::JointLimitsPoses;

    struct Toy {
        body: CapsuleBody,
        garment: Garment,
        smoother: LaplacianSmoother,
        fitting_norm: NormalizerTensors,
        local_norm: NormalizerTensors,
        ad: Device,
        /// Held while the toy lives: it seeds and draws from Burn's global random state.
        _serial: std::sync::MutexGuard<'static, ()>,
    }

    fn toy(resolution: Resolution) -> Toy {
        let serial = crate::test_util::training_lock();
        let body = CapsuleBody::smpl_neutral();
        let garment = Garment::tshirt(resolution, &body).unwrap();
        let smoother = LaplacianSmoother::new(&garment.rest, SmoothingSettings::default()).unwrap();
        let ad = Device::flex().autodiff();
        ad.seed(5);
        let (f, l) = rest_offset_normalizers(&garment, 0.02, 0.005).unwrap();
        Toy {
            fitting_norm: NormalizerTensors::new(&f, &ad),
            local_norm: NormalizerTensors::new(&l, &ad),
            body,
            garment,
            smoother,
            ad,
            _serial: serial,
        }
    }

    fn draw(t: &Toy, rng: &mut SplitMix64, size: usize) -> PhysicsBatch {
        PhysicsBatch::draw(
            &t.garment,
            &t.body,
            &DrapeSettings::default(),
            DisplacementFrame::Canonical,
            &JointLimitsPoses::default(),
            rng,
            size,
            &t.ad,
        )
        .unwrap()
    }

    fn nets(t: &Toy) -> (GarMatNet, GarMatNet) {
        let config = GarMatNetConfig::new(t.garment.vertex_count(), 32, 16, 64).with_dropout(0.0);
        (config.init(&t.ad), config.init(&t.ad))
    }

    fn scalar(t: Tensor<1>) -> f64 {
        f64::from(t.into_scalar::<f32>())
    }

    /// The toy's physics loss of `f` and `l` at `batch`.
    fn physics_loss(
        t: &Toy,
        f: &GarMatNet,
        l: &GarMatNet,
        batch: &PhysicsBatch,
    ) -> TwoNetPhysicsLoss {
        TwoNetPhysicsLoss::new(f, l, &t.fitting_norm, &t.local_norm, batch, &t.smoother).unwrap()
    }

    /// One Adam step of both nets down `loss`.
    fn step_both(
        (fitting, local): (GarMatNet, GarMatNet),
        (opt_f, opt_l): &mut (ModuleOptimizer, ModuleOptimizer),
        loss: Tensor<1>,
        learning_rate: f64,
    ) -> (GarMatNet, GarMatNet) {
        let mut grads = loss.backward();
        let (gf, gl) = (
            GradientsParams::from_module(&mut grads, &fitting),
            GradientsParams::from_module(&mut grads, &local),
        );
        (
            opt_f.step(learning_rate, fitting, gf),
            opt_l.step(learning_rate, local, gl),
        )
    }

    /// Positions and displacements are inverses, in the canonical frame too.
    #[test]
    fn positions_and_displacements_round_trip() {
        let t = toy(Resolution::Coarse);
        let batch = draw(&t, &mut SplitMix64::new(1), 2);
        let n = t.garment.vertex_count();
        let d = Tensor::<2>::random(
            [2, 3 * n],
            burn::tensor::Distribution::Normal(0.0, 0.1),
            &t.ad,
        );
        let back = batch.displacements(batch.positions(d.clone()));
        let error = scalar((back - d).abs().max().reshape([1]));
        assert!(error < 1e-5, "{error}");
    }

    /// Physics-only, a toy run: no label at all; fresh (pose, fabric) pairs every step.
    /// The energy of a held-out batch falls, nothing is NaN, and the decomposition term
    /// keeps the fitting net near the smoothed full prediction.
    #[test]
    fn a_toy_physics_only_run_lowers_the_energy_of_unseen_pairs() {
        let t = toy(Resolution::Coarse);
        let (mut fitting, mut local) = nets(&t);
        let mut rng = SplitMix64::new(2);
        let held_out = draw(&t, &mut rng, 4);
        let eval = |f: &GarMatNet, l: &GarMatNet| {
            let loss = physics_loss(&t, f, l, &held_out);
            (scalar(loss.energy), scalar(loss.decomposition))
        };
        let (before, _) = eval(&fitting, &local);
        let mut opts: (ModuleOptimizer, ModuleOptimizer) =
            (AdamConfig::new().init(), AdamConfig::new().init());
        let started = Instant::now();
        let steps = 12;
        for _ in 0..steps {
            let batch = draw(&t, &mut rng, 4);
            let total = physics_loss(&t, &fitting, &local, &batch).total();
            assert!(scalar(total.clone()).is_finite());
            (fitting, local) = step_both((fitting, local), &mut opts, total, 1e-3);
        }
        let per_step = started.elapsed().as_secs_f64() / steps as f64;
        let (after, decomposition) = eval(&fitting, &local);
        println!(
            "physics-only toy: held-out energy {before:.4} -> {after:.4} m, decomposition \
             {decomposition:.4}, {:.0} ms per step",
            per_step * 1e3
        );
        assert!(after.is_finite() && decomposition.is_finite());
        assert!(after < before, "{before} -> {after}");
    }

    /// Hybrid, a toy run: the supervised MSE to labels (here the posed rest shirts' own
    /// displacements, standing in for simulated drapes) plus λ times the physics loss.
    /// Both the supervised loss and the energy fall, nothing is NaN.
    #[test]
    fn a_toy_hybrid_run_lowers_both_the_supervised_loss_and_the_energy() {
        let t = toy(Resolution::Coarse);
        let (mut fitting, mut local) = nets(&t);
        let mut rng = SplitMix64::new(3);
        let labelled = draw(&t, &mut rng, 4);
        let n = t.garment.vertex_count();
        // The posed rest shirt as the label: zero fitting displacement from the rest
        // offsets, zero local detail.
        let fitting_target = Tensor::<2>::zeros([4, 3 * n], &t.ad);
        let local_target = Tensor::<2>::zeros([4, 3 * n], &t.ad);
        let supervised = |f: &GarMatNet, l: &GarMatNet| {
            let mse = |net: &GarMatNet, target: &Tensor<2>| {
                MseLoss::new().forward(
                    net.forward(labelled.poses.clone(), labelled.materials.clone()),
                    target.clone(),
                    Reduction::Mean,
                )
            };
            mse(f, &fitting_target) + mse(l, &local_target)
        };
        let physics =
            |f: &GarMatNet, l: &GarMatNet, batch: &PhysicsBatch| physics_loss(&t, f, l, batch);
        let held_out = draw(&t, &mut rng, 4);
        let (sup_before, energy_before) = (
            scalar(supervised(&fitting, &local)),
            scalar(physics(&fitting, &local, &held_out).energy),
        );
        let weight = 0.1;
        let mut opts: (ModuleOptimizer, ModuleOptimizer) =
            (AdamConfig::new().init(), AdamConfig::new().init());
        for _ in 0..12 {
            let batch = draw(&t, &mut rng, 4);
            let loss = supervised(&fitting, &local)
                + physics(&fitting, &local, &batch).total().mul_scalar(weight);
            assert!(scalar(loss.clone()).is_finite());
            (fitting, local) = step_both((fitting, local), &mut opts, loss, 1e-3);
        }
        let (sup_after, energy_after) = (
            scalar(supervised(&fitting, &local)),
            scalar(physics(&fitting, &local, &held_out).energy),
        );
        println!(
            "hybrid toy: supervised {sup_before:.4} -> {sup_after:.4}, held-out energy \
             {energy_before:.4} -> {energy_after:.4} m"
        );
        assert!(sup_after < sup_before, "{sup_before} -> {sup_after}");
        assert!(
            energy_after < energy_before,
            "{energy_before} -> {energy_after}"
        );
    }

    /// Time per physics step (batch 8, both nets, hidden 512) at default resolution; run
    /// with `cargo test -p garmatnet-train --release -- --ignored --nocapture physics_step`.
    #[test]
    #[ignore = "timing measurement, not a check"]
    fn physics_step_time() {
        for resolution in [Resolution::Coarse, Resolution::Default] {
            let t = toy(resolution);
            let config = crate::TrainConfig::default().net_config(t.garment.vertex_count());
            let (mut fitting, mut local) = (config.init(&t.ad), config.init(&t.ad));
            let mut rng = SplitMix64::new(4);
            let mut opts: (ModuleOptimizer, ModuleOptimizer) =
                (AdamConfig::new().init(), AdamConfig::new().init());
            let (mut draw_s, mut step_s) = (0.0, 0.0);
            let steps = 5;
            for _ in 0..steps {
                let started = Instant::now();
                let batch = draw(&t, &mut rng, 8);
                draw_s += started.elapsed().as_secs_f64();
                let started = Instant::now();
                let total = physics_loss(&t, &fitting, &local, &batch).total();
                (fitting, local) = step_both((fitting, local), &mut opts, total, 1e-4);
                step_s += started.elapsed().as_secs_f64();
            }
            println!(
                "{resolution:?} (n = {}): drawing a batch of 8 {:.0} ms, a physics step of both \
                 nets {:.0} ms",
                t.garment.vertex_count(),
                draw_s / steps as f64 * 1e3,
                step_s / steps as f64 * 1e3
            );
        }
    }
}
