//! Cloth-body contact helpers: an empty collider, smooth lagged Coulomb friction on a
//! contact vertex and on all the contacts of one drape, and the final projection out of the
//! collider.

use garmatnet_core::{Mat3, Real, SignedDistance, Vec3};

use crate::solver::drape_energy::{Contact, DrapeEnergy};

/// A collider that is nowhere: for cloth that only hangs from its pins.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EmptySpace;

impl SignedDistance for EmptySpace {
    fn distance_and_gradient(&self, _p: &Vec3) -> (Real, Vec3) {
        (Real::INFINITY, Vec3::y())
    }
}

/// Smooth Coulomb friction on one contact vertex, lagged at the start of a drape (the
/// incremental-potential-contact formulation of Li et al. 2020, for a quasi-static step): with the contact's outward unit `normal` and `weight = μ λ` (the friction
/// coefficient times the normal force, newtons) held fixed, the vertex's tangential slip
/// `u = (I - n nᵀ)(x - a)` from its anchor `a` (where it sat before the step, carried
/// with the body) costs `D(u) = μ λ f0(|u|)`. `f0` is `|u|` beyond the slip length `ε`
/// (sliding: a force of exactly `μ λ` against the slip) and a cubic blend below it (static
/// friction as a spring of stiffness `2 μ λ / ε` at rest) whose first and second
/// derivatives meet those of `|u|` at `ε`, so `D` is twice continuously differentiable and
/// convex in `u`, and Newton can converge on it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct FrictionContact {
    /// Outward unit normal of the contact.
    pub(crate) normal: Vec3,
    /// Friction coefficient times normal force (newtons).
    pub(crate) weight: Real,
}

impl FrictionContact {
    /// The tangential slip of `offset = x - anchor`.
    fn slip(&self, offset: &Vec3) -> Vec3 {
        offset - self.normal * offset.dot(&self.normal)
    }

    /// `D` (joules) at `offset = x - anchor`, for slip length `epsilon` (metres).
    pub(crate) fn potential(&self, offset: &Vec3, epsilon: Real) -> Real {
        let y = self.slip(offset).norm();
        self.weight
            * if y < epsilon {
                y * y / epsilon - y * y * y / (3.0 * epsilon * epsilon) + epsilon / 3.0
            } else {
                y
            }
    }

    /// The friction force `-∇D` (newtons) at `offset = x - anchor`.
    pub(crate) fn force(&self, offset: &Vec3, epsilon: Real) -> Vec3 {
        let u = self.slip(offset);
        let y = u.norm();
        // f1(y) / y, with f1 = f0': bounded as y -> 0.
        let scale = if y < epsilon {
            2.0 / epsilon - y / (epsilon * epsilon)
        } else {
            1.0 / y
        };
        -u * (self.weight * scale)
    }

    /// The Hessian of `D` at `offset = x - anchor`: positive semi-definite everywhere (no
    /// projection needed), zero along the normal.
    pub(crate) fn hessian(&self, offset: &Vec3, epsilon: Real) -> Mat3 {
        let tangent = Mat3::identity() - self.normal * self.normal.transpose();
        let u = self.slip(offset);
        let y = u.norm();
        if y < epsilon {
            // f1'(y) along the slip, f1(y)/y across it; both 2/ε at y = 0.
            let across = 2.0 / epsilon - y / (epsilon * epsilon);
            let along = 2.0 / epsilon - 2.0 * y / (epsilon * epsilon);
            let uu = if y > 0.0 {
                let d = u / y;
                d * d.transpose()
            } else {
                Mat3::zeros()
            };
            (tangent * across + uu * (along - across)) * self.weight
        } else {
            let d = u / y;
            (tangent - d * d.transpose()) * (self.weight / y)
        }
    }
}

/// Moves every vertex found inside the collider onto its surface (in a blend region of a
/// smooth union, up to [`garmatnet_core::PUSH_SLACK`] past it), so that the reported
/// penetration is what the penalty left behind, not hidden by it. Returns the largest
/// penetration depth (metres) remaining afterwards, measured with the collider itself.
pub(crate) fn push_out(
    positions: &mut [Vec3],
    collider: &impl SignedDistance,
    pinned: &[bool],
) -> Real {
    let mut deepest: Real = 0.0;
    for (x, &is_pinned) in positions.iter_mut().zip(pinned) {
        if is_pinned {
            continue;
        }
        *x = collider.push_outside(x, 0.0);
        deepest = deepest.max(-collider.distance(x));
    }
    deepest
}

/// The friction of one drape: the starting contacts' lagged normals and `μ λ`, and the
/// anchors.
pub(crate) struct Friction<'a> {
    coefficient: Real,
    slip: Real,
    anchors: &'a [Vec3],
    lagged: Vec<Option<FrictionContact>>,
}

impl<'a> Friction<'a> {
    /// Friction measured from `anchors`, with no contact lagged yet.
    pub(crate) fn new(coefficient: Real, slip: Real, anchors: &'a [Vec3]) -> Self {
        Self {
            coefficient,
            slip,
            anchors,
            lagged: vec![None; anchors.len()],
        }
    }

    /// Gives friction to every contact of the starting positions (`contacts` are their
    /// contacts, `conservative` their energy gradient, friction not included), lagging its
    /// normal and `μ λ` there for the whole drape.
    ///
    /// The normal force `λ` is the load the body carries, `n · ∇(E - penalty)` (springs and
    /// gravity pressing the vertex in), not the penalty's own force: the two agree at
    /// equilibrium, but a warm start carried with the body sits a fraction of a millimetre
    /// off it, where the stiff penalty's force is hundreds of times the vertex's weight and
    /// friction lagged at it glues the shirt in place.
    pub(crate) fn lag(
        &mut self,
        energy: &DrapeEnergy<'_>,
        contacts: &[Option<Contact>],
        conservative: &[Vec3],
    ) {
        if self.coefficient == 0.0 {
            return;
        }
        for (i, (c, l)) in contacts.iter().zip(self.lagged.iter_mut()).enumerate() {
            *l = c.map(|c| {
                let normal = c.normal();
                let load = (conservative[i] + energy.penalty_force(i, &c)).dot(&normal);
                FrictionContact {
                    normal,
                    weight: self.coefficient * load.max(0.0),
                }
            });
        }
    }

    /// Adds `∇D` at `x` to `gradient`; returns the total friction force on the cloth.
    pub(crate) fn add_to_gradient(&self, x: &[Vec3], gradient: &mut [Vec3]) -> Vec3 {
        let mut total = Vec3::zeros();
        for (i, l) in self.lagged.iter().enumerate() {
            if let Some(l) = l {
                let f = l.force(&(x[i] - self.anchors[i]), self.slip);
                gradient[i] -= f;
                total += f;
            }
        }
        total
    }

    pub(crate) fn add_hessian(&self, x: &[Vec3], diagonal: &mut [Mat3]) {
        for (i, l) in self.lagged.iter().enumerate() {
            if let Some(l) = l {
                diagonal[i] += l.hessian(&(x[i] - self.anchors[i]), self.slip);
            }
        }
    }

    /// `D(x1) - D(x0)` (joules).
    pub(crate) fn change(&self, x0: &[Vec3], x1: &[Vec3]) -> Real {
        self.lagged
            .iter()
            .enumerate()
            .filter_map(|(i, l)| {
                l.map(|l| {
                    l.potential(&(x1[i] - self.anchors[i]), self.slip)
                        - l.potential(&(x0[i] - self.anchors[i]), self.slip)
                })
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use garmatnet_core::Sphere;

    fn unit_sphere() -> Sphere {
        Sphere {
            centre: Vec3::zeros(),
            radius: 1.0,
        }
    }

    #[test]
    fn friction_force_and_hessian_are_the_potentials_derivatives() {
        let c = FrictionContact {
            normal: Vec3::new(0.2, 0.9, -0.1).normalize(),
            weight: 0.7,
        };
        let eps = 1e-3;
        // Static (slip below eps), at the blend, and sliding.
        for offset in [
            Vec3::new(2e-4, -3e-4, 1e-4),
            Vec3::new(6e-4, 5e-4, -4e-4),
            Vec3::new(3e-3, 1e-3, -2e-3),
        ] {
            let h = 1e-8;
            let f = c.force(&offset, eps);
            let k = c.hessian(&offset, eps);
            for axis in 0..3 {
                let mut plus = offset;
                let mut minus = offset;
                plus[axis] += h;
                minus[axis] -= h;
                let dd = (c.potential(&plus, eps) - c.potential(&minus, eps)) / (2.0 * h);
                assert_relative_eq!(-f[axis], dd, epsilon = 1e-6, max_relative = 1e-5);
                let df = (c.force(&plus, eps) - c.force(&minus, eps)) / (2.0 * h);
                for row in 0..3 {
                    assert_relative_eq!(
                        k[(row, axis)],
                        -df[row],
                        epsilon = 1e-3,
                        max_relative = 1e-4
                    );
                }
            }
            // Nothing along the normal; never more than mu * lambda.
            assert!(f.dot(&c.normal).abs() < 1e-12);
            assert!(f.norm() <= c.weight * (1.0 + 1e-12));
            assert!((k * c.normal).norm() < 1e-9);
            assert!(k.symmetric_eigenvalues().iter().all(|e| *e >= -1e-9));
        }
        // Sliding: exactly mu * lambda against the slip.
        let slide = Vec3::new(0.01, 0.0, 0.0);
        let t = c.slip(&slide).normalize();
        assert_relative_eq!(c.force(&slide, eps), -t * c.weight, epsilon = 1e-12);
        // At rest: no force, a spring of 2 mu lambda / eps across the contact.
        assert_eq!(c.force(&Vec3::zeros(), eps), Vec3::zeros());
        assert_relative_eq!(
            c.hessian(&Vec3::zeros(), eps).trace(),
            2.0 * 2.0 * c.weight / eps,
            max_relative = 1e-12
        );
    }

    #[test]
    fn push_out_leaves_no_penetration_and_skips_pins() {
        let s = unit_sphere();
        let mut p = vec![
            Vec3::new(0.0, 0.5, 0.0),
            Vec3::new(0.3, 0.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
        ];
        let deepest = push_out(&mut p, &s, &[false, true, false]);
        assert!(deepest <= 1e-12);
        assert_relative_eq!(p[0], Vec3::y(), epsilon = 1e-12);
        assert_eq!(p[1], Vec3::new(0.3, 0.0, 0.0));
        assert_eq!(p[2], Vec3::new(0.0, 2.0, 0.0));
    }
}
