//! The posed capsule body's signed distance in tensors: each tapered capsule's exact
//! distance ([`garmatnet_core::CapsuleGeometry`]) and their smooth union, differentiable in
//! the query points, for a batch of bodies in different poses.

use burn::prelude::*;
use burn::tensor::DType;
use garmatnet_core::{CapsuleGeometry, Error as CoreError, PosedBody, Real};

use crate::error::Result;

/// Below this squared length (metres²) a point counts as on a capsule's axis or centre:
/// lengths are taken as `sqrt(max(|v|², ε))` so their derivative stays finite there
/// (`1e-24` m², 1e-12 m: the CPU distance's own threshold).
const TINY_SQUARED: f64 = 1e-24;

/// A batch of posed capsule bodies as tensors: one row per body, one column per capsule,
/// in the body's order (the union folds them in that order).
#[derive(Debug, Clone)]
pub struct CapsuleTensors {
    /// One capsule end per body and capsule (metres), `[B, C, 3]`.
    a: Tensor<3>,
    /// The other end (metres), `[B, C, 3]`.
    b: Tensor<3>,
    /// Unit axis from `a` to `b`, `[B, C, 3]`.
    axis: Tensor<3>,
    /// Radius at `a` (metres), `[B, C]`.
    radius_a: Tensor<2>,
    /// Radius at `b` (metres), `[B, C]`.
    radius_b: Tensor<2>,
    /// The side's outward normal along the axis, `[B, C]`.
    normal_axial: Tensor<2>,
    /// The side's outward normal away from the axis, `[B, C]`.
    normal_radial: Tensor<2>,
    /// Where the side ends along its tangent (metres), `[B, C]`.
    side_end: Tensor<2>,
    /// The union's smooth-min blend radius (metres).
    blend_radius: Real,
    capsules: usize,
}

impl CapsuleTensors {
    /// The capsules of `bodies` (one per sample) on `device`, in float type `dtype`.
    ///
    /// # Errors
    /// [`CoreError::InvalidArgument`] for no body; [`CoreError::Mismatch`] if the bodies
    /// differ in capsule count or blend radius (they must be one body in several poses).
    pub fn new(bodies: &[&PosedBody], device: &Device, dtype: DType) -> Result<Self> {
        let first = bodies.first().ok_or_else(|| {
            CoreError::InvalidArgument("a capsule batch needs at least one posed body".into())
        })?;
        let blend_radius = first.body().blend_radius();
        let geometry: Vec<Vec<CapsuleGeometry>> =
            bodies.iter().map(|b| b.capsule_geometry()).collect();
        let capsules = geometry[0].len();
        for (i, (g, body)) in geometry.iter().zip(bodies).enumerate() {
            if g.len() != capsules || body.body().blend_radius() != blend_radius {
                return Err(CoreError::Mismatch {
                    what: format!("capsule body of sample {i}"),
                    expected: format!("{capsules} capsules blended over {blend_radius} m"),
                    got: format!(
                        "{} capsules blended over {} m",
                        g.len(),
                        body.body().blend_radius()
                    ),
                }
                .into());
            }
        }
        let batch = bodies.len();
        let vector = |f: fn(&CapsuleGeometry) -> [Real; 3]| {
            let v: Vec<f64> = geometry.iter().flatten().flat_map(f).collect();
            Tensor::<3>::from_data(TensorData::new(v, [batch, capsules, 3]), (device, dtype))
        };
        let scalar = |f: fn(&CapsuleGeometry) -> Real| {
            let v: Vec<f64> = geometry.iter().flatten().map(f).collect();
            Tensor::<2>::from_data(TensorData::new(v, [batch, capsules]), (device, dtype))
        };
        Ok(Self {
            a: vector(|g| g.a.into()),
            b: vector(|g| g.b.into()),
            axis: vector(|g| g.axis.into()),
            radius_a: scalar(|g| g.radius_a),
            radius_b: scalar(|g| g.radius_b),
            normal_axial: scalar(|g| g.normal_axial),
            normal_radial: scalar(|g| g.normal_radial),
            side_end: scalar(|g| g.side_end),
            blend_radius,
            capsules,
        })
    }

    /// The number of bodies `B`.
    #[must_use]
    pub fn batch(&self) -> usize {
        self.a.dims()[0]
    }

    /// The number of capsules `C` per body.
    #[must_use]
    pub fn capsule_count(&self) -> usize {
        self.capsules
    }

    /// The union's blend radius (metres).
    #[must_use]
    pub fn blend_radius(&self) -> Real {
        self.blend_radius
    }

    /// Every capsule's exact signed distance (metres) at every point, as
    /// `garmatnet_core`'s capsule computes it (sphere at `a`, conical side or sphere at `b`,
    /// by where the point lies along the side's tangent).
    ///
    /// # Shapes
    /// `x`: `[B, n, 3]` (metres) → `[B, n, C]`.
    #[must_use]
    pub fn capsule_distances(&self, x: Tensor<3>) -> Tensor<3> {
        let [batch, n, _] = x.dims();
        let c = self.capsules;
        let x = x.unsqueeze_dim::<4>(2); // [B, n, 1, 3]
        let per_capsule = |t: &Tensor<2>| t.clone().unsqueeze_dim::<3>(1); // [B, 1, C]
        let d = x.clone() - self.a.clone().unsqueeze_dim::<4>(1); // [B, n, C, 3]
        let axis = self.axis.clone().unsqueeze_dim::<4>(1);
        let axial = (d.clone() * axis.clone()).sum_dim(3); // [B, n, C, 1]
        let radial_vec = d.clone() - axis * axial.clone();
        let axial: Tensor<3> = axial.squeeze_dim(3);
        let radial = safe_norm(radial_vec);
        let (na, nr) = (
            per_capsule(&self.normal_axial),
            per_capsule(&self.normal_radial),
        );
        let along_side = axial.clone() * nr.clone() - radial.clone() * na.clone();
        let sphere_a = safe_norm(d) - per_capsule(&self.radius_a);
        let sphere_b =
            safe_norm(x - self.b.clone().unsqueeze_dim::<4>(1)) - per_capsule(&self.radius_b);
        let side = axial * na + radial * nr - per_capsule(&self.radius_a);
        let past_b = along_side
            .clone()
            .greater_equal(per_capsule(&self.side_end).expand([batch, n, c]));
        let before_a = along_side.lower_equal_elem(0.0);
        side.mask_where(past_b, sphere_b)
            .mask_where(before_a, sphere_a)
    }

    /// The body's signed distance (metres) at every point: the smooth union
    /// ([`smooth_union`]) of [`CapsuleTensors::capsule_distances`].
    ///
    /// # Shapes
    /// `x`: `[B, n, 3]` (metres) → `[B, n]`.
    #[must_use]
    pub fn distance(&self, x: Tensor<3>) -> Tensor<2> {
        smooth_union(self.capsule_distances(x), self.blend_radius)
    }
}

/// The capsules' union: `garmatnet_core`'s rule, a left fold over the capsules (in the
/// body's order) of the quadratic polynomial smooth-min
/// `smin(a, b) = mix(b, a, h) - k h (1 - h)`, `h = clamp(1/2 + (b - a) / 2k, 0, 1)`, with
/// blend radius `k` (metres). Its autodiff gradient is `mix(∇b, ∇a, h)`, the CPU field's.
/// The one place the blend rule lives on the tensor side: change it here when the body's
/// changes.
///
/// # Shapes
/// `distances`: `[B, n, C]` (metres) → `[B, n]`.
#[must_use]
pub fn smooth_union(distances: Tensor<3>, blend_radius: Real) -> Tensor<2> {
    let capsules = distances.dims()[2];
    let column = |c: usize| -> Tensor<2> { distances.clone().narrow(2, c, 1).squeeze_dim(2) };
    let mut union = column(0);
    for c in 1..capsules {
        union = smooth_min(union, column(c), blend_radius);
    }
    union
}

/// The polynomial smooth-min of `running` and `next` over blend radius `k` (metres): equal
/// to the smaller where they differ by `k` or more.
///
/// # Shapes
/// `running`, `next`: `[B, n]` → `[B, n]`.
fn smooth_min(running: Tensor<2>, next: Tensor<2>, k: Real) -> Tensor<2> {
    let h = (next.clone() - running.clone())
        .div_scalar(2.0 * k)
        .add_scalar(0.5)
        .clamp(0.0, 1.0);
    let bulge = h.clone() * (h.clone().neg().add_scalar(1.0)) * k;
    next.clone() + h * (running - next) - bulge
}

/// `sqrt(max(|v|², ε))` along the last axis, so the derivative stays finite at `v = 0`.
///
/// # Shapes
/// `v`: `[B, n, C, 3]` → `[B, n, C]`.
fn safe_norm(v: Tensor<4>) -> Tensor<3> {
    v.square()
        .sum_dim(3)
        .squeeze_dim::<3>(3)
        .clamp_min(TINY_SQUARED)
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use garmatnet_core::{CapsuleBody, JointLimits, SignedDistance, SplitMix64, Vec3};

    /// Random points from 3 cm inside to 5 cm outside the posed surfaces of random poses:
    /// the tensor distance and its autodiff gradient are the CPU field's (in f64, to
    /// rounding), blend regions included.
    #[test]
    fn distance_and_gradient_match_the_capsule_body() {
        let body = CapsuleBody::smpl_neutral();
        let limits = JointLimits::default();
        let mut rng = SplitMix64::new(17);
        let posed: Vec<_> = (0..3)
            .map(|_| body.pose(&limits.sample(&mut rng, 1.0)))
            .collect();
        let refs: Vec<_> = posed.iter().collect();
        let ad = Device::flex().autodiff();
        let caps = CapsuleTensors::new(&refs, &ad, DType::F64).unwrap();
        assert_eq!(caps.capsule_count(), body.capsules().len());
        let n = 2000;
        let mut points = Vec::new();
        for p in &posed {
            let mesh = p.mesh();
            for _ in 0..n {
                let v = mesh.vertices[rng.below(mesh.vertices.len())];
                let normal = p.distance_and_normal(&v).1;
                points.push(v + normal * rng.uniform(-0.03, 0.05));
            }
        }
        let flat: Vec<f64> = points.iter().flat_map(|v| [v.x, v.y, v.z]).collect();
        let x = Tensor::<3>::from_data(TensorData::new(flat, [3, n, 3]), (&ad, DType::F64))
            .require_grad();
        let d = caps.distance(x.clone());
        let grads = d.clone().sum().backward();
        let g: Vec<f64> = x
            .grad(&grads)
            .unwrap()
            .into_data()
            .try_into_vec_as::<f64>()
            .unwrap();
        let d: Vec<f64> = d.into_data().try_into_vec_as::<f64>().unwrap();
        let (mut blended, mut inside) = (0, 0);
        for (i, p) in points.iter().enumerate() {
            let (expected, gradient) = posed[i / n].distance_and_gradient(p);
            assert!(
                (d[i] - expected).abs() < 1e-12,
                "{i}: {} vs {expected}",
                d[i]
            );
            let got = Vec3::new(g[3 * i], g[3 * i + 1], g[3 * i + 2]);
            assert!(
                (got - gradient).norm() < 1e-9,
                "{i}: {got:?} vs {gradient:?}"
            );
            blended += usize::from(gradient.norm() < 0.999);
            inside += usize::from(expected < 0.0);
        }
        assert!(
            blended > 20 && inside > 500,
            "{blended} blended, {inside} inside"
        );
    }

    #[test]
    fn bodies_of_different_shapes_and_an_empty_batch_are_typed_errors() {
        let ad = Device::flex();
        assert!(matches!(
            CapsuleTensors::new(&[], &ad, DType::F32),
            Err(crate::Error::Core(CoreError::InvalidArgument(_)))
        ));
        let neutral = CapsuleBody::smpl_neutral();
        let skeleton = garmatnet_core::Skeleton::smpl_neutral();
        let fewer = CapsuleBody::new(skeleton, neutral.capsules()[..5].to_vec(), 0.03).unwrap();
        let pose = garmatnet_core::Pose::zero();
        let (a, b) = (neutral.pose(&pose), fewer.pose(&pose));
        assert!(matches!(
            CapsuleTensors::new(&[&a, &b], &ad, DType::F32),
            Err(crate::Error::Core(CoreError::Mismatch { .. }))
        ));
    }
}
