//! Cloth-body contact as a projective constraint: where a vertex's target point lies on the
//! collider's offset surface, with Coulomb friction deciding between sticking and sliding.

use garmatnet_core::{Real, SignedDistance, Vec3};

/// A collider that is nowhere: for cloth that only hangs from its pins.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EmptySpace;

impl SignedDistance for EmptySpace {
    fn distance_and_gradient(&self, _p: &Vec3) -> (Real, Vec3) {
        (Real::INFINITY, Vec3::y())
    }
}

/// The projective-constraint target of a vertex near the collider, or `None` when the
/// vertex is at least `margin` outside it.
///
/// The normal part pushes the vertex back to the offset surface `sdf = margin`. The
/// tangential part pulls it towards `anchor` (where it first touched during this drape):
/// fully while the tangential pull stays inside the friction cone (static friction), and
/// with exactly `friction` times the normal push otherwise, dragging the anchor along
/// (sliding). Both forces scale with the same penalty weight, which therefore cancels.
pub(crate) fn contact_target(
    x: &Vec3,
    collider: &impl SignedDistance,
    margin: Real,
    friction: Real,
    anchor: &mut Option<Vec3>,
) -> Option<Vec3> {
    let (d, n) = collider.distance_and_gradient(x);
    if !(d < margin) {
        *anchor = None;
        return None;
    }
    let push = margin - d;
    let on_surface = x + n * push;
    let Some(a) = *anchor else {
        *anchor = Some(on_surface);
        return Some(on_surface);
    };
    let offset = a - on_surface;
    let tangential = offset - n * offset.dot(&n);
    let slip = tangential.norm();
    let limit = friction * push;
    let target = if slip <= limit {
        on_surface + tangential
    } else {
        on_surface + tangential * (limit / slip)
    };
    *anchor = Some(target);
    Some(target)
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
        let (d, n) = collider.distance_and_gradient(x);
        if d < 0.0 {
            *x -= n * d;
            deepest = deepest.max(-collider.distance(x));
        }
    }
    deepest
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use garmatnet_core::Sphere;

    const MARGIN: Real = 0.003;

    fn unit_sphere() -> Sphere {
        Sphere {
            centre: Vec3::zeros(),
            radius: 1.0,
        }
    }

    #[test]
    fn far_vertex_has_no_target_and_forgets_its_anchor() {
        let mut anchor = Some(Vec3::y());
        let t = contact_target(
            &Vec3::new(0.0, 2.0, 0.0),
            &unit_sphere(),
            MARGIN,
            0.5,
            &mut anchor,
        );
        assert!(t.is_none() && anchor.is_none());
    }

    #[test]
    fn first_touch_projects_to_offset_surface() {
        let mut anchor = None;
        let x = Vec3::new(0.0, 0.9, 0.0);
        let t = contact_target(&x, &unit_sphere(), MARGIN, 0.5, &mut anchor).unwrap();
        assert_relative_eq!(t, Vec3::new(0.0, 1.0 + MARGIN, 0.0), epsilon = 1e-12);
        assert_eq!(anchor, Some(t));
    }

    #[test]
    fn small_slip_sticks_large_slip_slides_by_friction_limit() {
        let s = unit_sphere();
        let top = Vec3::new(0.0, 1.0 + MARGIN, 0.0);
        // Pushed 1 cm in, moved 1 mm sideways: inside the cone of friction 0.5.
        let x = Vec3::new(0.001, 0.993, 0.0);
        let mut anchor = Some(top);
        let t = contact_target(&x, &s, MARGIN, 0.5, &mut anchor).unwrap();
        assert_relative_eq!(t, top, epsilon = 1e-5);
        // Moved 10 cm sideways: slides; the tangential pull is friction * normal push.
        let x = Vec3::new(0.1, 0.99, 0.0);
        let mut anchor = Some(top);
        let t = contact_target(&x, &s, MARGIN, 0.5, &mut anchor).unwrap();
        let (d, n) = s.distance_and_gradient(&x);
        let on_surface = x + n * (MARGIN - d);
        assert_relative_eq!((t - on_surface).norm(), 0.5 * (MARGIN - d), epsilon = 1e-12);
        assert_eq!(anchor, Some(t));
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
