//! The displacement decomposition of the paper's eqs. 1, 4 and 5: the training labels.
//!
//! A simulated garment `T` (one position per template vertex) is split, against its
//! Laplacian-smoothed version `T_fitting` ([`crate::LaplacianSmoother`]) and the posed body
//! points `M` its vertices are measured from ([`crate::BodyAnchor::posed_point`]), into
//!
//! - `D_fitting = T_fitting - M`: the smooth, overall fit (the generally-fitting network's
//!   label),
//! - `D_local = T - T_fitting`: the wrinkles (the locally-detailed network's label),
//! - `D_whole = D_fitting + D_local`: the whole displacement (eq. 1).
//!
//! `D_whole` is *defined* as the floating-point sum of the two parts, rather than computed as
//! `T - M`, so that `d_fitting[i] + d_local[i] == d_whole[i]` holds bit for bit: label files,
//! metrics and predictions can then rely on the parts adding up exactly. The price is that
//! `M + D_whole` equals `T` only up to rounding (a few ulps of the coordinates, ~1e-15 m for
//! a human-sized garment), which is far below any physical tolerance.

use crate::body::anchor::{BodyAnchor, DisplacementFrame};
use crate::body::skeleton::JOINT_COUNT;
use crate::error::{Error, Result, ensure_finite};
use crate::math::{Iso3, Vec3};

/// A garment's displacement from the body, split into a smooth fit and local wrinkles
/// (metres, world frame, one vector per garment vertex).
#[derive(Debug, Clone, PartialEq)]
pub struct Decomposition {
    /// Smoothed garment minus body (eq. 5): the generally-fitting network's label.
    pub d_fitting: Vec<Vec3>,
    /// Simulated minus smoothed garment (eq. 4): the locally-detailed network's label.
    pub d_local: Vec<Vec3>,
    /// `d_fitting + d_local`, exactly (eq. 1).
    pub d_whole: Vec<Vec3>,
}

impl Decomposition {
    /// The number of garment vertices.
    #[must_use]
    pub fn len(&self) -> usize {
        self.d_whole.len()
    }

    /// Whether the decomposition has no vertices.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.d_whole.is_empty()
    }
}

/// Checks that `field` (named `what`) has `expected` entries and finite coordinates.
fn check_field(what: &str, field: &[Vec3], expected: usize, reference: &str) -> Result<()> {
    if field.len() != expected {
        return Err(Error::Mismatch {
            what: format!("{what} must have one entry per garment vertex"),
            expected: format!("{expected} (the length of {reference})"),
            got: field.len().to_string(),
        });
    }
    ensure_finite(what, field.iter().flat_map(|v| [v.x, v.y, v.z]))
}

/// Splits a simulated garment into the paper's labels (eqs. 4–5; see the module docs).
///
/// # Shapes
/// `simulated`, `smoothed`, `body_points`: `[n]`; every field of the result: `[n]`.
///
/// # Errors
/// [`Error::Mismatch`] naming the input whose length differs from `simulated`'s;
/// [`Error::NonFinite`] naming the input that holds a NaN or infinity.
pub fn decompose(
    simulated: &[Vec3],
    smoothed: &[Vec3],
    body_points: &[Vec3],
) -> Result<Decomposition> {
    let n = simulated.len();
    check_field(
        "simulated garment positions",
        simulated,
        n,
        "the simulated garment",
    )?;
    check_field(
        "smoothed garment positions",
        smoothed,
        n,
        "the simulated garment",
    )?;
    check_field("body points", body_points, n, "the simulated garment")?;
    let d_fitting: Vec<Vec3> = smoothed
        .iter()
        .zip(body_points)
        .map(|(s, b)| s - b)
        .collect();
    let d_local: Vec<Vec3> = simulated.iter().zip(smoothed).map(|(t, s)| t - s).collect();
    let d_whole = d_fitting.iter().zip(&d_local).map(|(f, l)| f + l).collect();
    Ok(Decomposition {
        d_fitting,
        d_local,
        d_whole,
    })
}

/// Rebuilds garment positions from the body and the two parts: `body + (d_fitting + d_local)`,
/// summing the parts first exactly as [`decompose`] defines `d_whole`.
///
/// # Shapes
/// `body_points`, `d_fitting`, `d_local`: `[n]`; returns `[n]`.
///
/// # Errors
/// [`Error::Mismatch`] naming the input whose length differs from `body_points`'s;
/// [`Error::NonFinite`] naming the input that holds a NaN or infinity.
pub fn recompose(body_points: &[Vec3], d_fitting: &[Vec3], d_local: &[Vec3]) -> Result<Vec<Vec3>> {
    let n = body_points.len();
    check_field("body points", body_points, n, "the body points")?;
    check_field("fitting displacements", d_fitting, n, "the body points")?;
    check_field("local displacements", d_local, n, "the body points")?;
    Ok(body_points
        .iter()
        .zip(d_fitting.iter().zip(d_local))
        .map(|(b, (f, l))| b + (f + l))
        .collect())
}

/// Checks the anchors against a displacement field.
fn check_anchors(field: &[Vec3], anchors: &[BodyAnchor]) -> Result<()> {
    if field.len() == anchors.len() {
        Ok(())
    } else {
        Err(Error::Mismatch {
            what: "displacement field and body anchors (one anchor per garment vertex)".into(),
            expected: format!("{} displacements", anchors.len()),
            got: format!("{} displacements", field.len()),
        })
    }
}

/// Expresses a world-frame displacement field in `frame`, vertex by vertex, with each
/// vertex's anchor ([`BodyAnchor::to_frame`]) and the pose's skinning transforms
/// ([`crate::Skeleton::skinning_transforms`]).
///
/// # Shapes
/// `world` and `anchors`: `[n]`; returns `[n]`.
///
/// # Errors
/// [`Error::Mismatch`] if `world` and `anchors` differ in length.
pub fn field_to_frame(
    world: &[Vec3],
    anchors: &[BodyAnchor],
    frame: DisplacementFrame,
    transforms: &[Iso3; JOINT_COUNT],
) -> Result<Vec<Vec3>> {
    check_anchors(world, anchors)?;
    Ok(world
        .iter()
        .zip(anchors)
        .map(|(d, a)| a.to_frame(d, frame, transforms))
        .collect())
}

/// Turns a displacement field expressed in `frame` back into the world frame (the inverse
/// of [`field_to_frame`], up to rounding).
///
/// # Shapes
/// `field` and `anchors`: `[n]`; returns `[n]`.
///
/// # Errors
/// [`Error::Mismatch`] if `field` and `anchors` differ in length.
pub fn field_from_frame(
    field: &[Vec3],
    anchors: &[BodyAnchor],
    frame: DisplacementFrame,
    transforms: &[Iso3; JOINT_COUNT],
) -> Result<Vec<Vec3>> {
    check_anchors(field, anchors)?;
    Ok(field
        .iter()
        .zip(anchors)
        .map(|(d, a)| a.from_frame(d, frame, transforms))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Pose, Skeleton};
    use proptest::prelude::*;

    fn vec3s(n: usize, scale: f64) -> impl Strategy<Value = Vec<Vec3>> {
        proptest::collection::vec(
            (-scale..scale, -scale..scale, -scale..scale).prop_map(|(x, y, z)| Vec3::new(x, y, z)),
            n,
        )
    }

    proptest! {
        #[test]
        fn parts_sum_bitwise_and_recompose_round_trips(
            body in vec3s(20, 1.0),
            fit in vec3s(20, 0.1),
            wrinkle in vec3s(20, 0.01),
        ) {
            let smoothed: Vec<Vec3> = body.iter().zip(&fit).map(|(b, f)| b + f).collect();
            let simulated: Vec<Vec3> =
                smoothed.iter().zip(&wrinkle).map(|(s, w)| s + w).collect();
            let d = decompose(&simulated, &smoothed, &body).unwrap();
            for i in 0..d.len() {
                let sum = d.d_fitting[i] + d.d_local[i];
                for k in 0..3 {
                    prop_assert_eq!(sum[k].to_bits(), d.d_whole[i][k].to_bits());
                }
            }
            let back = recompose(&body, &d.d_fitting, &d.d_local).unwrap();
            for (b, t) in back.iter().zip(&simulated) {
                prop_assert!((b - t).amax() <= 1e-12, "{b} vs {t}");
            }
        }

        #[test]
        fn frame_round_trip(field in vec3s(6, 0.05), angle in -1.5f64..1.5) {
            let mut pose = Pose::zero();
            pose.set_joint(16, Vec3::new(0.1, angle, -0.8));
            pose.set_joint(3, Vec3::new(angle, 0.0, 0.2));
            let t = Skeleton::smpl_neutral().skinning_transforms(&pose);
            let anchors: Vec<BodyAnchor> = (0..6)
                .map(|i| BodyAnchor {
                    rest_point: Vec3::new(0.05 * i as f64, 0.2, 0.1),
                    weights: vec![(16, 0.6), (3, 0.4)],
                })
                .collect();
            for frame in [DisplacementFrame::World, DisplacementFrame::Canonical] {
                let local = field_to_frame(&field, &anchors, frame, &t).unwrap();
                let back = field_from_frame(&local, &anchors, frame, &t).unwrap();
                for (b, f) in back.iter().zip(&field) {
                    prop_assert!((b - f).amax() <= 1e-12);
                }
            }
        }
    }

    #[test]
    fn length_mismatch_names_the_input() {
        let three = vec![Vec3::zeros(); 3];
        let two = vec![Vec3::zeros(); 2];
        let err = decompose(&three, &three, &two).unwrap_err();
        assert!(
            matches!(err, Error::Mismatch { .. }) && err.to_string().contains("body"),
            "{err}"
        );
        let err = decompose(&three, &two, &three).unwrap_err();
        assert!(err.to_string().contains("smoothed"), "{err}");
        let err = recompose(&three, &three, &two).unwrap_err();
        assert!(err.to_string().contains("local"), "{err}");
        let t = Skeleton::smpl_neutral().skinning_transforms(&Pose::zero());
        let err = field_to_frame(&three, &[], DisplacementFrame::World, &t).unwrap_err();
        assert!(err.to_string().contains("anchors"), "{err}");
    }

    #[test]
    fn nan_is_rejected() {
        let mut sim = vec![Vec3::zeros(); 2];
        sim[1].y = f64::NAN;
        let ok = vec![Vec3::zeros(); 2];
        let err = decompose(&sim, &ok, &ok).unwrap_err();
        assert!(matches!(err, Error::NonFinite { index: 4, .. }), "{err}");
    }
}
