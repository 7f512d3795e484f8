//! Cloth-body contact helpers: an empty collider, Coulomb friction on a contact vertex, and
//! the final projection out of the collider.

use garmatnet_core::{Real, SignedDistance, Vec3};

/// A collider that is nowhere: for cloth that only hangs from its pins.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EmptySpace;

impl SignedDistance for EmptySpace {
    fn distance_and_gradient(&self, _p: &Vec3) -> (Real, Vec3) {
        (Real::INFINITY, Vec3::y())
    }
}

/// Coulomb friction on a contact vertex, given the net force `force` (newtons) of
/// everything else on it, the contact's outward `normal` and the normal force magnitude
/// `normal_force`. Returns the friction force and whether the vertex sticks: static friction
/// cancels the tangential force while it stays within `friction * normal_force`; beyond that
/// the vertex slides against exactly that much, opposing the tangential force.
pub(crate) fn coulomb_friction(
    force: &Vec3,
    normal: &Vec3,
    normal_force: Real,
    friction: Real,
) -> (Vec3, bool) {
    let tangential = force - normal * force.dot(normal);
    let magnitude = tangential.norm();
    let limit = friction * normal_force;
    if magnitude <= limit {
        (-tangential, true)
    } else {
        (tangential * (-limit / magnitude), false)
    }
}

/// Moves every vertex found inside the collider onto its surface, so that the reported
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
    fn friction_sticks_inside_the_cone_and_slides_outside() {
        let n = Vec3::y();
        let f = Vec3::new(0.3, -1.0, 0.4);
        let (fr, stick) = coulomb_friction(&f, &n, 2.0, 0.5);
        assert!(stick);
        assert_relative_eq!(fr, Vec3::new(-0.3, 0.0, -0.4), epsilon = 1e-12);
        let (fr, stick) = coulomb_friction(&f, &n, 0.5, 0.5);
        assert!(!stick);
        assert_relative_eq!(fr.norm(), 0.25, epsilon = 1e-12);
        assert_relative_eq!(fr.normalize(), Vec3::new(-0.6, 0.0, -0.8), epsilon = 1e-12);
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
