//! The paper's baseline (§4): a TailorNet-style MLP of the pose alone, trained once per
//! material: θ → Linear → tanh → Linear → tanh → dropout → Linear → 3n.

use burn::module::{Initializer, Param};
use burn::nn::{Dropout, DropoutConfig, Linear, LinearConfig};
use burn::prelude::*;

use crate::error::{Error, Result};

/// Configuration of a [`BaselineNet`].
#[derive(Config, Debug)]
pub struct BaselineNetConfig {
    /// The number of garment vertices n; the output has 3n values.
    pub vertex_count: usize,
    /// Width of the first hidden layer.
    pub pose_hidden: usize,
    /// Width of the second hidden layer.
    pub hidden: usize,
    /// Length of the pose input θ.
    #[config(default = 72)]
    pub pose_dim: usize,
    /// Dropout probability after the second hidden layer.
    #[config(default = 0.1)]
    pub dropout: f64,
    /// Kaiming-normal gain of the hidden layers (5/3 for tanh); the output layer uses 1.
    #[config(default = 1.6666666666666667)]
    pub init_gain: f64,
}

impl BaselineNetConfig {
    /// Checks sizes (positive, at most [`crate::MAX_PARAMETERS`] weights), the dropout
    /// probability and the initialisation gain.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] naming the field to change.
    pub fn validate(&self) -> Result<()> {
        if self.vertex_count == 0 || self.pose_hidden == 0 || self.hidden == 0 || self.pose_dim == 0
        {
            return Err(Error::InvalidConfig(
                "every size of the baseline must be positive".into(),
            ));
        }
        if !(0.0..1.0).contains(&self.dropout) {
            return Err(Error::InvalidConfig(format!(
                "dropout = {} must lie in [0, 1)",
                self.dropout
            )));
        }
        if !(self.init_gain.is_finite() && self.init_gain > 0.0) {
            return Err(Error::InvalidConfig(format!(
                "init_gain = {} must be a positive number (5/3 for tanh)",
                self.init_gain
            )));
        }
        crate::net::garmatnet_net::check_parameter_count(
            "the baseline",
            &[
                (self.pose_dim, self.pose_hidden),
                (self.pose_hidden, self.hidden),
                (self.hidden, self.vertex_count.saturating_mul(3)),
            ],
        )
    }

    /// A baseline with Kaiming-normal weights and zero biases.
    ///
    /// # Panics
    /// If the configuration is invalid (see [`BaselineNetConfig::validate`]).
    #[must_use]
    pub fn init(&self, device: &Device) -> BaselineNet {
        if let Err(e) = self.validate() {
            panic!("BaselineNetConfig::init on an invalid configuration: {e}");
        }
        let layer = |d_in, d_out, gain| {
            let init = Initializer::KaimingNormal {
                gain,
                fan_out_only: false,
            };
            let mut l = LinearConfig::new(d_in, d_out)
                .with_initializer(init)
                .init(device);
            l.bias = Some(Param::from_tensor(Tensor::zeros([d_out], device)));
            l
        };
        BaselineNet {
            first: layer(self.pose_dim, self.pose_hidden, self.init_gain),
            second: layer(self.pose_hidden, self.hidden, self.init_gain),
            dropout: DropoutConfig::new(self.dropout).init(),
            output: layer(self.hidden, 3 * self.vertex_count, 1.0),
        }
    }
}

/// The TailorNet-style baseline MLP (one instance per material).
#[derive(Module, Debug)]
pub struct BaselineNet {
    first: Linear,
    second: Linear,
    dropout: Dropout,
    output: Linear,
}

impl BaselineNet {
    /// Normalised displacements for a batch of poses.
    ///
    /// # Shapes
    /// - `pose`: `[B, 72]`
    /// - output: `[B, 3n]`
    pub fn forward(&self, pose: Tensor<2>) -> Tensor<2> {
        let x = self.first.forward(pose).tanh();
        let x = self.dropout.forward(self.second.forward(x).tanh());
        self.output.forward(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{cpu, random_inputs, to_vec};

    #[test]
    fn forward_shape_and_pose_dependence() {
        let dev = cpu();
        let net = BaselineNetConfig::new(50, 32, 32).init(&dev);
        let (p1, _) = random_inputs(2, 1, &dev);
        let (p2, _) = random_inputs(2, 2, &dev);
        let a = net.forward(p1);
        assert_eq!(a.dims(), [2, 150]);
        assert_ne!(to_vec(a), to_vec(net.forward(p2)));
        assert!(
            BaselineNetConfig::new(50, 32, 32)
                .with_dropout(1.0)
                .validate()
                .is_err()
        );
    }

    #[test]
    fn invalid_configurations_are_refused_by_validate() {
        let good = BaselineNetConfig::new(50, 32, 32);
        good.validate().unwrap();
        for bad in [
            BaselineNetConfig::new(50, 32, 0),
            BaselineNetConfig::new(0, 32, 32),
            BaselineNetConfig::new(50, 32, 32).with_pose_dim(0),
            BaselineNetConfig::new(50, 32, 32).with_dropout(f64::NAN),
            BaselineNetConfig::new(50, 32, 32).with_init_gain(0.0),
            BaselineNetConfig::new(50, 32, 32).with_init_gain(f64::INFINITY),
        ] {
            assert!(
                matches!(bad.validate(), Err(Error::InvalidConfig(_))),
                "{bad:?} was accepted"
            );
        }
    }
}
