//! Keeping the arms off the torso, so no cloth is pinched between them.
//!
//! The procedural body is a smooth union of capsules ([`garmatnet_core::CapsuleBody`]): where
//! an arm comes within about half the blend radius of the torso the union fills the gap, and
//! cloth lying between them (the side of the shirt under a lowered arm) ends up inside the
//! body, pushed out to both sides at once. The solver still converges, to a torn drape: in the
//! 30 × 200 brisk dataset of seed 0 made before this check, 22 of 30 fabrics first tore at
//! frames 167–177, exactly the frames whose upper arm dipped into the chest (gap −1.4 cm at
//! frame 167, the first below zero). Nothing in the joint limits prevents it: a shoulder
//! lowered by 1.3 rad and swung forward brings the upper arm into the chest.
//!
//! [`ArmClearance`] measures, per arm, the smallest gap between the arm's capsules (the upper
//! arm without its root, which always sits in the armpit; forearm; palm; fingers) and the
//! torso's (pelvis, waist, chest), and [`ArmClearance::enforce`] lifts an arm that comes
//! closer than [`ArmClearance::min_gap`] toward the T-pose (scaling its collar, shoulder,
//! elbow, wrist and hand rotations by the same factor) just far enough to clear it.

use garmatnet_core::{Capsule, Error, Pose, Real, Result, Skeleton, Vec3, smpl_neutral_capsules};

/// The default [`ArmClearance::min_gap`] (metres): the smooth union fills gaps below about
/// 1.5 cm (half its 3 cm blend radius), two layers of cloth with their 3 mm contact margins
/// need about 1 cm more, and the rest is slack for the capsule-axis approximation of the gap.
pub const DEFAULT_ARM_CLEARANCE: Real = 0.04;

/// The part of the upper arm nearest the shoulder that is left out of the gap: it meets the
/// chest in the armpit in every pose, the T-pose included.
const UPPER_ARM_ROOT: Real = 0.4;

/// The arm chains (collar, shoulder, elbow, wrist, hand), left then right.
const ARM_CHAINS: [[usize; 5]; 2] = [[13, 16, 18, 20, 22], [14, 17, 19, 21, 23]];

/// Joints carrying the torso's capsules: pelvis, spine1, spine2, spine3.
const TORSO_JOINTS: [usize; 4] = [0, 3, 6, 9];

/// A smallest-gap check between the arms and the torso of the neutral procedural body, and a
/// minimal correction of poses that break it. Where an arm comes within about half the
/// body's blend radius of the torso, the smooth union of capsules fills the gap and cloth
/// lying between them ends up inside the body, pushed out to both sides at once: a torn
/// drape. [`ArmClearance::enforce`] lifts such an arm toward the T-pose just far enough.
#[derive(Debug, Clone)]
pub struct ArmClearance {
    skeleton: Skeleton,
    /// The capsules of the left and the right arm (the upper arm trimmed at its root).
    arms: [Vec<Capsule>; 2],
    torso: Vec<Capsule>,
    min_gap: Real,
}

impl ArmClearance {
    /// A check that keeps `min_gap` metres between the arms and the torso of
    /// [`garmatnet_core::CapsuleBody::smpl_neutral`]'s capsules.
    ///
    /// # Errors
    /// [`Error::OutOfRange`] unless `min_gap` is finite and in 0 … 0.1 m (more would forbid
    /// ordinary poses with the arms hanging down).
    pub fn new(min_gap: Real) -> Result<Self> {
        if !(min_gap.is_finite() && (0.0..=0.1).contains(&min_gap)) {
            return Err(Error::OutOfRange {
                what: "arm–torso clearance (metres)".into(),
                value: min_gap,
                min: 0.0,
                max: 0.1,
                hint: format!("; the default is {DEFAULT_ARM_CLEARANCE}, 0 turns the check off"),
            });
        }
        let skeleton = Skeleton::smpl_neutral();
        let capsules = smpl_neutral_capsules(&skeleton);
        let arm = |chain: &[usize; 5]| -> Vec<Capsule> {
            capsules
                .iter()
                .filter(|c| chain[1..].contains(&c.joint))
                .map(|c| {
                    if c.joint == chain[1] {
                        Capsule {
                            a: c.a + (c.b - c.a) * UPPER_ARM_ROOT,
                            radius_a: c.radius_a + (c.radius_b - c.radius_a) * UPPER_ARM_ROOT,
                            ..*c
                        }
                    } else {
                        *c
                    }
                })
                .collect()
        };
        let torso = capsules
            .iter()
            .filter(|c| TORSO_JOINTS.contains(&c.joint))
            .copied()
            .collect();
        Ok(Self {
            arms: [arm(&ARM_CHAINS[0]), arm(&ARM_CHAINS[1])],
            skeleton,
            torso,
            min_gap,
        })
    }

    /// The smallest gap kept (metres).
    #[must_use]
    pub fn min_gap(&self) -> Real {
        self.min_gap
    }

    /// The smallest gap (metres; negative where they overlap) between the left and the right
    /// arm and the torso in `pose`: the distance between capsule axes minus the radii at the
    /// closest axis points.
    #[must_use]
    pub fn gaps(&self, pose: &Pose) -> [Real; 2] {
        let transforms = self.skeleton.skinning_transforms(pose);
        let place = |c: &Capsule| {
            let t = &transforms[c.joint];
            (
                t.rotation * c.a + t.translation.vector,
                t.rotation * c.b + t.translation.vector,
            )
        };
        let torso: Vec<(Vec3, Vec3)> = self.torso.iter().map(place).collect();
        std::array::from_fn(|side| {
            let mut gap = Real::INFINITY;
            for arm in &self.arms[side] {
                let (p1, q1) = place(arm);
                for (body, (p2, q2)) in self.torso.iter().zip(&torso) {
                    let (s, t) = closest_parameters(p1, q1, *p2, *q2);
                    let d = (p1 + (q1 - p1) * s - p2 - (q2 - p2) * t).norm();
                    let r1 = arm.radius_a + (arm.radius_b - arm.radius_a) * s;
                    let r2 = body.radius_a + (body.radius_b - body.radius_a) * t;
                    gap = gap.min(d - r1 - r2);
                }
            }
            gap
        })
    }

    /// `pose` with each arm that comes closer than [`Self::min_gap`] to the torso lifted toward
    /// the T-pose: its chain's rotations scaled by the largest factor in [0, 1] that clears
    /// the gap (found to 1e-6 by bisection within the first of eight equal brackets that
    /// clears). Poses that already clear are returned unchanged, bit for bit; so is everything
    /// but the arms.
    #[must_use]
    pub fn enforce(&self, pose: &Pose) -> Pose {
        if self.min_gap <= 0.0 {
            return pose.clone();
        }
        let mut out = pose.clone();
        let gaps = self.gaps(pose);
        for side in 0..2 {
            if gaps[side] >= self.min_gap {
                continue;
            }
            let lifted = |t: Real| {
                let mut p = out.clone();
                for &j in &ARM_CHAINS[side] {
                    p.set_joint(j, pose.joint(j) * (1.0 - t));
                }
                p
            };
            let clears = |t: Real| self.gaps(&lifted(t))[side] >= self.min_gap;
            const BRACKETS: usize = 8;
            let upper = (1..=BRACKETS)
                .map(|k| k as Real / BRACKETS as Real)
                .find(|&t| clears(t))
                .unwrap_or(1.0);
            let (mut lo, mut hi) = (upper - 1.0 / BRACKETS as Real, upper);
            while hi - lo > 1e-6 {
                let mid = 0.5 * (lo + hi);
                if clears(mid) {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            out = lifted(hi);
        }
        out
    }
}

/// The parameters (s, t) ∈ [0, 1]² of the closest points of segments p1–q1 and p2–q2
/// (Ericson, *Real-Time Collision Detection*, §5.1.9).
pub(crate) fn closest_parameters(p1: Vec3, q1: Vec3, p2: Vec3, q2: Vec3) -> (Real, Real) {
    const EPS: Real = 1e-12;
    let (d1, d2, r) = (q1 - p1, q2 - p2, p1 - p2);
    let (a, e, f) = (d1.dot(&d1), d2.dot(&d2), d2.dot(&r));
    if a <= EPS && e <= EPS {
        return (0.0, 0.0);
    }
    if a <= EPS {
        return (0.0, (f / e).clamp(0.0, 1.0));
    }
    let c = d1.dot(&r);
    if e <= EPS {
        return ((-c / a).clamp(0.0, 1.0), 0.0);
    }
    let b = d1.dot(&d2);
    let denom = a * e - b * b;
    let s = if denom > EPS {
        ((b * f - c * e) / denom).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let t = (b * s + f) / e;
    if t < 0.0 {
        ((-c / a).clamp(0.0, 1.0), 0.0)
    } else if t > 1.0 {
        (((b - c) / a).clamp(0.0, 1.0), 1.0)
    } else {
        (s, t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use garmatnet_core::JOINT_COUNT;
    use proptest::prelude::*;

    #[test]
    fn closest_parameters_match_brute_force() {
        let cases = [
            (
                Vec3::zeros(),
                Vec3::x(),
                Vec3::new(0.5, 1.0, -1.0),
                Vec3::new(0.5, 1.0, 1.0),
            ),
            (
                Vec3::zeros(),
                Vec3::x(),
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(3.0, 1.0, 0.0),
            ),
            (
                Vec3::zeros(),
                Vec3::x(),
                Vec3::new(0.0, 1.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
            ),
            (
                Vec3::zeros(),
                Vec3::zeros(),
                Vec3::new(-1.0, 1.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
            ),
        ];
        for (p1, q1, p2, q2) in cases {
            let (s, t) = closest_parameters(p1, q1, p2, q2);
            let d = |s: Real, t: Real| (p1 + (q1 - p1) * s - p2 - (q2 - p2) * t).norm();
            let brute = (0..=200)
                .flat_map(|i| (0..=200).map(move |j| (i as Real / 200.0, j as Real / 200.0)))
                .map(|(s, t)| d(s, t))
                .fold(Real::INFINITY, Real::min);
            assert!(d(s, t) <= brute + 1e-9, "{d} vs {brute}", d = d(s, t));
        }
    }

    #[test]
    fn the_t_pose_clears_and_a_lowered_arm_swung_into_the_chest_does_not() {
        let check = ArmClearance::new(DEFAULT_ARM_CLEARANCE).unwrap();
        let [left, right] = check.gaps(&Pose::zero());
        // SMPL's rest skeleton is not quite symmetric: 8.3 and 9.1 cm.
        assert!(left > 0.06 && right > 0.06, "{left} {right}");
        // Frame 167 of the old seed-0 brisk motion: the right arm lowered (z 1.08) and swung
        // forward (y 0.98) into the chest, where 22 of 30 fabrics tore.
        let mut pose = Pose::zero();
        pose.set_joint(17, Vec3::new(0.11, 0.98, 1.08));
        pose.set_joint(16, Vec3::new(-0.01, 0.42, -0.3));
        let [left, right] = check.gaps(&pose);
        assert!(right < 0.0, "right arm gap {right}");
        assert!(left > DEFAULT_ARM_CLEARANCE, "left arm gap {left}");
        let fixed = check.enforce(&pose);
        let [_, right] = check.gaps(&fixed);
        assert!(right >= DEFAULT_ARM_CLEARANCE - 1e-9, "gap after {right}");
        assert!(
            right < DEFAULT_ARM_CLEARANCE + 2e-3,
            "lifted further than needed: {right}"
        );
        // Only the offending arm's chain moved (the left arm clears), and only toward the
        // T-pose.
        for j in 0..JOINT_COUNT {
            if ARM_CHAINS[1].contains(&j) {
                assert!(fixed.joint(j).norm() <= pose.joint(j).norm());
            } else {
                assert_eq!(fixed.joint(j), pose.joint(j), "joint {j}");
            }
        }
        assert_eq!(check.enforce(&Pose::zero()), Pose::zero());
        let off = ArmClearance::new(0.0).unwrap();
        assert_eq!(off.enforce(&pose), pose);
    }

    #[test]
    fn bad_clearances_are_refused_with_the_default_named() {
        for bad in [-0.01, 0.5, Real::NAN, Real::INFINITY] {
            let err = ArmClearance::new(bad).unwrap_err().to_string();
            assert!(err.contains("0.04"), "{err}");
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        #[test]
        fn enforced_poses_always_clear(seed in any::<u64>()) {
            let limits = garmatnet_core::JointLimits::default();
            let pose = limits.sample(&mut garmatnet_core::SplitMix64::new(seed), 1.0);
            let check = ArmClearance::new(DEFAULT_ARM_CLEARANCE).unwrap();
            let fixed = check.enforce(&pose);
            for gap in check.gaps(&fixed) {
                prop_assert!(gap >= DEFAULT_ARM_CLEARANCE - 1e-9, "gap {}", gap);
            }
            prop_assert!(limits.validate(&fixed, 1e-12).is_ok());
        }
    }
}
