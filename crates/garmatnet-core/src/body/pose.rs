//! SMPL poses: 72-d axis-angle vectors (root orientation first), joint limits and
//! interpolation.

use serde::{Deserialize, Serialize};

use crate::body::joints::{JOINT_COUNT, JOINT_NAMES, MIRRORED_JOINTS};
use crate::error::{Error, Result, ensure_finite};
use crate::math::{Real, UnitQuat, Vec3};
use crate::rng::SplitMix64;

/// The length of an SMPL pose vector: 24 joints × 3 axis-angle components.
pub const POSE_DIM: usize = JOINT_COUNT * 3;

/// The length of an SMPL+H (AMASS) pose vector: 52 joints × 3.
pub const SMPLH_POSE_DIM: usize = 156;

/// The largest magnitude (radians) [`Pose::validate`] accepts for an axis-angle component.
pub const MAX_POSE_COMPONENT: Real = 1e3;

/// How far (radians) [`Pose::a_pose`] lowers each upper arm below horizontal: 45°, an
/// everyday relaxed A-pose.
pub const A_POSE_SHOULDER_ANGLE: Real = std::f64::consts::FRAC_PI_4;

/// SMPL's left and right shoulder joints (the upper arms' roots).
const SHOULDER_JOINTS: [usize; 2] = [16, 17];

/// An SMPL pose θ: one axis-angle rotation (radians) per joint, relative to its parent,
/// in SMPL's joint order; joint 0 is the global root orientation. There is no global
/// translation: garments are predicted relative to the posed body.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "Vec<Real>", into = "Vec<Real>")]
pub struct Pose {
    axis_angle: [Vec3; JOINT_COUNT],
}

impl Default for Pose {
    fn default() -> Self {
        Self::zero()
    }
}

impl TryFrom<Vec<Real>> for Pose {
    type Error = Error;
    fn try_from(values: Vec<Real>) -> Result<Self> {
        Self::from_slice(&values)
    }
}

impl From<Pose> for Vec<Real> {
    fn from(pose: Pose) -> Self {
        pose.to_vec()
    }
}

impl Pose {
    /// The rest pose (SMPL's T-pose): all rotations zero.
    #[must_use]
    pub fn zero() -> Self {
        Self {
            axis_angle: [Vec3::zeros(); JOINT_COUNT],
        }
    }

    /// The everyday A-pose: the T-pose with both upper arms lowered by
    /// [`A_POSE_SHOULDER_ANGLE`] about the forward (z) axis, the left (+x) shoulder by a
    /// negative rotation and the right by a positive one. The fitted T-shirt's rest mesh is
    /// dressed in this pose ([`crate::Garment::rest_pose`]).
    ///
    /// ```
    /// use garmatnet_core::{Pose, Skeleton, Vec3};
    /// let skeleton = Skeleton::smpl_neutral();
    /// let joints = skeleton.posed_joints(&Pose::a_pose());
    /// let (shoulder, elbow) = (joints[16], joints[18]);
    /// let drop = (shoulder.y - elbow.y).atan2(elbow.x - shoulder.x);
    /// // 45° turn on a bone that already slopes ~3° down in SMPL's T-pose.
    /// assert!((40.0..50.0).contains(&drop.to_degrees()));
    /// ```
    #[must_use]
    pub fn a_pose() -> Self {
        let mut pose = Self::zero();
        let [left, right] = SHOULDER_JOINTS;
        pose.set_joint(left, Vec3::new(0.0, 0.0, -A_POSE_SHOULDER_ANGLE));
        pose.set_joint(right, Vec3::new(0.0, 0.0, A_POSE_SHOULDER_ANGLE));
        pose
    }

    /// A pose from SMPL's 72-vector.
    ///
    /// # Errors
    /// [`Error::WrongLength`] unless `values.len() == 72` (for AMASS's 156-vectors use
    /// [`Pose::from_smplh`]); as [`Pose::validate`] for NaN, infinity or an absurd angle.
    pub fn from_slice(values: &[Real]) -> Result<Self> {
        if values.len() != POSE_DIM {
            return Err(Error::WrongLength {
                what: "SMPL pose vector".into(),
                expected: format!(
                    "{POSE_DIM} (24 joints x 3 axis-angle values; AMASS's 156 via Pose::from_smplh)"
                ),
                got: values.len(),
            });
        }
        let pose = Self {
            axis_angle: std::array::from_fn(|j| {
                Vec3::new(values[3 * j], values[3 * j + 1], values[3 * j + 2])
            }),
        };
        pose.validate()?;
        Ok(pose)
    }

    /// Checks every component: finite and at most [`MAX_POSE_COMPONENT`] radians in
    /// magnitude. Constructors that read values check it; call it on a pose assembled with
    /// [`Pose::set_joint`] before handing it to code that cannot take NaN (the solver).
    ///
    /// # Errors
    /// [`Error::NonFinite`] for NaN or infinity; [`Error::OutOfRange`] for a component
    /// beyond [`MAX_POSE_COMPONENT`] (a joint's squared angle would overflow to infinity
    /// near 1e154, and no rotation needs more than a few π).
    pub fn validate(&self) -> Result<()> {
        let values = self.axis_angle.iter().flat_map(|v| [v.x, v.y, v.z]);
        ensure_finite("SMPL pose vector", values.clone())?;
        if let Some((i, v)) = values
            .enumerate()
            .find(|(_, v)| v.abs() > MAX_POSE_COMPONENT)
        {
            return Err(Error::OutOfRange {
                what: format!("SMPL pose component {i} (radians)"),
                value: v,
                min: -MAX_POSE_COMPONENT,
                max: MAX_POSE_COMPONENT,
                hint: "; axis-angle values are angles, a few π at most".into(),
            });
        }
        Ok(())
    }

    /// A pose from a 72-vector (SMPL) or a 156-vector (SMPL+H, as in AMASS's `poses`).
    ///
    /// SMPL+H shares SMPL's first 22 joints; its hand joints are dropped and SMPL's two hand
    /// joints (22, 23) are set to zero, the standard conversion.
    ///
    /// # Errors
    /// [`Error::WrongLength`] for other lengths; [`Error::NonFinite`] for NaN or infinity.
    pub fn from_smplh(values: &[Real]) -> Result<Self> {
        match values.len() {
            POSE_DIM => Self::from_slice(values),
            SMPLH_POSE_DIM => {
                ensure_finite("SMPL+H pose vector", values.iter().copied())?;
                let mut smpl = vec![0.0; POSE_DIM];
                smpl[..66].copy_from_slice(&values[..66]);
                Self::from_slice(&smpl)
            }
            got => Err(Error::WrongLength {
                what: "pose vector".into(),
                expected: format!("{POSE_DIM} (SMPL) or {SMPLH_POSE_DIM} (SMPL+H / AMASS)"),
                got,
            }),
        }
    }

    /// The 72 values, joint by joint.
    #[must_use]
    pub fn to_vec(&self) -> Vec<Real> {
        self.axis_angle
            .iter()
            .flat_map(|v| [v.x, v.y, v.z])
            .collect()
    }

    /// Joint `j`'s axis-angle vector (radians).
    ///
    /// # Panics
    /// If `j >= 24`.
    #[must_use]
    pub fn joint(&self, j: usize) -> Vec3 {
        self.axis_angle[j]
    }

    /// Sets joint `j`'s axis-angle vector (radians).
    ///
    /// # Panics
    /// If `j >= 24`.
    pub fn set_joint(&mut self, j: usize, axis_angle: Vec3) {
        self.axis_angle[j] = axis_angle;
    }

    /// Joint `j`'s local rotation (the exponential map of its axis-angle vector; exact and
    /// orthonormal for every finite input, including zero and angles beyond π).
    #[must_use]
    pub fn joint_rotation(&self, j: usize) -> UnitQuat {
        UnitQuat::from_scaled_axis(self.axis_angle[j])
    }

    /// Interpolates joint rotations from `self` (t = 0) to `other` (t = 1) by spherical
    /// linear interpolation along the shortest arc, joint by joint.
    #[must_use]
    pub fn slerp(&self, other: &Pose, t: Real) -> Pose {
        Pose {
            axis_angle: std::array::from_fn(|j| {
                let a = self.joint_rotation(j);
                let b = other.joint_rotation(j);
                // `try_slerp` returns `None` only for antipodal rotations: nlerp there. Two
                // rotations closer than about 3e-8 rad (their cosine rounds to 1) give the
                // start rotation, under 30 nm at arm's length.
                let q = a.try_slerp(&b, t, 1e-9).unwrap_or_else(|| a.nlerp(&b, t));
                q.scaled_axis()
            }),
        }
    }

    /// The pose mirrored through the body's sagittal plane (x → −x): left and right joints
    /// swap ([`MIRRORED_JOINTS`]) and each axis-angle vector `(x, y, z)` becomes
    /// `(x, −y, −z)` (an axial vector under a reflection). Exact; mirroring twice gives the
    /// pose back (bit for bit, but for −0.0 which becomes +0.0), and a left-right symmetric
    /// pose is its own mirror.
    ///
    /// ```
    /// use garmatnet_core::{Pose, Vec3};
    /// let mut pose = Pose::zero();
    /// pose.set_joint(16, Vec3::new(0.1, -0.2, -1.2)); // the left arm lowered
    /// let mirrored = pose.mirrored();
    /// assert_eq!(mirrored.joint(17), Vec3::new(0.1, 0.2, 1.2)); // the right arm lowered
    /// assert_eq!(mirrored.joint(16), Vec3::zeros());
    /// assert_eq!(mirrored.mirrored(), pose);
    /// ```
    #[must_use]
    pub fn mirrored(&self) -> Pose {
        Pose {
            axis_angle: std::array::from_fn(|j| {
                let v = self.axis_angle[MIRRORED_JOINTS[j]];
                // `0.0 - y`, not `-y`: a zero stays +0.0, so a symmetric pose built from
                // zeros is its own mirror bit for bit.
                Vec3::new(v.x, 0.0 - v.y, 0.0 - v.z)
            }),
        }
    }

    /// The largest angle (radians) by which any joint's local rotation differs between the
    /// two poses.
    #[must_use]
    pub fn max_joint_angle_to(&self, other: &Pose) -> Real {
        (0..JOINT_COUNT)
            .map(|j| self.joint_rotation(j).angle_to(&other.joint_rotation(j)))
            .fold(0.0, Real::max)
    }
}

/// Per-joint limits on the three axis-angle components (radians, in the joint's parent
/// frame), used to sample and validate poses.
///
/// For the moderate angles a garment dataset needs, axis-angle components behave like
/// rotations about the parent's x (left), y (up) and z (forward) axes. The default ranges
/// ([`JointLimits::default`]) are our own anatomical estimates, deliberately a little inside
/// the human range so garments stay simulable:
///
/// | joints | x (flex/extend) | y (twist/swing) | z (abduct) |
/// |---|---|---|---|
/// | pelvis (root) | ±0.35 | ±0.6 | ±0.25 |
/// | hips | −1.6 … 0.5 | ±0.5 | −0.3 … 0.9 (left; mirrored right) |
/// | knees | 0 … 2.0 | ±0.05 | ±0.05 |
/// | spine1–3 (each) | −0.2 … 0.35 | ±0.25 | ±0.2 |
/// | ankles | −0.5 … 0.6 | ±0.2 | ±0.2 |
/// | feet | ±0.2 | ±0.1 | ±0.1 |
/// | neck, head | −0.35 … 0.4 | ±0.5 | ±0.3 |
/// | collars | ±0.15 | ±0.25 | −0.2 … 0.35 (left; mirrored right) |
/// | shoulders | ±0.8 | −1.2 … 0.5 (left; mirrored right) | −1.3 … 0.9 (left; mirrored right) |
/// | elbows | ±0.6 | −2.2 … 0 (left; mirrored right) | ±0.05 |
/// | wrists | ±0.5 | ±0.3 | ±0.5 |
/// | hands | ±0.2 | ±0.2 | ±0.2 |
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JointLimits {
    /// Lower bound per joint and component (radians).
    pub min: Vec<[Real; 3]>,
    /// Upper bound per joint and component (radians).
    pub max: Vec<[Real; 3]>,
}

impl Default for JointLimits {
    fn default() -> Self {
        // (x, y, z) ranges for the left side; right-side joints mirror y and z.
        let table: [([Real; 2], [Real; 2], [Real; 2]); JOINT_COUNT] = [
            ([-0.35, 0.35], [-0.6, 0.6], [-0.25, 0.25]),  // pelvis
            ([-1.6, 0.5], [-0.5, 0.5], [-0.3, 0.9]),      // left_hip
            ([-1.6, 0.5], [-0.5, 0.5], [-0.3, 0.9]),      // right_hip (mirrored below)
            ([-0.2, 0.35], [-0.25, 0.25], [-0.2, 0.2]),   // spine1
            ([0.0, 2.0], [-0.05, 0.05], [-0.05, 0.05]),   // left_knee
            ([0.0, 2.0], [-0.05, 0.05], [-0.05, 0.05]),   // right_knee
            ([-0.2, 0.35], [-0.25, 0.25], [-0.2, 0.2]),   // spine2
            ([-0.5, 0.6], [-0.2, 0.2], [-0.2, 0.2]),      // left_ankle
            ([-0.5, 0.6], [-0.2, 0.2], [-0.2, 0.2]),      // right_ankle
            ([-0.2, 0.35], [-0.25, 0.25], [-0.2, 0.2]),   // spine3
            ([-0.2, 0.2], [-0.1, 0.1], [-0.1, 0.1]),      // left_foot
            ([-0.2, 0.2], [-0.1, 0.1], [-0.1, 0.1]),      // right_foot
            ([-0.35, 0.4], [-0.5, 0.5], [-0.3, 0.3]),     // neck
            ([-0.15, 0.15], [-0.25, 0.25], [-0.2, 0.35]), // left_collar
            ([-0.15, 0.15], [-0.25, 0.25], [-0.2, 0.35]), // right_collar
            ([-0.35, 0.4], [-0.5, 0.5], [-0.3, 0.3]),     // head
            ([-0.8, 0.8], [-1.2, 0.5], [-1.3, 0.9]),      // left_shoulder
            ([-0.8, 0.8], [-1.2, 0.5], [-1.3, 0.9]),      // right_shoulder
            ([-0.6, 0.6], [-2.2, 0.0], [-0.05, 0.05]),    // left_elbow
            ([-0.6, 0.6], [-2.2, 0.0], [-0.05, 0.05]),    // right_elbow
            ([-0.5, 0.5], [-0.3, 0.3], [-0.5, 0.5]),      // left_wrist
            ([-0.5, 0.5], [-0.3, 0.3], [-0.5, 0.5]),      // right_wrist
            ([-0.2, 0.2], [-0.2, 0.2], [-0.2, 0.2]),      // left_hand
            ([-0.2, 0.2], [-0.2, 0.2], [-0.2, 0.2]),      // right_hand
        ];
        let mut min = Vec::with_capacity(JOINT_COUNT);
        let mut max = Vec::with_capacity(JOINT_COUNT);
        for (j, (x, y, z)) in table.iter().enumerate() {
            let (y, z) = if JOINT_NAMES[j].starts_with("right_") {
                ([-y[1], -y[0]], [-z[1], -z[0]])
            } else {
                (*y, *z)
            };
            min.push([x[0], y[0], z[0]]);
            max.push([x[1], y[1], z[1]]);
        }
        Self { min, max }
    }
}

impl JointLimits {
    /// The limits of everyday poses ([`JointLimits::default`] with wider shoulders), within
    /// which the independent-pose sampler of `garmatnet-sim` draws. The default limits stop
    /// the upper arm about 75° below and 50° above the horizontal (shoulder z −1.3 … 0.9),
    /// short of arms hanging at the sides and of arms overhead; these allow (left shoulder;
    /// the right mirrors y and z):
    ///
    /// | component | default | everyday |
    /// |---|---|---|
    /// | x (twist about the arm) | ±0.8 | ±1.2 |
    /// | y (forward −, back +) | −1.2 … 0.5 | −2.0 … 0.9 |
    /// | z (down −, up +) | −1.3 … 0.9 | −1.65 … 1.6 |
    ///
    /// Every other joint keeps its default range. The default limits are left as they are
    /// because the built-in walk ([`JointLimits::sample`] within them) must stay
    /// bit-identical for datasets made with it.
    #[must_use]
    pub fn everyday() -> Self {
        let mut limits = Self::default();
        let left: ([Real; 3], [Real; 3]) = ([-1.2, -2.0, -1.65], [1.2, 0.9, 1.6]);
        for (j, mirror) in [(16, false), (17, true)] {
            let (lo, hi) = left;
            limits.min[j] = if mirror { [lo[0], -hi[1], -hi[2]] } else { lo };
            limits.max[j] = if mirror { [hi[0], -lo[1], -lo[2]] } else { hi };
        }
        limits
    }

    /// Checks `pose` against the limits (with `tolerance` radians of slack).
    ///
    /// # Errors
    /// [`Error::OutOfRange`] naming the first joint and component outside its range.
    pub fn validate(&self, pose: &Pose, tolerance: Real) -> Result<()> {
        for (j, name) in JOINT_NAMES.iter().enumerate() {
            let v = pose.joint(j);
            for (c, axis) in ["x", "y", "z"].iter().enumerate() {
                let (lo, hi) = (self.min[j][c], self.max[j][c]);
                if v[c] < lo - tolerance || v[c] > hi + tolerance {
                    return Err(Error::OutOfRange {
                        what: format!("joint `{name}` axis-angle {axis} component (rad)"),
                        value: v[c],
                        min: lo,
                        max: hi,
                        hint:
                            "; clamp the pose with JointLimits::clamp or sample within the limits"
                                .into(),
                    });
                }
            }
        }
        Ok(())
    }

    /// `pose` with every component clamped into its range.
    #[must_use]
    pub fn clamp(&self, pose: &Pose) -> Pose {
        let mut out = pose.clone();
        for j in 0..JOINT_COUNT {
            let v = pose.joint(j);
            out.set_joint(
                j,
                Vec3::from_fn(|c, _| v[c].clamp(self.min[j][c], self.max[j][c])),
            );
        }
        out
    }

    /// A pose drawn uniformly within the limits, each range scaled by `amplitude` ∈ [0, 1]
    /// around its centre-most admissible point (0 when 0 is inside the range).
    #[must_use]
    pub fn sample(&self, rng: &mut SplitMix64, amplitude: Real) -> Pose {
        let amplitude = amplitude.clamp(0.0, 1.0);
        let mut pose = Pose::zero();
        for j in 0..JOINT_COUNT {
            pose.set_joint(
                j,
                Vec3::from_fn(|c, _| {
                    let (lo, hi) = (self.min[j][c], self.max[j][c]);
                    let centre = 0.0_f64.clamp(lo, hi);
                    let lo = centre + (lo - centre) * amplitude;
                    let hi = centre + (hi - centre) * amplitude;
                    rng.uniform(lo, hi)
                }),
            );
        }
        pose
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    #[test]
    fn wrong_lengths_and_nan_are_typed_errors() {
        assert!(matches!(
            Pose::from_slice(&[0.0; 71]),
            Err(Error::WrongLength { got: 71, .. })
        ));
        assert!(matches!(
            Pose::from_smplh(&[0.0; 100]),
            Err(Error::WrongLength { got: 100, .. })
        ));
        let mut v = vec![0.0; 72];
        v[40] = f64::NAN;
        assert!(matches!(
            Pose::from_slice(&v),
            Err(Error::NonFinite { index: 40, .. })
        ));
        // Finite, but its squared angle overflows: refused by magnitude.
        v[40] = 1e300;
        assert!(matches!(
            Pose::from_slice(&v),
            Err(Error::OutOfRange { .. })
        ));
        v[40] = -MAX_POSE_COMPONENT;
        assert!(Pose::from_slice(&v).is_ok());
        let mut v = vec![0.0; 156];
        v[150] = f64::INFINITY; // even in the dropped hand joints
        assert!(matches!(Pose::from_smplh(&v), Err(Error::NonFinite { .. })));
    }

    #[test]
    fn smplh_keeps_body_joints_and_zeroes_hands() {
        let v: Vec<Real> = (0..156).map(|i| i as Real * 1e-3).collect();
        let p = Pose::from_smplh(&v).unwrap();
        let out = p.to_vec();
        assert_eq!(&out[..66], &v[..66]);
        assert!(out[66..].iter().all(|x| *x == 0.0));
    }

    #[test]
    fn json_round_trip() {
        let mut p = Pose::zero();
        p.set_joint(3, Vec3::new(0.1, -0.2, 0.3));
        let s = serde_json::to_string(&p).unwrap();
        let q: Pose = serde_json::from_str(&s).unwrap();
        assert_eq!(p, q);
        assert!(serde_json::from_str::<Pose>("[1.0, 2.0]").is_err());
    }

    #[test]
    fn mirroring_swaps_sides_negates_y_and_z_and_is_an_involution() {
        let v: Vec<Real> = (0..POSE_DIM).map(|i| (i as Real * 0.37).sin()).collect();
        let p = Pose::from_slice(&v).unwrap();
        let m = p.mirrored();
        assert_eq!(m.mirrored(), p);
        // Left shoulder (16) ← right shoulder (17), y and z negated; the spine keeps its x.
        let r = p.joint(17);
        assert_eq!(m.joint(16), Vec3::new(r.x, -r.y, -r.z));
        let s = p.joint(3);
        assert_eq!(m.joint(3), Vec3::new(s.x, -s.y, -s.z));
        // Mirroring commutes with rotation: the mirrored rotation is M R M, M = diag(-1, 1, 1).
        let mirror = crate::math::Mat3::from_diagonal(&Vec3::new(-1.0, 1.0, 1.0));
        for (j, &twin) in MIRRORED_JOINTS.iter().enumerate() {
            let expected =
                mirror * p.joint_rotation(twin).to_rotation_matrix().into_inner() * mirror;
            let got = m.joint_rotation(j).to_rotation_matrix().into_inner();
            assert!((expected - got).abs().max() < 1e-12, "joint {j}");
        }
        // The default and everyday limits are mirror symmetric: a pose within them mirrors
        // into them.
        for limits in [JointLimits::default(), JointLimits::everyday()] {
            let inside = limits.sample(&mut SplitMix64::new(9), 1.0);
            limits.validate(&inside.mirrored(), 1e-12).unwrap();
        }
    }

    #[test]
    fn everyday_limits_widen_only_the_shoulders() {
        let (d, e) = (JointLimits::default(), JointLimits::everyday());
        for j in 0..JOINT_COUNT {
            if j == 16 || j == 17 {
                for c in 0..3 {
                    assert!(e.min[j][c] < d.min[j][c] && e.max[j][c] > d.max[j][c]);
                }
            } else {
                assert_eq!((e.min[j], e.max[j]), (d.min[j], d.max[j]), "joint {j}");
            }
        }
        // Arms hanging 85° below the horizontal fit the everyday limits, not the default.
        let mut hanging = Pose::zero();
        hanging.set_joint(16, Vec3::new(0.0, 0.0, -1.48));
        hanging.set_joint(17, Vec3::new(0.0, 0.0, 1.48));
        assert!(d.validate(&hanging, 0.0).is_err());
        e.validate(&hanging, 0.0).unwrap();
    }

    #[test]
    fn default_limits_contain_zero_and_are_ordered() {
        let l = JointLimits::default();
        l.validate(&Pose::zero(), 0.0).unwrap();
        for j in 0..JOINT_COUNT {
            for c in 0..3 {
                assert!(l.min[j][c] <= l.max[j][c]);
            }
        }
        // Mirroring: the right shoulder lowers with positive z, the left with negative.
        assert!(l.min[16][2] < -1.0 && l.max[17][2] > 1.0);
    }

    #[test]
    fn sampled_poses_are_within_limits_and_seeded() {
        let l = JointLimits::default();
        let a = l.sample(&mut SplitMix64::new(5), 1.0);
        let b = l.sample(&mut SplitMix64::new(5), 1.0);
        assert_eq!(a, b);
        l.validate(&a, 0.0).unwrap();
        let mut big = a.clone();
        big.set_joint(4, Vec3::new(3.0, 0.0, 0.0));
        assert!(matches!(
            l.validate(&big, 0.0),
            Err(Error::OutOfRange { .. })
        ));
        l.validate(&l.clamp(&big), 0.0).unwrap();
    }

    proptest! {
        #[test]
        fn rotations_stay_orthonormal(v in prop::collection::vec(-1e3f64..1e3, 72)) {
            let p = Pose::from_slice(&v).unwrap();
            for j in 0..JOINT_COUNT {
                let r = p.joint_rotation(j).to_rotation_matrix().into_inner();
                let should_be_identity = r.transpose() * r;
                prop_assert!((should_be_identity - crate::math::Mat3::identity()).abs().max() < 1e-9);
                prop_assert!((r.determinant() - 1.0).abs() < 1e-9);
            }
        }

        #[test]
        fn slerp_hits_its_endpoints(a in prop::collection::vec(-2.0f64..2.0, 72), b in prop::collection::vec(-2.0f64..2.0, 72)) {
            let pa = Pose::from_slice(&a).unwrap();
            let pb = Pose::from_slice(&b).unwrap();
            prop_assert!(pa.slerp(&pb, 0.0).max_joint_angle_to(&pa) < 1e-6);
            prop_assert!(pa.slerp(&pb, 1.0).max_joint_angle_to(&pb) < 1e-6);
            let mid = pa.slerp(&pb, 0.5);
            for j in 0..JOINT_COUNT {
                let total = pa.joint_rotation(j).angle_to(&pb.joint_rotation(j));
                let half = pa.joint_rotation(j).angle_to(&mid.joint_rotation(j));
                prop_assert!((half - total / 2.0).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn small_angles_are_exact() {
        let mut p = Pose::zero();
        p.set_joint(1, Vec3::new(1e-12, 0.0, 0.0));
        let r = p.joint_rotation(1);
        assert_relative_eq!(r.angle(), 1e-12, epsilon = 1e-15);
    }
}
