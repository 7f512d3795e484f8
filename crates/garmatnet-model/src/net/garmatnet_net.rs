//! The GarMatNet MLP (paper §3.4–3.6): separate pose and material input branches, a shared
//! hidden layer and a normalised per-vertex displacement output.
//!
//! The same module serves as the generally-fitting network and the locally-detailed network
//! (two instances with separate weights).

use burn::module::{Initializer, Param};
use burn::nn::{Dropout, DropoutConfig, Linear, LinearConfig};
use burn::prelude::*;
use burn::tensor::module::linear;
use garmatnet_core::{DisplacementFrame, JOINT_COUNT, Material, POSE_DIM};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

pub(crate) use garmatnet_core::MATERIAL_DIM;

/// The most weights a network may have (both nets' configurations are checked against it):
/// 500 million, 2 GB of f32, some 75 times the shipped paper-resolution nets together. A
/// larger size from a command line or a file would abort the process on allocation instead
/// of failing with a message.
pub const MAX_PARAMETERS: usize = 500_000_000;

/// Checks that a network of `layers` (fan-in, fan-out) pairs has at most
/// [`MAX_PARAMETERS`] weights.
pub(crate) fn check_parameter_count(what: &str, layers: &[(usize, usize)]) -> Result<()> {
    let count = layers
        .iter()
        .try_fold(0usize, |sum, &(a, b)| a.checked_mul(b)?.checked_add(sum));
    match count {
        Some(n) if n <= MAX_PARAMETERS => Ok(()),
        _ => Err(Error::InvalidConfig(format!(
            "{what} would have {} weights, more than the {MAX_PARAMETERS} allowed: choose \
             smaller hidden sizes or an output rank",
            count.map_or_else(|| "more than 2^64".to_owned(), |n| n.to_string())
        ))),
    }
}

/// How the pose branch reads θ.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PoseEncoding {
    /// The 72 axis-angle numbers as given (the paper's input).
    #[default]
    AxisAngle,
    /// Each joint's rotation matrix minus the identity, R(θⱼ) − I, row-major: 24 × 9 = 216
    /// numbers (SMPL's pose-blend-shape feature). Zero at the rest pose, continuous in the
    /// rotation (axis-angle jumps where a joint's angle crosses π), and each entry is a
    /// smooth function of the joint's rotation rather than of its angle and axis separately.
    RotationMatrix,
}

impl PoseEncoding {
    /// Both encodings.
    pub const ALL: [Self; 2] = [Self::AxisAngle, Self::RotationMatrix];

    /// The command-line name: `axis-angle` or `rotation-matrix`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::AxisAngle => "axis-angle",
            Self::RotationMatrix => "rotation-matrix",
        }
    }

    /// Whether this is the paper's axis-angle input (the default).
    #[must_use]
    pub fn is_axis_angle(&self) -> bool {
        *self == Self::AxisAngle
    }

    /// The width of the encoded pose, the pose branch's input.
    #[must_use]
    pub fn width(self) -> usize {
        match self {
            Self::AxisAngle => POSE_DIM,
            Self::RotationMatrix => JOINT_COUNT * 9,
        }
    }

    /// Encodes a batch of poses.
    ///
    /// # Shapes
    /// - `pose`: `[B, 72]` (axis-angle, radians)
    /// - output: `[B, self.width()]`
    pub fn encode(self, pose: Tensor<2>) -> Tensor<2> {
        match self {
            Self::AxisAngle => pose,
            Self::RotationMatrix => rotation_minus_identity(pose),
        }
    }
}

impl std::fmt::Display for PoseEncoding {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for PoseEncoding {
    type Err = Error;

    /// `axis-angle` or `rotation-matrix` (case-insensitive; `_` for `-` accepted).
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] for anything else.
    fn from_str(s: &str) -> Result<Self> {
        let wanted = s.trim().replace('_', "-");
        Self::ALL
            .into_iter()
            .find(|e| e.name().eq_ignore_ascii_case(&wanted))
            .ok_or_else(|| {
                Error::InvalidConfig(format!(
                    "unknown pose encoding `{s}`: use `axis-angle` (the paper's, the default) \
                     or `rotation-matrix`"
                ))
            })
    }
}

/// R(θⱼ) − I for every joint by Rodrigues' formula, written so it stays accurate at small
/// angles: R − I = (sin a / a) \[x\]ₓ + ((1 − cos a) / a²) (x xᵀ − a² I) with a = |x|, and
/// 1 − cos a = 2 sin²(a / 2).
///
/// # Shapes
/// - `pose`: `[B, 72]`
/// - output: `[B, 216]`, joint-major, each joint's 3 × 3 block row-major
fn rotation_minus_identity(pose: Tensor<2>) -> Tensor<2> {
    let [batch, _] = pose.dims();
    let x = pose.reshape([batch, JOINT_COUNT, 3]);
    let squared = x.clone().powi_scalar(2).sum_dim(2); // [B, 24, 1]
    // The tiny shift keeps a = 0 (the rest pose) finite; its effect is below f32 precision
    // wherever a is not itself negligible.
    let angle = squared.clone().add_scalar(1e-12).sqrt();
    let sin_over = angle.clone().sin().div(angle.clone());
    let half_sin = angle.clone().mul_scalar(0.5).sin();
    let one_minus_cos_over = half_sin
        .powi_scalar(2)
        .mul_scalar(2.0)
        .div(angle.powi_scalar(2));
    let c = |i: usize| x.clone().narrow(2, i, 1);
    let (x0, x1, x2) = (c(0), c(1), c(2));
    // The skew part (sin a / a) xᵢ and the symmetric off-diagonal part, once each.
    let s = |v: &Tensor<3>| sin_over.clone().mul(v.clone());
    let (s0, s1, s2) = (s(&x0), s(&x1), s(&x2));
    let k = |a: &Tensor<3>, b: &Tensor<3>| one_minus_cos_over.clone().mul(a.clone().mul(b.clone()));
    let (k01, k02, k12) = (k(&x0, &x1), k(&x0, &x2), k(&x1, &x2));
    let diagonal = |v: &Tensor<3>| {
        one_minus_cos_over
            .clone()
            .mul(v.clone().powi_scalar(2).sub(squared.clone()))
    };
    let entries = vec![
        diagonal(&x0),
        k01.clone().sub(s2.clone()),
        k02.clone().add(s1.clone()),
        k01.add(s2),
        diagonal(&x1),
        k12.clone().sub(s0.clone()),
        k02.sub(s1),
        k12.add(s0),
        diagonal(&x2),
    ];
    Tensor::cat(entries, 2).reshape([batch, JOINT_COUNT * 9])
}

/// Configuration of a [`GarMatNet`].
///
/// θ (72) × (1 − α) → Linear → tanh ┐
///                                   ├ concat → Linear → tanh → dropout → Linear → 3n
/// ω (6)  × α       → Linear → tanh ┘
///
/// With `output_rank = Some(k)` the last layer outputs `k` coefficients that multiply a
/// basis `[k, 3n]` (plus a mean `[3n]`) held as module parameters: set them from PCA of the
/// training displacements with [`GarMatNet::set_output_basis`]. With
/// [`PoseEncoding::RotationMatrix`] the pose branch reads the 216 numbers R(θⱼ) − I instead
/// of θ's 72.
#[derive(Config, Debug)]
pub struct GarMatNetConfig {
    /// The number of garment vertices n; the output has 3n values.
    pub vertex_count: usize,
    /// Width of the pose branch's hidden layer.
    pub pose_hidden: usize,
    /// Width of the material branch's hidden layer.
    pub material_hidden: usize,
    /// Width of the hidden layer after the merge.
    pub hidden: usize,
    /// Length of the pose input θ (SMPL: 24 joints × 3).
    #[config(default = 72)]
    pub pose_dim: usize,
    /// Length of the material input ω (normalised to [0, 1]).
    #[config(default = 6)]
    pub material_dim: usize,
    /// Dropout probability after the merged hidden layer (acts only while training).
    #[config(default = 0.1)]
    pub dropout: f64,
    /// The weight controller α ∈ [0, 1] (paper §3.6): ω is scaled by α and θ by 1 − α.
    #[config(default = 0.5)]
    pub alpha: f64,
    /// `Some(k)`: low-rank output through a `[k, 3n]` basis; `None`: a full output layer.
    #[config(default = "None")]
    pub output_rank: Option<usize>,
    /// The frame the predicted displacements are expressed in.
    #[config(default = "DisplacementFrame::World")]
    pub displacement_frame: DisplacementFrame,
    /// Project ω onto the plane orthogonal to
    /// [`Material::uniform_scaling_direction`] before the material branch, so scaling every
    /// stiffness and the density by one factor (which leaves a static drape unchanged) cannot
    /// change the prediction: the net sees stiffness-to-weight ratios. Default off (the
    /// paper's net); model files written before this option read as off.
    #[config(default = false)]
    pub scale_free_material: bool,
    /// How the pose branch reads θ. Default axis-angle (the paper's net); model files
    /// written before this option read as axis-angle.
    #[config(default = "PoseEncoding::AxisAngle")]
    pub pose_encoding: PoseEncoding,
    /// Kaiming-normal gain of the hidden layers (std = gain / √fan_in). 5/3 is the usual gain
    /// for tanh; the output layer uses gain 1 because it feeds no nonlinearity.
    #[config(default = 1.6666666666666667)]
    pub init_gain: f64,
}

impl GarMatNetConfig {
    /// The number of output values, 3n.
    #[must_use]
    pub fn output_dim(&self) -> usize {
        // Saturating, so `validate` can refuse an absurd vertex count instead of overflowing.
        self.vertex_count.saturating_mul(3)
    }

    /// Checks that every size is positive, the weights at most [`MAX_PARAMETERS`], and α,
    /// dropout and the rank in range.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] naming the field to change.
    pub fn validate(&self) -> Result<()> {
        let sizes = [
            ("vertex_count", self.vertex_count),
            ("pose_hidden", self.pose_hidden),
            ("material_hidden", self.material_hidden),
            ("hidden", self.hidden),
            ("pose_dim", self.pose_dim),
            ("material_dim", self.material_dim),
        ];
        if let Some((name, _)) = sizes.iter().find(|(_, v)| *v == 0) {
            return Err(Error::InvalidConfig(format!("{name} must be positive")));
        }
        if self.pose_dim != POSE_DIM || self.material_dim != MATERIAL_DIM {
            return Err(Error::InvalidConfig(format!(
                "pose_dim must be {POSE_DIM} and material_dim {MATERIAL_DIM}, got {} and {}",
                self.pose_dim, self.material_dim
            )));
        }
        if !(0.0..=1.0).contains(&self.alpha) {
            return Err(Error::InvalidConfig(format!(
                "alpha = {} must lie in [0, 1]",
                self.alpha
            )));
        }
        if !(0.0..1.0).contains(&self.dropout) {
            return Err(Error::InvalidConfig(format!(
                "dropout = {} must lie in [0, 1)",
                self.dropout
            )));
        }
        if !(self.init_gain.is_finite() && self.init_gain > 0.0) {
            return Err(Error::InvalidConfig(
                "init_gain must be a positive number".into(),
            ));
        }
        if let Some(k) = self.output_rank
            && (k == 0 || k > self.output_dim())
        {
            return Err(Error::InvalidConfig(format!(
                "output_rank = {k} must lie in [1, 3n = {}]",
                self.output_dim()
            )));
        }
        // Saturating: a size near usize::MAX must fail the count, not overflow first.
        let outputs = self.output_dim();
        let head = match self.output_rank {
            Some(k) => vec![(self.hidden, k), (k, outputs)],
            None => vec![(self.hidden, outputs)],
        };
        check_parameter_count(
            "the network",
            &[
                &[
                    (self.pose_dim, self.pose_hidden),
                    (self.material_dim, self.material_hidden),
                    (
                        self.pose_hidden.saturating_add(self.material_hidden),
                        self.hidden,
                    ),
                ][..],
                &head,
            ]
            .concat(),
        )?;
        Ok(())
    }

    /// A network with Kaiming-normal weights and zero biases.
    ///
    /// # Panics
    /// If the configuration is invalid; call [`GarMatNetConfig::validate`] first for
    /// configurations that come from users.
    #[must_use]
    pub fn init(&self, device: &Device) -> GarMatNet {
        if let Err(e) = self.validate() {
            panic!("GarMatNetConfig::init on an invalid configuration: {e}");
        }
        let hidden_init = Initializer::KaimingNormal {
            gain: self.init_gain,
            fan_out_only: false,
        };
        let output_init = Initializer::KaimingNormal {
            gain: 1.0,
            fan_out_only: false,
        };
        let layer = |d_in, d_out, init: &Initializer| {
            let mut l = LinearConfig::new(d_in, d_out)
                .with_initializer(init.clone())
                .init(device);
            // He initialisation zeroes biases; Burn's initialiser would draw them too.
            l.bias = Some(Param::from_tensor(Tensor::zeros([d_out], device)));
            l
        };
        let out_width = self.output_rank.unwrap_or(self.output_dim());
        let (basis, basis_mean) = match self.output_rank {
            Some(k) => {
                // A placeholder until the trainer sets the PCA basis: random directions of
                // unit expected norm, so the untrained net still produces varied output.
                let std = 1.0 / (k as f64).sqrt();
                let init = Initializer::Normal { mean: 0.0, std };
                let b: Param<Tensor<2>> =
                    init.init_with([k, self.output_dim()], None, None, device);
                let m = Param::from_tensor(Tensor::zeros([self.output_dim()], device));
                (Some(b), Some(m))
            }
            None => (None, None),
        };
        GarMatNet {
            pose_in: layer(self.pose_encoding.width(), self.pose_hidden, &hidden_init),
            material_in: layer(self.material_dim, self.material_hidden, &hidden_init),
            merge: layer(
                self.pose_hidden + self.material_hidden,
                self.hidden,
                &hidden_init,
            ),
            dropout: DropoutConfig::new(self.dropout).init(),
            output: layer(self.hidden, out_width, &output_init),
            basis,
            basis_mean,
            config: self.clone(),
        }
    }
}

/// The GarMatNet MLP; see [`GarMatNetConfig`] for the architecture.
#[derive(Module, Debug)]
pub struct GarMatNet {
    pub(crate) pose_in: Linear,
    pub(crate) material_in: Linear,
    pub(crate) merge: Linear,
    pub(crate) dropout: Dropout,
    pub(crate) output: Linear,
    pub(crate) basis: Option<Param<Tensor<2>>>,
    pub(crate) basis_mean: Option<Param<Tensor<1>>>,
    #[module(skip)]
    pub(crate) config: GarMatNetConfig,
}

/// The output layer restricted to a subset of vertices: a row-subset forward computes only
/// those output columns. Build once per subset with [`GarMatNet::output_head`] and reuse.
#[derive(Debug, Clone)]
pub struct OutputHead {
    vertices: Option<Vec<usize>>,
    weight: Tensor<2>,
    bias: Tensor<1>,
    basis: Option<(Tensor<2>, Tensor<1>)>,
}

impl OutputHead {
    /// The vertices this head computes, in output order (`None`: all of them).
    #[must_use]
    pub fn vertices(&self) -> Option<&[usize]> {
        self.vertices.as_deref()
    }
}

impl GarMatNet {
    /// The net with dropout probability `p` in training (fine-tuning a trained net with
    /// another dropout than it was trained with); its config records it.
    #[must_use]
    pub fn with_dropout(mut self, p: f64) -> Self {
        self.dropout = DropoutConfig::new(p).init();
        self.config.dropout = p;
        self
    }

    /// The configuration the net was built from.
    #[must_use]
    pub fn config(&self) -> &GarMatNetConfig {
        &self.config
    }

    /// The number of garment vertices n.
    #[must_use]
    pub fn vertex_count(&self) -> usize {
        self.config.vertex_count
    }

    /// The low-rank output's rank `k`, if the net has one.
    #[must_use]
    pub fn output_rank(&self) -> Option<usize> {
        self.basis.as_ref().map(|b| b.dims()[0])
    }

    /// Normalised displacements for a batch.
    ///
    /// # Shapes
    /// - `pose`: `[B, 72]` (axis-angle, radians)
    /// - `material`: `[B, 6]` (normalised to [0, 1])
    /// - output: `[B, 3n]`, vertex-major (`x0 y0 z0 x1 …`), normalised
    ///
    /// # Panics
    /// If the input widths are not 72 and 6 (Burn's shape assertion).
    pub fn forward(&self, pose: Tensor<2>, material: Tensor<2>) -> Tensor<2> {
        let hidden = self.hidden(self.pose_features(pose), self.material_features(material));
        self.forward_all(hidden)
    }

    /// The pose branch's activation, tanh(W (1 − α) e(θ) + b), with e the configured
    /// [`PoseEncoding`].
    ///
    /// # Shapes
    /// - `pose`: `[B, 72]`
    /// - output: `[B, pose_hidden]`
    pub fn pose_features(&self, pose: Tensor<2>) -> Tensor<2> {
        self.pose_in
            .forward(
                self.config
                    .pose_encoding
                    .encode(pose)
                    .mul_scalar(1.0 - self.config.alpha),
            )
            .tanh()
    }

    /// The material branch's activation, tanh(W α ω + b) (ω projected first when
    /// [`GarMatNetConfig::scale_free_material`] is set). It depends on ω only, so callers
    /// that see the same material every frame can cache it.
    ///
    /// # Shapes
    /// - `material`: `[B, 6]`
    /// - output: `[B, material_hidden]`
    pub fn material_features(&self, material: Tensor<2>) -> Tensor<2> {
        let material = if self.config.scale_free_material {
            // ω − (ω·u) uᵀ, with u the unit scaling direction.
            let u = Material::uniform_scaling_direction().map(|x| x as f32);
            let device = material.device();
            let column = Tensor::<1>::from_floats(u, &device).reshape([MATERIAL_DIM, 1]);
            let along = material.clone().matmul(column.clone());
            material - along.matmul(column.transpose())
        } else {
            material
        };
        self.material_in
            .forward(material.mul_scalar(self.config.alpha))
            .tanh()
    }

    /// The merged hidden layer, dropout(tanh(W [pose ‖ material] + b)).
    ///
    /// # Shapes
    /// - `pose_features`: `[B, pose_hidden]`
    /// - `material_features`: `[B, material_hidden]`
    /// - output: `[B, hidden]`
    pub fn hidden(&self, pose_features: Tensor<2>, material_features: Tensor<2>) -> Tensor<2> {
        let x = Tensor::cat(vec![pose_features, material_features], 1);
        self.dropout.forward(self.merge.forward(x).tanh())
    }

    /// The output layer for all vertices.
    ///
    /// # Shapes
    /// - `hidden`: `[B, hidden]`
    /// - output: `[B, 3n]`
    pub fn forward_all(&self, hidden: Tensor<2>) -> Tensor<2> {
        let y = self.output.forward(hidden);
        match (&self.basis, &self.basis_mean) {
            (Some(basis), Some(mean)) => linear(y, basis.val(), Some(mean.val())),
            _ => y,
        }
    }

    /// The output layer restricted to `vertices` (`None`: all), with the weight/bias (or
    /// basis/mean) columns of those vertices sliced out once.
    ///
    /// # Errors
    /// [`crate::Error::Core`] (out of range) if a vertex index is not below n.
    pub fn output_head(&self, vertices: Option<&[usize]>) -> Result<OutputHead> {
        let weight = self.output.weight.val();
        let bias = self.output.bias.as_ref().map(|b| b.val());
        let bias = bias.unwrap_or_else(|| Tensor::zeros([weight.dims()[1]], &weight.device()));
        let basis = match (&self.basis, &self.basis_mean) {
            (Some(b), Some(m)) => Some((b.val(), m.val())),
            _ => None,
        };
        let Some(vertices) = vertices else {
            return Ok(OutputHead {
                vertices: None,
                weight,
                bias,
                basis,
            });
        };
        if let Some(&bad) = vertices.iter().find(|&&v| v >= self.config.vertex_count) {
            return Err(garmatnet_core::Error::OutOfRange {
                what: "vertex index of the subset".into(),
                value: bad as f64,
                min: 0.0,
                max: (self.config.vertex_count - 1) as f64,
                hint: "; subset indices must address the garment template's vertices".into(),
            }
            .into());
        }
        let columns: Vec<i64> = vertices
            .iter()
            .flat_map(|&v| (0..3).map(move |c| (3 * v + c) as i64))
            .collect();
        let device = weight.device();
        let index =
            Tensor::<1, Int>::from_data(TensorData::new(columns.clone(), [columns.len()]), &device);
        let vertices = Some(vertices.to_vec());
        Ok(match basis {
            // Low rank: all k coefficients are needed; only the basis columns are sliced.
            Some((b, m)) => OutputHead {
                vertices,
                weight,
                bias,
                basis: Some((b.select(1, index.clone()), m.select(0, index))),
            },
            None => OutputHead {
                vertices,
                weight: weight.select(1, index.clone()),
                bias: bias.select(0, index),
                basis: None,
            },
        })
    }

    /// The output layer through a precomputed [`OutputHead`].
    ///
    /// # Shapes
    /// - `hidden`: `[B, hidden]`
    /// - output: `[B, 3m]` for a head of `m` vertices (`m = n` without a subset)
    pub fn forward_head(&self, hidden: Tensor<2>, head: &OutputHead) -> Tensor<2> {
        let y = linear(hidden, head.weight.clone(), Some(head.bias.clone()));
        match &head.basis {
            Some((b, m)) => linear(y, b.clone(), Some(m.clone())),
            None => y,
        }
    }

    /// Sets the low-rank output basis (e.g. PCA components of the normalised training
    /// displacements) and its mean. The basis stays a parameter, so training may fine-tune it.
    ///
    /// # Shapes
    /// - `basis`: `[k, 3n]` (one component per row)
    /// - `mean`: `[3n]`
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] if the net has no low-rank output; [`Error::Shape`] if the
    /// shapes differ from the above.
    pub fn set_output_basis(&mut self, basis: Tensor<2>, mean: Tensor<1>) -> Result<()> {
        let Some(k) = self.output_rank() else {
            return Err(Error::InvalidConfig(
                "set_output_basis needs a net built with output_rank = Some(k)".into(),
            ));
        };
        let n3 = 3 * self.config.vertex_count;
        if basis.dims() != [k, n3] {
            return Err(Error::Shape {
                what: "output basis".into(),
                expected: vec![k, n3],
                got: basis.dims().to_vec(),
            });
        }
        if mean.dims() != [n3] {
            return Err(Error::Shape {
                what: "output basis mean".into(),
                expected: vec![n3],
                got: mean.dims().to_vec(),
            });
        }
        self.basis = Some(Param::from_tensor(basis));
        self.basis_mean = Some(Param::from_tensor(mean));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{cpu, random_inputs, to_vec};
    use approx::assert_abs_diff_eq;

    fn config() -> GarMatNetConfig {
        GarMatNetConfig::new(50, 32, 16, 32)
    }

    #[test]
    fn sizes_beyond_the_parameter_cap_are_refused_not_allocated() {
        let huge = GarMatNetConfig {
            hidden: 1_000_000_000_000,
            ..GarMatNetConfig::new(100, 512, 64, 512)
        };
        let err = huge.validate().unwrap_err().to_string();
        assert!(err.contains("weights"), "{err}");
        let overflow = GarMatNetConfig {
            pose_hidden: usize::MAX,
            ..GarMatNetConfig::new(100, 512, 64, 512)
        };
        assert!(overflow.validate().is_err());
        assert!(GarMatNetConfig::new(4350, 512, 64, 512).validate().is_ok());
    }

    #[test]
    fn forward_shapes_full_and_low_rank() {
        let dev = cpu();
        let (p, m) = random_inputs(4, 1, &dev);
        let net = config().init(&dev);
        assert_eq!(net.forward(p.clone(), m.clone()).dims(), [4, 150]);
        let low = config().with_output_rank(Some(8)).init(&dev);
        assert_eq!(low.output_rank(), Some(8));
        assert_eq!(low.forward(p, m).dims(), [4, 150]);
    }

    #[test]
    fn alpha_zero_ignores_material_and_alpha_one_ignores_pose() {
        let dev = cpu();
        let (p1, m1) = random_inputs(3, 2, &dev);
        let (p2, m2) = random_inputs(3, 3, &dev);
        let net = config().with_alpha(0.0).init(&dev);
        let a = to_vec(net.forward(p1.clone(), m1.clone()));
        let b = to_vec(net.forward(p1.clone(), m2.clone()));
        assert_eq!(a, b, "alpha = 0 must ignore the material");
        assert_ne!(
            a,
            to_vec(net.forward(p2.clone(), m1.clone())),
            "but not the pose"
        );

        let net = config().with_alpha(1.0).init(&dev);
        let a = to_vec(net.forward(p1.clone(), m1.clone()));
        assert_eq!(
            a,
            to_vec(net.forward(p2, m1.clone())),
            "alpha = 1 must ignore the pose"
        );
        assert_ne!(a, to_vec(net.forward(p1, m2)), "but not the material");
    }

    #[test]
    fn scale_free_material_ignores_a_common_scaling_only() {
        let dev = cpu();
        let silk = Material::preset("Silk Charmeuse").unwrap();
        let heavy = silk.scaled(3.0, 3.0).unwrap();
        let stiffer = silk.scaled(3.0, 1.0).unwrap();
        let rows = |ms: [&Material; 3]| {
            let data: Vec<f32> = ms
                .iter()
                .flat_map(|m| m.to_normalized().map(|x| x as f32))
                .collect();
            Tensor::<1>::from_floats(data.as_slice(), &dev).reshape([3, MATERIAL_DIM])
        };
        let material = rows([&silk, &heavy, &stiffer]);
        let (pose, _) = random_inputs(1, 6, &dev);
        let pose = pose.repeat_dim(0, 3);
        for scale_free in [false, true] {
            let net = config().with_scale_free_material(scale_free).init(&dev);
            let out = to_vec(net.forward(pose.clone(), material.clone()));
            let (a, b, c) = (&out[..150], &out[150..300], &out[300..]);
            let gap = |x: &[f32], y: &[f32]| {
                x.iter()
                    .zip(y)
                    .map(|(p, q)| (p - q).abs())
                    .fold(0.0, f32::max)
            };
            if scale_free {
                assert!(gap(a, b) < 1e-5, "a common scaling changed the output");
            } else {
                assert!(gap(a, b) > 1e-3, "the paper's net sees density");
            }
            assert!(gap(a, c) > 1e-3, "stiffness relative to weight must matter");
        }
    }

    #[test]
    fn rotation_encoding_is_rodrigues_at_every_angle() {
        use garmatnet_core::{Mat3, Rot3, Vec3};
        let dev = cpu();
        // Zero, tiny, moderate and near-π angles about assorted axes, one per joint.
        let mut rng = garmatnet_core::SplitMix64::new(9);
        let joints: Vec<Vec3> = (0..2 * JOINT_COUNT)
            .map(|j| {
                let axis =
                    Vec3::new(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), 0.3).normalize();
                let angle = [0.0, 1e-7, 1e-3, 0.4, 1.5, 3.1][j % 6];
                axis * angle
            })
            .collect();
        let pose: Vec<f32> = joints
            .iter()
            .flat_map(|v| v.iter().map(|&x| x as f32))
            .collect();
        let pose = Tensor::<1>::from_floats(pose.as_slice(), &dev).reshape([2, POSE_DIM]);
        let encoded = PoseEncoding::RotationMatrix.encode(pose);
        assert_eq!(encoded.dims(), [2, PoseEncoding::RotationMatrix.width()]);
        let got = to_vec(encoded);
        for (j, v) in joints.iter().enumerate() {
            let want = Rot3::from_scaled_axis(*v).into_inner() - Mat3::identity();
            for r in 0..3 {
                for c in 0..3 {
                    assert_abs_diff_eq!(
                        f64::from(got[9 * j + 3 * r + c]),
                        want[(r, c)],
                        epsilon = 2e-6
                    );
                }
            }
        }
    }

    #[test]
    fn pose_encodings_parse_from_their_names() {
        for e in PoseEncoding::ALL {
            assert_eq!(e.to_string().parse::<PoseEncoding>().unwrap(), e);
        }
        assert_eq!(
            " Rotation_Matrix".parse::<PoseEncoding>().unwrap(),
            PoseEncoding::RotationMatrix
        );
        let bad = "euler".parse::<PoseEncoding>().unwrap_err().to_string();
        assert!(bad.contains("rotation-matrix"), "{bad}");
    }

    #[test]
    fn rotation_encoding_sees_rotations_not_their_axis_angle_spelling() {
        let dev = cpu();
        // One joint at 3.0 rad about x, and the same rotation written as 3.0 − 2π about x:
        // axis-angle inputs far apart, one rotation.
        let mut a = vec![0.0f32; 2 * POSE_DIM];
        a[3] = 3.0;
        a[POSE_DIM + 3] = (3.0 - std::f64::consts::TAU) as f32;
        let pose = Tensor::<1>::from_floats(a.as_slice(), &dev).reshape([2, POSE_DIM]);
        let (_, m) = random_inputs(1, 7, &dev);
        let m = m.repeat_dim(0, 2);
        for (encoding, same) in [
            (PoseEncoding::RotationMatrix, true),
            (PoseEncoding::AxisAngle, false),
        ] {
            let net = config().with_pose_encoding(encoding).init(&dev);
            let out = to_vec(net.forward(pose.clone(), m.clone()));
            let gap = out[..150]
                .iter()
                .zip(&out[150..])
                .map(|(p, q)| (p - q).abs())
                .fold(0.0, f32::max);
            assert_eq!(gap < 1e-5, same, "{encoding:?}: gap {gap}");
        }
    }

    #[test]
    fn subset_head_matches_full_output_columns() {
        let dev = cpu();
        let (p, m) = random_inputs(3, 4, &dev);
        for rank in [None, Some(6)] {
            let net = config().with_output_rank(rank).init(&dev);
            let full = to_vec(net.forward(p.clone(), m.clone()));
            let subset = [7usize, 0, 49, 13];
            let head = net.output_head(Some(&subset)).unwrap();
            let h = net.hidden(
                net.pose_features(p.clone()),
                net.material_features(m.clone()),
            );
            let part = to_vec(net.forward_head(h, &head));
            for b in 0..3 {
                for (i, &v) in subset.iter().enumerate() {
                    for c in 0..3 {
                        assert_abs_diff_eq!(
                            part[b * 12 + 3 * i + c],
                            full[b * 150 + 3 * v + c],
                            epsilon = 1e-5
                        );
                    }
                }
            }
        }
        let net = config().init(&dev);
        assert!(net.output_head(Some(&[50])).is_err());
    }

    #[test]
    fn set_output_basis_checks_shapes() {
        let dev = cpu();
        let mut net = config().with_output_rank(Some(4)).init(&dev);
        assert!(
            net.set_output_basis(Tensor::zeros([4, 149], &dev), Tensor::zeros([150], &dev))
                .is_err()
        );
        net.set_output_basis(Tensor::zeros([4, 150], &dev), Tensor::ones([150], &dev))
            .unwrap();
        let (p, m) = random_inputs(2, 5, &dev);
        assert!(to_vec(net.forward(p, m)).iter().all(|&v| v == 1.0));
        let mut full = config().init(&dev);
        assert!(
            full.set_output_basis(Tensor::zeros([4, 150], &dev), Tensor::zeros([150], &dev))
                .is_err()
        );
    }

    #[test]
    fn invalid_configs_are_refused() {
        assert!(config().with_alpha(1.5).validate().is_err());
        assert!(config().with_dropout(1.0).validate().is_err());
        assert!(config().with_output_rank(Some(151)).validate().is_err());
        assert!(GarMatNetConfig::new(0, 1, 1, 1).validate().is_err());
        assert!(config().validate().is_ok());
    }
}
