//! The posed body's signed distance where the contact energy needs it, from the body itself.
//!
//! The solver's contact penalty reads the body's field: the capsules' smooth union within each
//! part, the limb roots' blend balls and the channel left where two parts press together
//! ([`garmatnet_core::PINCH_HALF_WIDTH`]). Rather than a second, tensor copy of that rule
//! (which would have to follow every change to it), [`BodyField`] asks the body: at the
//! garment's current positions `x₀` it evaluates each vertex's distance `d₀` and gradient
//! `n₀` in f64 ([`SignedDistance::distance_and_gradient`]) and stands for the field by its
//! first-order expansion `d(x) = d₀ + n₀ · (x - x₀)`. At `x = x₀`, the only point the
//! energy is ever evaluated at, its value and its derivative are the body's own, so the
//! energy and its gradient are the solver's to the float type's precision. (Its second
//! derivative is not: a Newton step on the energy would need the field's curvature, which
//! gradient descent on the nets' weights never asks for.)

use burn::prelude::*;
use garmatnet_core::{Error as CoreError, PosedBody, SignedDistance, Vec3};

use crate::error::Result;

/// The posed bodies' distance fields, linearised at a batch of garments (see the module
/// docs).
#[derive(Debug, Clone)]
pub struct BodyField {
    /// Where the field was evaluated (metres), `[B, n, 3]`, no gradient.
    at: Tensor<3>,
    /// The distance there (metres), `[B, n]`.
    distance: Tensor<2>,
    /// The distance's gradient there, `[B, n, 3]`.
    gradient: Tensor<3>,
}

impl BodyField {
    /// Each body of `bodies` (one per sample) evaluated at its garment in `x` (metres),
    /// on `x`'s device and in its float type.
    ///
    /// # Shapes
    /// `x`: `[B, n, 3]`, `B = bodies.len()`.
    ///
    /// # Errors
    /// [`CoreError::Mismatch`] if `x` is not `[bodies.len(), n, 3]`;
    /// [`crate::Error::TensorRead`] if its values cannot be read back from the device.
    pub fn at(bodies: &[PosedBody], x: &Tensor<3>) -> Result<Self> {
        let [batch, n, three] = x.dims();
        if batch != bodies.len() || three != 3 {
            return Err(CoreError::Mismatch {
                what: "garment positions of a body field".into(),
                expected: format!("[{}, n, 3]", bodies.len()),
                got: format!("[{batch}, {n}, {three}]"),
            }
            .into());
        }
        let (device, dtype) = (x.device(), x.dtype());
        let flat: Vec<f64> = x
            .clone()
            .into_data()
            .try_into_vec_as::<f64>()
            .map_err(|source| crate::Error::TensorRead {
                what: "garment positions of a body field",
                source,
            })?;
        let fields: Vec<(f64, Vec3)> = flat
            .chunks_exact(3)
            .enumerate()
            .map(|(k, p)| bodies[k / n].distance_and_gradient(&Vec3::new(p[0], p[1], p[2])))
            .collect();
        let distance: Vec<f64> = fields.iter().map(|f| f.0).collect();
        let gradient: Vec<f64> = fields.iter().flat_map(|f| [f.1.x, f.1.y, f.1.z]).collect();
        Ok(Self {
            at: Tensor::from_data(TensorData::new(flat, [batch, n, 3]), (&device, dtype)),
            distance: Tensor::from_data(TensorData::new(distance, [batch, n]), (&device, dtype)),
            gradient: Tensor::from_data(TensorData::new(gradient, [batch, n, 3]), (&device, dtype)),
        })
    }

    /// The number of bodies `B`.
    #[must_use]
    pub fn batch(&self) -> usize {
        self.distance.dims()[0]
    }

    /// The signed distance (metres) of garments `x` to the bodies, differentiable in `x`:
    /// the body's own at the positions the field was evaluated at.
    ///
    /// # Shapes
    /// `x`: `[B, n, 3]` → `[B, n]`.
    #[must_use]
    pub fn distance(&self, x: Tensor<3>) -> Tensor<2> {
        let moved: Tensor<2> = ((x - self.at.clone()) * self.gradient.clone())
            .sum_dim(2)
            .squeeze_dim(2);
        self.distance.clone() + moved
    }
}
