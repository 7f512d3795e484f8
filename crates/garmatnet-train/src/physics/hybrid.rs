//! Hybrid training's physics term (`garmatnet train --physics-weight λ`): beside the
//! locally-detailed net's supervised loss, `λ` times the mean normalised drape energy of
//! the full prediction (the finished fitting net's plus the local net's) at (pose, fabric)
//! pairs drawn afresh every step. The fitting net is trained on its smooth labels alone,
//! so the decomposition keeps its meaning: the physics moves the detail only.

use burn::prelude::*;
use garmatnet_core::{CapsuleBody, DisplacementFrame, Garment, Real, SplitMix64};
use garmatnet_model::{GarMatNet, OutputNormalizer};
use garmatnet_sim::DrapeSettings;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::physics::batch::{PhysicsBatch, PhysicsPoses, PoseSource};
use crate::physics::two_net_loss::NormalizerTensors;
use crate::training::training_loop::ExtraLoss;

/// The physics term of hybrid training.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PhysicsConfig {
    /// `λ`: the weight of the mean normalised energy (metres; [`PhysicsBatch::
    /// normalised_energy`]) beside the supervised MSE of normalised outputs. 0 (default)
    /// turns the term off.
    pub weight: f64,
    /// (pose, fabric) pairs drawn per step.
    pub batch_size: usize,
    /// Which poses the pairs take (default: the datasets' independent-pose sampler).
    pub poses: PhysicsPoses,
}

impl Default for PhysicsConfig {
    fn default() -> Self {
        Self {
            weight: 0.0,
            batch_size: 8,
            poses: PhysicsPoses::default(),
        }
    }
}

impl PhysicsConfig {
    /// Whether the term is off (weight 0): runs without it keep their fingerprints.
    #[must_use]
    pub fn is_off(&self) -> bool {
        self.weight == 0.0
    }

    /// Checks the settings.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] for a weight that is negative or not finite, no pair per
    /// step; as [`PhysicsPoses::validate`].
    pub fn validate(&self) -> Result<()> {
        if !(self.weight.is_finite() && self.weight >= 0.0) {
            return Err(Error::InvalidConfig(format!(
                "physics weight {} must be finite and at least 0 (0 turns it off)",
                self.weight
            )));
        }
        if self.batch_size == 0 {
            return Err(Error::InvalidConfig(
                "the physics term needs at least one (pose, fabric) pair per step".into(),
            ));
        }
        self.poses.validate()?;
        Ok(())
    }
}

/// The physics term of the local net's phase: the energy of the finished fitting net's
/// prediction plus the local net's.
pub(crate) struct LocalPhysics {
    pub(crate) config: PhysicsConfig,
    /// The source of `config.poses`, made once for the run.
    pub(crate) poses: Box<dyn PoseSource>,
    /// The finished fitting net, on the plain device.
    pub(crate) fitting: GarMatNet,
    pub(crate) fitting_norm: OutputNormalizer,
    pub(crate) local_norm: NormalizerTensors,
    pub(crate) garment: Garment,
    pub(crate) body: CapsuleBody,
    pub(crate) settings: DrapeSettings,
    pub(crate) frame: DisplacementFrame,
    /// The autodiff device.
    pub(crate) device: Device,
}

impl LocalPhysics {
    /// `λ` times the mean normalised energy of the full prediction at a fresh batch.
    fn term(&self, local: &GarMatNet, rng: &mut SplitMix64) -> Result<Tensor<1>> {
        let batch = PhysicsBatch::draw(
            &self.garment,
            &self.body,
            &self.settings,
            self.frame,
            self.poses.as_ref(),
            rng,
            self.config.batch_size,
            &self.device,
        )?;
        let plain = self.device.clone().inner();
        let (pose, omega) = batch.inputs_on(&plain);
        let fitting: Vec<f32> = self
            .fitting
            .forward(pose, omega)
            .into_data()
            .try_into_vec_as::<f32>()
            .unwrap_or_else(|e| panic!("reading a tensor back from the device failed: {e:?}"));
        let size = self.config.batch_size;
        let cols = fitting.len() / size;
        let fitting: Vec<f32> = fitting
            .chunks_exact(cols)
            .flat_map(|row| self.fitting_norm.denormalize(row))
            .map(|v: Real| v as f32)
            .collect();
        let fitting = Tensor::<2>::from_data(TensorData::new(fitting, [size, cols]), &self.device);
        let local = self
            .local_norm
            .denormalize(local.forward(batch.poses.clone(), batch.materials.clone()));
        let energy = batch.normalised_energy(batch.positions(fitting + local))?;
        Ok(energy.mean().mul_scalar(self.config.weight))
    }
}

impl ExtraLoss<GarMatNet> for LocalPhysics {
    fn loss(&mut self, net: &GarMatNet, rng: &mut SplitMix64) -> Result<Tensor<1>> {
        self.term(net, rng)
    }
}
