//! Bodies as signed distance fields: the contract between the body, the garment template,
//! the solver's contact handling and the predictor's push-out.

use crate::body::skeleton::Skeleton;
use crate::math::{Real, Vec3};

/// The outward unit normal of a distance field with gradient `gradient`: the gradient
/// normalised, `+y` where it vanishes (the rule [`SignedDistance::distance_and_normal`]
/// uses, for callers that already hold a gradient).
#[must_use]
pub fn unit_normal(gradient: &Vec3) -> Vec3 {
    gradient.try_normalize(1e-12).unwrap_or_else(Vec3::y)
}

/// A closed surface given by its signed distance: metres, negative inside, positive outside.
pub trait SignedDistance: Sync {
    /// The signed distance at `p` and its gradient there: the exact derivative of
    /// [`SignedDistance::distance`] wherever the field is differentiable, so forces derived
    /// from a potential of the distance agree with that potential. Unit length for a true
    /// distance field; shorter (never longer) in the blend regions of a smooth union, which
    /// is only a distance bound there. Where the field is not differentiable, any vector of
    /// length at most one.
    fn distance_and_gradient(&self, p: &Vec3) -> (Real, Vec3);

    /// The signed distance at `p` and the outward unit normal: the gradient normalised
    /// (`+y` where it vanishes).
    fn distance_and_normal(&self, p: &Vec3) -> (Real, Vec3) {
        let (d, g) = self.distance_and_gradient(p);
        (d, unit_normal(&g))
    }

    /// The signed distance at `p`.
    fn distance(&self, p: &Vec3) -> Real {
        self.distance_and_gradient(p).0
    }

    /// The closest surface point to `p`: Newton steps along the normal until the distance
    /// is below 0.1 mm (one step for true distance fields; smooth unions of primitives are
    /// only distance *bounds* in their blend regions, where each step recovers part of it).
    fn project(&self, p: &Vec3) -> Vec3 {
        let mut x = *p;
        for _ in 0..PROJECTION_STEPS {
            let (d, g) = self.distance_and_normal(&x);
            if d.is_nan() || d.abs() < 1e-4 {
                break;
            }
            x -= g * d;
        }
        x
    }

    /// `p` moved along the normal until it is at least `clearance` metres outside the
    /// surface; points already that far out are returned unchanged.
    ///
    /// Each step is a Newton step along the normal, the remaining gap divided by the
    /// gradient's length, capped at the gap plus [`PUSH_SLACK`]. A true distance field
    /// needs one step. In a smooth union's blend regions the gradient is short (it vanishes
    /// in the crevice between two limbs), and steps of the gap alone crawl: they could leave
    /// a point inside the clearance after any fixed number of steps. The cap keeps a point
    /// from being flung where the gradient nearly vanishes; since a distance field changes
    /// by at most one metre per metre, a point ends at most [`PUSH_SLACK`] past the
    /// clearance. Where the gradient is exactly zero (the very mid-line of a crevice) the
    /// step goes along `+y`, which need not lead out: only such a point can come back still
    /// inside the clearance, when the steps run out.
    fn push_outside(&self, p: &Vec3, clearance: Real) -> Vec3 {
        let mut x = *p;
        for _ in 0..PUSH_STEPS {
            let (d, g) = self.distance_and_gradient(&x);
            // A tiny slack keeps rounding from re-flagging a point just placed at the
            // clearance; a NaN distance (a broken field) leaves the point where it is.
            if d.is_nan() || d >= clearance - INSIDE_SLACK {
                break;
            }
            x += unit_normal(&g) * push_step(clearance - d, &g);
        }
        x
    }
}

/// The most Newton steps of [`SignedDistance::project`]: where the capsule union's gradient
/// is at least 0.2 long, 32 steps close all but 1e-3 of the gap; true distance fields need one.
const PROJECTION_STEPS: usize = 32;

/// The most steps of [`SignedDistance::push_outside`]. In a narrow crevice between two
/// separate parts of a hard union (an arm a few millimetres from the ribs) the steps zig-zag
/// from one side to the other on their way out, and 64 left points a few nanometres short.
const PUSH_STEPS: usize = 256;

/// How far (metres) one step of [`SignedDistance::push_outside`] may go past the remaining
/// gap, and so the most a pushed point can end past the clearance.
pub const PUSH_SLACK: Real = 0.002;

/// How far short of its clearance (metres) a point may lie and still count as out: a tiny
/// slack keeps rounding from re-flagging a point just placed at the clearance.
pub(crate) const INSIDE_SLACK: Real = 1e-9;

/// One step of [`SignedDistance::push_outside`] for a point `gap` metres short of its
/// clearance where the field's gradient is `g`: the gap over the gradient's length (the floor
/// only keeps the division finite), capped at the gap plus [`PUSH_SLACK`].
pub(crate) fn push_step(gap: Real, g: &Vec3) -> Real {
    (gap / g.norm().max(1e-3)).min(gap + PUSH_SLACK)
}

/// A rest-pose body that garments can be fitted to: a signed distance field on a skeleton,
/// with linear-blend-skinning weights for any point near its surface.
pub trait SkinnedBody: SignedDistance {
    /// The skeleton the body is rigged to.
    fn skeleton(&self) -> &Skeleton;

    /// Skinning weights `(joint, weight)` for a rest-pose point near the surface: at most
    /// four joints, weights positive and summing to one.
    fn skin_weights(&self, rest_point: &Vec3) -> Vec<(usize, Real)>;
}

/// A sphere, for tests and simple scenes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre (metres).
    pub centre: Vec3,
    /// Radius (metres).
    pub radius: Real,
}

impl SignedDistance for Sphere {
    fn distance_and_gradient(&self, p: &Vec3) -> (Real, Vec3) {
        let r = p - self.centre;
        let n = r.norm();
        let g = if n > 1e-12 { r / n } else { Vec3::y() };
        (n - self.radius, g)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn sphere_distance_projection() {
        let s = Sphere {
            centre: Vec3::new(0.0, 1.0, 0.0),
            radius: 0.5,
        };
        assert_relative_eq!(s.distance(&Vec3::new(0.0, 2.0, 0.0)), 0.5);
        assert_relative_eq!(s.distance(&Vec3::new(0.0, 1.0, 0.0)), -0.5);
        let p = s.project(&Vec3::new(1.0, 1.0, 0.0));
        assert_relative_eq!(p, Vec3::new(0.5, 1.0, 0.0), epsilon = 1e-12);
    }
}
