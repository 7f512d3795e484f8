//! Tapered capsules (round cones): the convex hull of two spheres, the building block of the
//! procedural body.

use crate::body::skeleton::JOINT_COUNT;
use crate::error::{Error, Result, ensure_finite};
use crate::math::{Iso3, Real, Vec3};

/// A tapered capsule riding rigidly on one joint: the convex hull of a sphere of radius
/// `radius_a` at `a` and one of radius `radius_b` at `b` (rest pose, metres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Capsule {
    /// The joint whose skinning transform carries the capsule (a bone's parent joint).
    pub joint: usize,
    /// One end in the rest pose (metres).
    pub a: Vec3,
    /// The other end in the rest pose (metres).
    pub b: Vec3,
    /// The radius at `a` (metres).
    pub radius_a: Real,
    /// The radius at `b` (metres).
    pub radius_b: Real,
}

impl Capsule {
    /// Checks that the capsule is usable: a known joint, finite ends, positive radii.
    ///
    /// # Errors
    /// [`Error::OutOfRange`] for a joint index past 23 or a radius that is not positive;
    /// [`Error::NonFinite`] for NaN or infinite coordinates or radii.
    pub fn validate(&self) -> Result<()> {
        if self.joint >= JOINT_COUNT {
            return Err(Error::OutOfRange {
                what: "capsule joint index".into(),
                value: self.joint as f64,
                min: 0.0,
                max: (JOINT_COUNT - 1) as f64,
                hint: "; use an SMPL joint index (see JOINT_NAMES)".into(),
            });
        }
        let values = [self.a.x, self.a.y, self.a.z, self.b.x, self.b.y, self.b.z];
        ensure_finite(
            "capsule ends and radii",
            values.into_iter().chain([self.radius_a, self.radius_b]),
        )?;
        for r in [self.radius_a, self.radius_b] {
            if r <= 0.0 {
                return Err(Error::OutOfRange {
                    what: "capsule radius (metres)".into(),
                    value: r,
                    min: f64::MIN_POSITIVE,
                    max: f64::INFINITY,
                    hint: "; radii must be positive".into(),
                });
            }
        }
        Ok(())
    }
}

/// A capsule with everything a distance query needs precomputed (in the frame it is queried
/// in: rest or posed).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PreparedCapsule {
    a: Vec3,
    b: Vec3,
    /// Unit axis from `a` to `b` (arbitrary when the capsule is a sphere).
    axis: Vec3,
    radius_a: Real,
    radius_b: Real,
    /// The side's outward normal in the (axial, radial) half-plane.
    normal_axial: Real,
    normal_radial: Real,
    /// Where the side ends along its tangent direction (`length · normal_radial`).
    side_end: Real,
    /// A sphere enclosing the capsule, for cheap rejection.
    pub(crate) bound_centre: Vec3,
    pub(crate) bound_radius: Real,
}

impl PreparedCapsule {
    /// Prepares `capsule` moved by `transform`.
    pub(crate) fn new(capsule: &Capsule, transform: &Iso3) -> Self {
        let a = transform * nalgebra::Point3::from(capsule.a);
        let b = transform * nalgebra::Point3::from(capsule.b);
        let (mut a, mut b) = (a.coords, b.coords);
        let (mut radius_a, mut radius_b) = (capsule.radius_a, capsule.radius_b);
        let mut length = (b - a).norm();
        // One sphere swallows the other: the hull is just the bigger sphere.
        if length <= (radius_a - radius_b).abs() {
            let (centre, radius) = if radius_a >= radius_b {
                (a, radius_a)
            } else {
                (b, radius_b)
            };
            (a, b, radius_a, radius_b, length) = (centre, centre, radius, radius, 0.0);
        }
        let axis = if length > 0.0 {
            (b - a) / length
        } else {
            Vec3::y()
        };
        let normal_axial = if length > 0.0 {
            (radius_a - radius_b) / length
        } else {
            0.0
        };
        let normal_radial = (1.0 - normal_axial * normal_axial).max(0.0).sqrt();
        Self {
            a,
            b,
            axis,
            radius_a,
            radius_b,
            normal_axial,
            normal_radial,
            side_end: length * normal_radial,
            bound_centre: (a + b) * 0.5,
            bound_radius: length * 0.5 + radius_a.max(radius_b),
        }
    }

    /// Exact signed distance (metres) and its unit gradient.
    #[inline]
    pub(crate) fn distance_and_gradient(&self, p: &Vec3) -> (Real, Vec3) {
        let d = p - self.a;
        let axial = d.dot(&self.axis);
        let radial_vec = d - self.axis * axial;
        let radial = radial_vec.norm();
        // Position along the side's tangent: before 0 the sphere at `a` is nearest, past
        // `side_end` the sphere at `b`, in between the conical side.
        let s = axial * self.normal_radial - radial * self.normal_axial;
        if s <= 0.0 {
            sphere_distance(&d, self.radius_a)
        } else if s >= self.side_end {
            sphere_distance(&(p - self.b), self.radius_b)
        } else {
            let radial_dir = if radial > 1e-12 {
                radial_vec / radial
            } else {
                any_perpendicular(&self.axis)
            };
            let distance = axial * self.normal_axial + radial * self.normal_radial - self.radius_a;
            (
                distance,
                self.axis * self.normal_axial + radial_dir * self.normal_radial,
            )
        }
    }
}

#[inline]
fn sphere_distance(offset: &Vec3, radius: Real) -> (Real, Vec3) {
    let n = offset.norm();
    let g = if n > 1e-12 { offset / n } else { Vec3::y() };
    (n - radius, g)
}

fn any_perpendicular(axis: &Vec3) -> Vec3 {
    let helper = if axis.x.abs() < 0.9 {
        Vec3::x()
    } else {
        Vec3::y()
    };
    axis.cross(&helper).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn cone() -> PreparedCapsule {
        let c = Capsule {
            joint: 0,
            a: Vec3::zeros(),
            b: Vec3::new(1.0, 0.0, 0.0),
            radius_a: 0.3,
            radius_b: 0.1,
        };
        PreparedCapsule::new(&c, &Iso3::identity())
    }

    #[test]
    fn distances_at_known_points() {
        let c = cone();
        assert_relative_eq!(c.distance_and_gradient(&Vec3::new(-0.5, 0.0, 0.0)).0, 0.2);
        assert_relative_eq!(c.distance_and_gradient(&Vec3::new(1.5, 0.0, 0.0)).0, 0.4);
        assert_relative_eq!(
            c.distance_and_gradient(&Vec3::zeros()).0,
            -0.3,
            epsilon = 1e-12
        );
        // The side's tangent points (and one midway) lie on the surface; stepping 5 cm
        // along the side's normal from them is 5 cm outside.
        let n = Vec3::new(0.2, (1.0f64 - 0.04).sqrt(), 0.0);
        for p in [
            n * 0.3,
            Vec3::new(1.0, 0.0, 0.0) + n * 0.1,
            n * 0.2 + Vec3::new(0.5, 0.0, 0.0),
        ] {
            assert_relative_eq!(c.distance_and_gradient(&p).0, 0.0, epsilon = 1e-12);
            let (d, g) = c.distance_and_gradient(&(p + n * 0.05));
            assert_relative_eq!(d, 0.05, epsilon = 1e-12);
            assert_relative_eq!(g, n, epsilon = 1e-12);
        }
    }

    #[test]
    fn gradient_matches_finite_differences() {
        let c = cone();
        let h = 1e-6;
        for p in [
            Vec3::new(0.4, 0.3, 0.1),
            Vec3::new(-0.2, 0.1, 0.3),
            Vec3::new(1.2, -0.1, 0.0),
        ] {
            let (_, g) = c.distance_and_gradient(&p);
            let fd = Vec3::from_fn(|i, _| {
                let e = Vec3::ith(i, h);
                (c.distance_and_gradient(&(p + e)).0 - c.distance_and_gradient(&(p - e)).0)
                    / (2.0 * h)
            });
            assert_relative_eq!(g, fd, epsilon = 1e-6);
            assert_relative_eq!(g.norm(), 1.0, epsilon = 1e-12);
        }
    }

    #[test]
    fn swallowed_sphere_degenerates_to_the_bigger_sphere() {
        let c = Capsule {
            joint: 3,
            a: Vec3::zeros(),
            b: Vec3::new(0.05, 0.0, 0.0),
            radius_a: 0.2,
            radius_b: 0.1,
        };
        let p = PreparedCapsule::new(&c, &Iso3::identity());
        assert_relative_eq!(
            p.distance_and_gradient(&Vec3::new(0.0, 0.5, 0.0)).0,
            0.3,
            epsilon = 1e-12
        );
        assert_relative_eq!(
            p.distance_and_gradient(&Vec3::new(0.5, 0.0, 0.0)).0,
            0.3,
            epsilon = 1e-12
        );
    }

    #[test]
    fn validation_rejects_bad_capsules() {
        let good = Capsule {
            joint: 3,
            a: Vec3::zeros(),
            b: Vec3::x(),
            radius_a: 0.1,
            radius_b: 0.1,
        };
        assert!(good.validate().is_ok());
        assert!(Capsule { joint: 24, ..good }.validate().is_err());
        assert!(
            Capsule {
                radius_b: 0.0,
                ..good
            }
            .validate()
            .is_err()
        );
        assert!(
            Capsule {
                a: Vec3::new(Real::NAN, 0.0, 0.0),
                ..good
            }
            .validate()
            .is_err()
        );
    }
}
