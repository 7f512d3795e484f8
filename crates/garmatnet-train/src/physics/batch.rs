//! The (pose, fabric) pairs of physics-informed training, drawn continuously: fabrics
//! uniform in normalised ω, poses from any [`PoseSource`] (by default the independent-pose
//! sampler of `simulate --poses N`, [`PhysicsPoses::Sampler`]), and everything a batch's
//! energy needs as tensors.

use burn::prelude::*;
use burn::tensor::DType;
use garmatnet_core::{
    CapsuleBody, DisplacementFrame, Garment, JointLimits, MATERIAL_DIM, Material, POSE_DIM, Pose,
    PosedBody, Real, SplitMix64,
};
use garmatnet_sim::{
    DEFAULT_HANGING_FRACTION, DEFAULT_RAISED_FRACTION, DrapeSettings, PoseSampler,
    PoseSamplerConfig, cloth_from_garment,
};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::physics::energy::ClothTensors;

/// Where physics-informed training draws its poses: [`SampledPoses`], [`JointLimitsPoses`],
/// or any closure `Fn(&mut SplitMix64) -> Result<Pose>`. A source draws all its
/// randomness from the stream it is given, so one source serves every batch of a run.
pub trait PoseSource {
    /// The next pose, drawing any randomness from `rng`.
    ///
    /// # Errors
    /// When the source cannot give a pose (e.g. the sampler found none within its attempts).
    fn next_pose(&self, rng: &mut SplitMix64) -> Result<Pose>;
}

impl<F: Fn(&mut SplitMix64) -> Result<Pose>> PoseSource for F {
    fn next_pose(&self, rng: &mut SplitMix64) -> Result<Pose> {
        self(rng)
    }
}

/// Poses drawn by [`JointLimits::sample`] at `amplitude` (0 to 1 of each joint's range):
/// every joint independently, so arms pass through the torso and rarely hang at the sides.
#[derive(Debug, Clone, PartialEq)]
pub struct JointLimitsPoses {
    /// The joint limits.
    pub limits: JointLimits,
    /// Fraction of each joint's range drawn from (dimensionless, 0 to 1).
    pub amplitude: Real,
}

impl Default for JointLimitsPoses {
    fn default() -> Self {
        Self {
            limits: JointLimits::default(),
            amplitude: 0.5,
        }
    }
}

impl PoseSource for JointLimitsPoses {
    fn next_pose(&self, rng: &mut SplitMix64) -> Result<Pose> {
        Ok(self.limits.sample(rng, self.amplitude))
    }
}

/// Poses of the independent-pose sampler that makes datasets (`simulate --poses N --seed
/// S`, [`PoseSampler`]): arms from hanging at the sides to overhead, bent elbows, torso bends
/// and twists, strides and weight shifts, with no body part passing through another. Each
/// pose is the sampler's pose at an index drawn from the training stream, so a run draws
/// fresh poses of the datasets' distribution for as long as it trains.
#[derive(Debug, Clone)]
pub struct SampledPoses {
    sampler: PoseSampler,
}

impl SampledPoses {
    /// The sampler with its default configuration and `seed`.
    ///
    /// # Errors
    /// As [`PoseSampler::new`].
    pub fn new(seed: u64) -> Result<Self> {
        Self::with_config(PoseSamplerConfig {
            seed,
            ..PoseSamplerConfig::default()
        })
    }

    /// The sampler with `config` (e.g. another share of hanging and raised arms).
    ///
    /// # Errors
    /// As [`PoseSampler::new`]: fractions outside [0, 1] or summing past 1, among others.
    pub fn with_config(config: PoseSamplerConfig) -> Result<Self> {
        Ok(Self {
            sampler: PoseSampler::new(config)?,
        })
    }
}

impl PoseSource for SampledPoses {
    fn next_pose(&self, rng: &mut SplitMix64) -> Result<Pose> {
        Ok(self.sampler.pose(rng.next_u64())?)
    }
}

/// Which poses physics-informed training draws (a run's configuration; [`Self::source`]
/// makes the [`PoseSource`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case", tag = "kind")]
pub enum PhysicsPoses {
    /// The datasets' independent-pose sampler ([`SampledPoses`]) with this seed.
    Sampler {
        /// The sampler's seed.
        seed: u64,
        /// The fractions of arms drawn hanging and raised
        /// ([`PoseSamplerConfig::hanging_fraction`], [`PoseSamplerConfig::raised_fraction`]);
        /// `None` keeps the datasets' default, as `simulate --arm-bands` does.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        arm_bands: Option<[Real; 2]>,
    },
    /// Each joint uniformly within `amplitude` of its range ([`JointLimitsPoses`]).
    JointLimits {
        /// Fraction of each joint's range drawn from (0 to 1).
        amplitude: f64,
    },
}

impl Default for PhysicsPoses {
    fn default() -> Self {
        Self::Sampler {
            seed: 1,
            arm_bands: None,
        }
    }
}

impl PhysicsPoses {
    /// Checks the settings.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] for an amplitude outside `[0, 1]`, or arm fractions outside
    /// `[0, 1]` or summing past 1.
    pub fn validate(&self) -> Result<()> {
        match self {
            Self::JointLimits { amplitude } if !(0.0..=1.0).contains(amplitude) => {
                Err(Error::InvalidConfig(format!(
                    "physics pose amplitude {amplitude} must lie in [0, 1] (a fraction of each \
                     joint's range)"
                )))
            }
            Self::Sampler {
                arm_bands: Some([hanging, raised]),
                ..
            } if !((0.0..=1.0).contains(hanging)
                && (0.0..=1.0).contains(raised)
                && hanging + raised <= 1.0) =>
            {
                Err(Error::InvalidConfig(format!(
                    "physics pose arm bands {hanging},{raised}: the fractions of arms hanging \
                     and raised each lie in [0, 1] and make at most 1 together (the rest lie \
                     between)"
                )))
            }
            _ => Ok(()),
        }
    }

    /// The source of these poses.
    ///
    /// # Errors
    /// As [`Self::validate`] and [`SampledPoses::new`].
    pub fn source(&self) -> Result<Box<dyn PoseSource>> {
        self.validate()?;
        Ok(match *self {
            Self::Sampler { seed, arm_bands } => {
                let [hanging_fraction, raised_fraction] =
                    arm_bands.unwrap_or([DEFAULT_HANGING_FRACTION, DEFAULT_RAISED_FRACTION]);
                Box::new(SampledPoses::with_config(PoseSamplerConfig {
                    seed,
                    hanging_fraction,
                    raised_fraction,
                    ..PoseSamplerConfig::default()
                })?)
            }
            Self::JointLimits { amplitude } => Box::new(JointLimitsPoses {
                limits: JointLimits::default(),
                amplitude,
            }),
        })
    }
}

impl std::str::FromStr for PhysicsPoses {
    type Err = Error;

    /// `sampler`, `sampler:SEED`, `sampler:SEED:H,R` (the fractions of arms hanging and
    /// raised, as `simulate --arm-bands H,R`), `joint-limits` or `joint-limits:AMPLITUDE`
    /// (defaults: seed 1, the datasets' arm bands, amplitude 0.5).
    fn from_str(s: &str) -> Result<Self> {
        let (kind, value) = match s.trim().split_once(':') {
            Some((k, v)) => (k.trim(), Some(v.trim())),
            None => (s.trim(), None),
        };
        let bad = |what: &str| {
            Error::InvalidConfig(format!(
                "physics poses `{s}`: {what}; use sampler, sampler:SEED, sampler:SEED:H,R, \
                 joint-limits or joint-limits:AMPLITUDE"
            ))
        };
        let poses = match kind {
            "sampler" => {
                let (seed, bands) = match value.map(|v| v.split_once(':')) {
                    None => (None, None),
                    Some(None) => (value, None),
                    Some(Some((seed, bands))) => (Some(seed.trim()), Some(bands)),
                };
                let arm_bands = match bands {
                    None => None,
                    Some(text) => {
                        let values = text
                            .split(',')
                            .map(|v| v.trim().parse::<Real>())
                            .collect::<std::result::Result<Vec<_>, _>>()
                            .map_err(|_| bad("the arm bands are not two numbers H,R"))?;
                        let [hanging, raised] = values[..] else {
                            return Err(bad("the arm bands are not two numbers H,R"));
                        };
                        Some([hanging, raised])
                    }
                };
                Self::Sampler {
                    seed: seed.map_or(Ok(1), |v| {
                        v.parse().map_err(|_| bad("the seed is not a whole number"))
                    })?,
                    arm_bands,
                }
            }
            "joint-limits" => Self::JointLimits {
                amplitude: value.map_or(Ok(0.5), |v| {
                    v.parse().map_err(|_| bad("the amplitude is not a number"))
                })?,
            },
            _ => return Err(bad("unknown kind")),
        };
        poses.validate()?;
        Ok(poses)
    }
}

/// A fabric uniform in normalised ω (`[0, 1]⁶`, log-uniform in each physical component
/// between the standard bounds).
///
/// # Errors
/// Never for the standard bounds; as [`Material::from_normalized`] otherwise.
pub fn uniform_fabric(rng: &mut SplitMix64) -> Result<Material> {
    let omega: [Real; MATERIAL_DIM] = std::array::from_fn(|_| rng.next_f64());
    Ok(Material::from_normalized(omega)?)
}

/// One batch of physics-informed training on the autodiff device: the nets' inputs, the
/// energy's constants and the body frame that turns predicted displacements into garment
/// positions.
#[derive(Debug, Clone)]
pub struct PhysicsBatch {
    /// Poses (axis-angle, radians), `[B, 72]`.
    pub poses: Tensor<2>,
    /// Normalised ω, `[B, 6]`.
    pub materials: Tensor<2>,
    /// The energy's per-sample cloth constants.
    pub cloth: ClothTensors,
    /// The posed bodies, one per sample.
    pub bodies: Vec<PosedBody>,
    /// Each vertex's posed body anchor (metres), `[B, n, 3]`.
    anchors: Tensor<3>,
    /// Each vertex's frame rotation (row-major 3 × 3; identity for the world frame),
    /// `[B, n, 3, 3]`.
    frames: Tensor<4>,
    pose_rows: Vec<f32>,
    omega_rows: Vec<f32>,
}

impl PhysicsBatch {
    /// Draws `size` (pose, fabric) pairs: poses from `poses`, fabrics uniform in normalised
    /// ω, on `device` in f32.
    ///
    /// # Errors
    /// As [`PoseSource::next_pose`], [`cloth_from_garment`] and [`ClothTensors::new`].
    #[allow(clippy::too_many_arguments)]
    pub fn draw(
        garment: &Garment,
        body: &CapsuleBody,
        settings: &DrapeSettings,
        frame: DisplacementFrame,
        poses: &dyn PoseSource,
        rng: &mut SplitMix64,
        size: usize,
        device: &Device,
    ) -> Result<Self> {
        let (mut pose_rows, mut omega_rows) = (Vec::new(), Vec::new());
        let (mut models, mut posed) = (Vec::new(), Vec::new());
        let (mut anchors, mut frames) = (Vec::new(), Vec::new());
        for _ in 0..size {
            let pose = poses.next_pose(rng)?;
            let material = uniform_fabric(rng)?;
            pose_rows.extend(pose.to_vec().into_iter().map(|v| v as f32));
            omega_rows.extend(material.to_normalized().into_iter().map(|v| v as f32));
            models.push(cloth_from_garment(garment, &material)?);
            let p = body.pose(&pose);
            let t = p.skinning_transforms();
            for a in &garment.anchors {
                anchors.extend(a.posed_point(t).iter().map(|&v| v as f32));
                let r = match frame {
                    DisplacementFrame::World => garmatnet_core::Mat3::identity(),
                    DisplacementFrame::Canonical => a.frame(t).to_rotation_matrix().into_inner(),
                };
                // Row-major, world[i] = Σ_j r[(i, j)] d[j].
                for i in 0..3 {
                    for j in 0..3 {
                        frames.push(r[(i, j)] as f32);
                    }
                }
            }
            posed.push(p);
        }
        let n = garment.vertex_count();
        let model_refs: Vec<_> = models.iter().collect();
        Ok(Self {
            poses: Tensor::from_data(TensorData::new(pose_rows.clone(), [size, POSE_DIM]), device),
            materials: Tensor::from_data(
                TensorData::new(omega_rows.clone(), [size, MATERIAL_DIM]),
                device,
            ),
            pose_rows,
            omega_rows,
            cloth: ClothTensors::new(&model_refs, settings, device, DType::F32)?,
            bodies: posed,
            anchors: Tensor::from_data(TensorData::new(anchors, [size, n, 3]), device),
            frames: Tensor::from_data(TensorData::new(frames, [size, n, 3, 3]), device),
        })
    }

    /// The nets' inputs (poses `[B, 72]`, normalised ω `[B, 6]`) on another device, such
    /// as the plain device of a finished net.
    #[must_use]
    pub fn inputs_on(&self, device: &Device) -> (Tensor<2>, Tensor<2>) {
        let size = self.pose_rows.len() / POSE_DIM;
        (
            Tensor::from_data(
                TensorData::new(self.pose_rows.clone(), [size, POSE_DIM]),
                device,
            ),
            Tensor::from_data(
                TensorData::new(self.omega_rows.clone(), [size, MATERIAL_DIM]),
                device,
            ),
        )
    }

    /// Garment positions (metres) from displacements in the batch's frame (metres): each
    /// vertex's posed anchor plus its displacement rotated into the world.
    ///
    /// # Shapes
    /// `displacements`: `[B, 3n]` → `[B, n, 3]`.
    #[must_use]
    pub fn positions(&self, displacements: Tensor<2>) -> Tensor<3> {
        let [batch, n, _] = self.anchors.dims();
        let d = displacements.reshape([batch, n, 1, 3]);
        let world: Tensor<3> = (self.frames.clone() * d).sum_dim(3).squeeze_dim(3);
        self.anchors.clone() + world
    }

    /// Displacements (metres, in the batch's frame) of garment positions (metres): the
    /// inverse of [`PhysicsBatch::positions`].
    ///
    /// # Shapes
    /// `positions`: `[B, n, 3]` → `[B, 3n]`.
    #[must_use]
    pub fn displacements(&self, positions: Tensor<3>) -> Tensor<2> {
        let [batch, n, _] = self.anchors.dims();
        let world = (positions - self.anchors.clone()).reshape([batch, n, 3, 1]);
        // Rᵀ w: sum over the rows of R.
        let d: Tensor<3> = (self.frames.clone() * world).sum_dim(2).squeeze_dim(2);
        d.reshape([batch, 3 * n])
    }

    /// Each sample's drape energy per unit weight, `E / Σ m g` (metres): gravity's part is
    /// the garment's mass-weighted mean height, whatever the fabric; the springs' and the
    /// contact's are in the same units, so heavy or stiff fabrics do not dominate the batch
    /// through their scale alone.
    ///
    /// # Shapes
    /// `positions`: `[B, n, 3]` → `[B]`.
    ///
    /// # Errors
    /// As [`ClothTensors::energy`].
    pub fn normalised_energy(&self, positions: Tensor<3>) -> Result<Tensor<1>> {
        let e = self.cloth.energy(positions, &self.bodies)?;
        Ok(e.total() / self.cloth.weight())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn physics_poses_parse_with_defaults_and_bad_ones_say_what_to_write() {
        assert_eq!(
            "sampler".parse::<PhysicsPoses>().unwrap(),
            PhysicsPoses::default()
        );
        assert_eq!(
            "sampler:7".parse::<PhysicsPoses>().unwrap(),
            PhysicsPoses::Sampler {
                seed: 7,
                arm_bands: None
            }
        );
        assert_eq!(
            "sampler:2: 0.1, 0.15".parse::<PhysicsPoses>().unwrap(),
            PhysicsPoses::Sampler {
                seed: 2,
                arm_bands: Some([0.1, 0.15])
            }
        );
        assert_eq!(
            " joint-limits : 0.3 ".parse::<PhysicsPoses>().unwrap(),
            PhysicsPoses::JointLimits { amplitude: 0.3 }
        );
        for bad in [
            "walk",
            "sampler:x",
            "joint-limits:2",
            "joint-limits:nan",
            "sampler:1:0.5",
            "sampler:1:a,b",
            "sampler:1:0.7,0.4",
            "sampler:1:-0.1,0.2",
            "sampler:1:nan,0.2",
        ] {
            let e = bad.parse::<PhysicsPoses>().unwrap_err().to_string();
            assert!(
                e.contains("sampler:SEED:H,R") || e.contains("[0, 1]"),
                "{bad}: {e}"
            );
        }
        // The default bands are left out of a saved config, so older configs read the same.
        let json = serde_json::to_value(PhysicsPoses::default()).unwrap();
        assert!(json.get("arm_bands").is_none(), "{json}");
        assert_eq!(
            serde_json::from_value::<PhysicsPoses>(json).unwrap(),
            PhysicsPoses::default()
        );
    }

    /// Other arm bands draw other poses from the same stream; the default bands draw the
    /// datasets' sampler's poses.
    #[test]
    fn sampler_arm_bands_change_the_poses_drawn() {
        let draw = |poses: PhysicsPoses| {
            let source = poses.source().unwrap();
            let mut rng = SplitMix64::new(5);
            (0..4)
                .map(|_| source.next_pose(&mut rng).unwrap())
                .collect::<Vec<_>>()
        };
        let default = draw(PhysicsPoses::default());
        let explicit = draw(PhysicsPoses::Sampler {
            seed: 1,
            arm_bands: Some([DEFAULT_HANGING_FRACTION, DEFAULT_RAISED_FRACTION]),
        });
        assert_eq!(default, explicit);
        let middle = draw("sampler:1:0,0".parse().unwrap());
        assert_ne!(default, middle);
    }

    /// The sampler's poses are the datasets' (no part passes through another, arms hang
    /// as low as the sampler's hanging band) and repeat for the same stream.
    #[test]
    fn sampled_poses_repeat_per_stream_and_differ_between_draws() {
        let source = PhysicsPoses::default().source().unwrap();
        let mut rng = SplitMix64::new(3);
        let a: Vec<Pose> = (0..3)
            .map(|_| source.next_pose(&mut rng).unwrap())
            .collect();
        let again = PhysicsPoses::default().source().unwrap();
        let mut rng = SplitMix64::new(3);
        let b: Vec<Pose> = (0..3).map(|_| again.next_pose(&mut rng).unwrap()).collect();
        assert_eq!(a, b);
        assert_ne!(a[0], a[1]);
        let check = garmatnet_sim::SelfIntersection::new(
            &CapsuleBody::smpl_neutral(),
            garmatnet_sim::DEFAULT_ARM_GAP,
        )
        .unwrap();
        for p in &a {
            assert!(check.worst(p).is_none(), "{p:?}");
        }
    }
}
