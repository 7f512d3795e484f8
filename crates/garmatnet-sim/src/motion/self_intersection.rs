//! Refusing poses whose body passes through itself.
//!
//! Joint limits bound each joint on its own; they cannot see that a lowered arm swung
//! forward goes through the chest, that a forearm folded down enters the thigh, or that two
//! adducted legs cross through each other. [`SelfIntersection`] measures, on the posed
//! capsules of a [`CapsuleBody`], the gap between every pair of body parts that should not
//! meet, and refuses a pose where one is smaller than allowed:
//!
//! - a pair with an arm capsule (upper arm past its root, forearm, palm, fingers, or the
//!   collar against the *other* arm) must keep [`SelfIntersection::arm_gap_m`] between the
//!   surfaces (default [`DEFAULT_ARM_GAP`], -3 cm: an arm hanging at the side may press up
//!   to 3 cm into the ribs, and the body leaves the cloth a channel there, but no deeper);
//! - any other pair (the legs against each other and the torso) must not overlap.
//!
//! Pairs that touch by construction are skipped: capsules of one joint, of a joint and its
//! parent, the torso's capsules among themselves, and the limb roots against the torso they
//! grow out of: the collars and hips, the upper arm's first [`UPPER_ARM_ROOT_FRACTION`] (the
//! armpit) and the thigh's first [`THIGH_ROOT_FRACTION`] (the crotch, also against the other
//! thigh).
//!
//! The gap between two tapered capsules is taken as the distance between their axes minus the
//! radii at the closest axis points (exact for untapered capsules; for the body's gentle tapers
//! within a few tenths of a millimetre).

use garmatnet_core::{
    Capsule, CapsuleBody, JOINT_NAMES, PARENTS, Pose, Real, Skeleton, SkinnedBody, Vec3,
};

use crate::error::{Error, Result};
use crate::motion::arm_clearance::closest_parameters;

/// The default smallest gap (metres) between an arm and any other body part: negative, so an
/// arm may press up to 3 cm into the torso, a thigh or the other arm, as soft tissue does when
/// the arms hang at the sides (at 86° below the horizontal the neutral body's upper arm
/// overlaps the ribs by 2.1 cm). The body leaves a channel for the cloth wherever two parts
/// press together ([`garmatnet_core::PINCH_HALF_WIDTH`]); deeper than 3 cm, the arm is
/// passing through.
pub const DEFAULT_ARM_GAP: Real = -0.03;

/// The fraction of the upper arm's capsule nearest the shoulder that is not checked against
/// the torso: the armpit, about 15 cm deep, where arm and chest meet with the arm lowered
/// and where a T-shirt's armhole seam joins sleeve and body, so no cloth lies between them.
pub const UPPER_ARM_ROOT_FRACTION: Real = 0.6;

/// The fraction of the thigh's capsule nearest the hip that is not checked against the torso
/// and the other thigh: the crotch, where the thighs meet each other and the pelvis in every
/// pose, the T-pose included.
pub const THIGH_ROOT_FRACTION: Real = 0.45;

/// The body part a joint belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Part {
    /// Pelvis, spine, neck, head.
    Core,
    /// Collar, shoulder, elbow, wrist, hand of one side (0 left, 1 right).
    Arm(usize),
    /// Hip, knee, ankle, foot of one side.
    Leg(usize),
}

fn part(joint: usize) -> Part {
    match joint {
        13 | 16 | 18 | 20 | 22 => Part::Arm(0),
        14 | 17 | 19 | 21 | 23 => Part::Arm(1),
        1 | 4 | 7 | 10 => Part::Leg(0),
        2 | 5 | 8 | 11 => Part::Leg(1),
        _ => Part::Core,
    }
}

/// Whether `joint` is a limb's root (collar or hip).
fn is_limb_root(joint: usize) -> bool {
    matches!(joint, 1 | 2 | 13 | 14)
}

/// Whether `joint` carries the capsule that grows out of a limb root (upper arm, thigh).
fn is_root_bone(joint: usize) -> bool {
    matches!(joint, 1 | 2 | 16 | 17)
}

/// The closest pair of body parts in a pose: which joints carry the two capsules, their gap
/// and the gap they must keep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SelfContact {
    /// The joint carrying the first capsule (an SMPL joint index).
    pub joint_a: usize,
    /// The joint carrying the second capsule.
    pub joint_b: usize,
    /// The gap between the two surfaces (metres; negative where they overlap).
    pub gap_m: Real,
    /// The smallest gap this pair must keep (metres).
    pub required_m: Real,
}

impl SelfContact {
    /// How far the pair falls short of its required gap (metres; positive when refused).
    #[must_use]
    pub fn shortfall_m(&self) -> Real {
        self.required_m - self.gap_m
    }

    /// The typed error refusing this contact.
    #[must_use]
    pub fn to_error(&self) -> Error {
        Error::SelfIntersecting {
            joint_a: JOINT_NAMES[self.joint_a],
            joint_b: JOINT_NAMES[self.joint_b],
            gap_m: self.gap_m,
            required_m: self.required_m,
        }
    }
}

/// One checked pair: capsule indices into the trimmed lists and the gap it must keep.
#[derive(Debug, Clone, Copy)]
struct Pair {
    a: usize,
    b: usize,
    /// Whether `a` is checked with its root trimmed (`trimmed[a]`) rather than whole.
    trim_a: bool,
    trim_b: bool,
    required: Real,
}

/// The self-intersection check of one body: the gap, on the posed capsules of a
/// [`CapsuleBody`], between every pair of body parts that should not meet. A pair with an arm
/// capsule must keep [`SelfIntersection::arm_gap_m`] between the surfaces (an arm at the side
/// may press a little into the ribs); any other pair must not overlap. Pairs that touch by
/// construction (a joint and its parent, the torso's capsules, the limb roots) are skipped.
///
/// ```
/// use garmatnet_core::{CapsuleBody, Pose};
/// use garmatnet_sim::{ArmPlacement, DEFAULT_ARM_GAP, SelfIntersection, Side};
/// let check = SelfIntersection::new(&CapsuleBody::smpl_neutral(), DEFAULT_ARM_GAP).unwrap();
/// assert!(check.worst(&Pose::zero()).is_none()); // the T-pose is clear
/// let mut pose = Pose::zero();
/// // The left arm lowered and swung forward across the chest: through the torso.
/// let across = ArmPlacement { elevation_rad: -0.9, azimuth_rad: 1.8, twist_rad: 0.0, elbow_flex_rad: 0.0 };
/// across.apply(&mut pose, Side::Left);
/// assert!(check.worst(&pose).is_some());
/// ```
#[derive(Debug, Clone)]
pub struct SelfIntersection {
    skeleton: Skeleton,
    whole: Vec<Capsule>,
    trimmed: Vec<Capsule>,
    pairs: Vec<Pair>,
    arm_gap: Real,
}

impl SelfIntersection {
    /// The check for `body`, keeping `arm_gap_m` metres between an arm and any other part.
    ///
    /// # Errors
    /// [`garmatnet_core::Error::OutOfRange`] unless `arm_gap_m` is finite and in -0.05 …
    /// 0.05 m (negative lets an arm press that deep into another part; more than 5 cm either
    /// way passes an arm through the torso or forbids arms hanging at the sides).
    pub fn new(body: &CapsuleBody, arm_gap_m: Real) -> Result<Self> {
        if !(arm_gap_m.is_finite() && (-0.05..=0.05).contains(&arm_gap_m)) {
            return Err(garmatnet_core::Error::OutOfRange {
                what: "smallest arm gap (metres)".into(),
                value: arm_gap_m,
                min: -0.05,
                max: 0.05,
                hint: format!("; the default is {DEFAULT_ARM_GAP}"),
            }
            .into());
        }
        let whole = body.capsules().to_vec();
        let trimmed: Vec<Capsule> = whole
            .iter()
            .map(|c| {
                if is_root_bone(c.joint) {
                    let f = if matches!(part(c.joint), Part::Arm(_)) {
                        UPPER_ARM_ROOT_FRACTION
                    } else {
                        THIGH_ROOT_FRACTION
                    };
                    Capsule {
                        a: c.a + (c.b - c.a) * f,
                        radius_a: c.radius_a + (c.radius_b - c.radius_a) * f,
                        ..*c
                    }
                } else {
                    *c
                }
            })
            .collect();
        let mut pairs = Vec::new();
        for a in 0..whole.len() {
            for b in a + 1..whole.len() {
                let (ja, jb) = (whole[a].joint, whole[b].joint);
                if ja == jb || PARENTS[ja] == Some(jb) || PARENTS[jb] == Some(ja) {
                    continue;
                }
                let (pa, pb) = (part(ja), part(jb));
                let arm = matches!(pa, Part::Arm(_)) || matches!(pb, Part::Arm(_));
                let pair = match (pa, pb) {
                    (Part::Core, Part::Core) => None,
                    // Collars and hips sit on the torso; the bones they carry grow out of it.
                    (Part::Core, _) if is_limb_root(jb) => None,
                    (_, Part::Core) if is_limb_root(ja) => None,
                    (Part::Core, _) | (_, Part::Core) => Some((true, true)),
                    (x, y) if x == y => Some((false, false)),
                    // The two collars meet nothing of the other side but its arm.
                    _ if is_limb_root(ja) && is_limb_root(jb) => None,
                    // Opposite thighs meet at the crotch: only past their roots.
                    (Part::Leg(_), Part::Leg(_)) => Some((true, true)),
                    _ => Some((false, false)),
                };
                if let Some((trim_a, trim_b)) = pair {
                    pairs.push(Pair {
                        a,
                        b,
                        trim_a,
                        trim_b,
                        // Cloth lies between an arm and another part, not between the
                        // bones of one limb.
                        required: if arm && pa != pb { arm_gap_m } else { 0.0 },
                    });
                }
            }
        }
        Ok(Self {
            skeleton: body.skeleton().clone(),
            whole,
            trimmed,
            pairs,
            arm_gap: arm_gap_m,
        })
    }

    /// The smallest gap (metres) kept between an arm and any other body part.
    #[must_use]
    pub fn arm_gap_m(&self) -> Real {
        self.arm_gap
    }

    /// The checked pair with the smallest margin (gap minus required gap) in `pose`, whether
    /// or not it is refused.
    #[must_use]
    pub fn closest(&self, pose: &Pose) -> SelfContact {
        let transforms = self.skeleton.skinning_transforms(pose);
        let place = |c: &Capsule| {
            let t = &transforms[c.joint];
            (
                t.rotation * c.a + t.translation.vector,
                t.rotation * c.b + t.translation.vector,
            )
        };
        let whole: Vec<(Vec3, Vec3)> = self.whole.iter().map(place).collect();
        let trimmed: Vec<(Vec3, Vec3)> = self.trimmed.iter().map(place).collect();
        let mut closest = SelfContact {
            joint_a: 0,
            joint_b: 0,
            gap_m: Real::INFINITY,
            required_m: 0.0,
        };
        for pair in &self.pairs {
            let pick = |i: usize, trim: bool| {
                if trim {
                    (&self.trimmed[i], trimmed[i])
                } else {
                    (&self.whole[i], whole[i])
                }
            };
            let (ca, (p1, q1)) = pick(pair.a, pair.trim_a);
            let (cb, (p2, q2)) = pick(pair.b, pair.trim_b);
            let (s, t) = closest_parameters(p1, q1, p2, q2);
            let distance = (p1 + (q1 - p1) * s - p2 - (q2 - p2) * t).norm();
            let ra = ca.radius_a + (ca.radius_b - ca.radius_a) * s;
            let rb = cb.radius_a + (cb.radius_b - cb.radius_a) * t;
            let gap = distance - ra - rb;
            if gap.is_nan() {
                return SelfContact {
                    joint_a: ca.joint,
                    joint_b: cb.joint,
                    gap_m: Real::NAN,
                    required_m: pair.required,
                };
            }
            if gap - pair.required < closest.gap_m - closest.required_m {
                closest = SelfContact {
                    joint_a: ca.joint,
                    joint_b: cb.joint,
                    gap_m: gap,
                    required_m: pair.required,
                };
            }
        }
        closest
    }

    /// The refused pair with the largest shortfall in `pose`, or `None` when the pose is
    /// clear. NaN in the pose counts as refused.
    #[must_use]
    pub fn worst(&self, pose: &Pose) -> Option<SelfContact> {
        let closest = self.closest(pose);
        (closest.shortfall_m() > 0.0 || closest.gap_m.is_nan()).then_some(closest)
    }

    /// Checks `pose`.
    ///
    /// # Errors
    /// [`Error::SelfIntersecting`] naming the worst pair when the body passes through
    /// itself (or comes closer than the arm gap).
    pub fn check(&self, pose: &Pose) -> Result<()> {
        match self.worst(pose) {
            Some(contact) => Err(contact.to_error()),
            None => Ok(()),
        }
    }
}

/// The worst self-intersection of `body` in `pose` at the default arm gap
/// ([`DEFAULT_ARM_GAP`]), or `None` when the pose is clear. Builds the pair list on every
/// call: for many poses, make one [`SelfIntersection`] and call
/// [`SelfIntersection::worst`].
#[must_use]
pub fn self_intersection(body: &CapsuleBody, pose: &Pose) -> Option<SelfContact> {
    SelfIntersection::new(body, DEFAULT_ARM_GAP)
        .unwrap_or_else(|_| unreachable!("the default arm gap is valid"))
        .worst(pose)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::arm_placement::{ArmPlacement, Side};
    use std::sync::OnceLock;

    fn check() -> &'static SelfIntersection {
        static CHECK: OnceLock<SelfIntersection> = OnceLock::new();
        CHECK.get_or_init(|| {
            SelfIntersection::new(&CapsuleBody::smpl_neutral(), DEFAULT_ARM_GAP).unwrap()
        })
    }

    fn arms(elevation_deg: Real, azimuth_deg: Real, elbow: Real) -> Pose {
        let mut pose = Pose::zero();
        let arm = ArmPlacement {
            elevation_rad: elevation_deg.to_radians(),
            azimuth_rad: azimuth_deg.to_radians(),
            twist_rad: 0.0,
            elbow_flex_rad: elbow,
        };
        arm.apply(&mut pose, Side::Left);
        arm.apply(&mut pose, Side::Right);
        pose
    }

    #[test]
    fn the_t_pose_and_arms_at_the_sides_are_clear() {
        let rest = check().closest(&Pose::zero());
        assert!(rest.gap_m > 0.03, "{rest:?}");
        // Arms hanging 84° below the horizontal press into the ribs, within the 3 cm allowed.
        let down = arms(-84.0, -10.0, 0.15);
        let closest = check().closest(&down);
        assert!(closest.gap_m < 0.0, "{closest:?}");
        assert!(check().worst(&down).is_none(), "{closest:?}");
        check().check(&down).unwrap();
    }

    #[test]
    fn an_arm_turned_into_the_torso_is_refused_with_the_pair_named() {
        // The left arm lowered and swung forward across the chest.
        let mut pose = Pose::zero();
        ArmPlacement {
            elevation_rad: -0.9,
            azimuth_rad: 1.8,
            twist_rad: 0.0,
            elbow_flex_rad: 0.0,
        }
        .apply(&mut pose, Side::Left);
        let contact = check().worst(&pose).expect("refused");
        assert!(contact.gap_m < 0.0, "{contact:?}");
        assert!(
            [13, 16, 18, 20, 22].contains(&contact.joint_a)
                || [13, 16, 18, 20, 22].contains(&contact.joint_b)
        );
        match check().check(&pose) {
            Err(Error::SelfIntersecting {
                gap_m, required_m, ..
            }) => {
                assert!(gap_m < 0.0 && required_m == DEFAULT_ARM_GAP);
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(
            self_intersection(&CapsuleBody::smpl_neutral(), &pose),
            Some(contact)
        );
    }

    #[test]
    fn arms_straight_down_press_into_the_torso_and_the_gap_decides() {
        // Hanging straight down, the arm of the neutral body presses into the torso's side,
        // less deeply than the default allows.
        let straight = arms(-89.0, 0.0, 0.0);
        let gap = check().closest(&straight).gap_m;
        assert!(gap < 0.0 && gap > DEFAULT_ARM_GAP, "{gap}");
        // An arm pressing in less than the default but touching: accepted by default,
        // refused when no overlap is allowed.
        let near = (0..400)
            .map(|i| arms(-70.0 - 0.05 * i as Real, 12.0, 0.15))
            .find(|p| {
                let gap = check().closest(p).gap_m;
                gap < 0.0 && gap > DEFAULT_ARM_GAP
            })
            .expect("some elevation presses the arm into the ribs");
        assert!(check().worst(&near).is_none());
        let strict = SelfIntersection::new(&CapsuleBody::smpl_neutral(), 0.0).unwrap();
        assert!(strict.worst(&near).is_some());
    }

    #[test]
    fn crossed_legs_are_refused_and_an_arm_resting_on_the_thigh_is_not() {
        // Both hips fully adducted (within the joint limits): the shins cross.
        let mut legs = Pose::zero();
        legs.set_joint(1, Vec3::new(0.0, 0.0, -0.3));
        legs.set_joint(2, Vec3::new(0.0, 0.0, 0.3));
        let contact = check().worst(&legs).expect("crossed legs refused");
        assert_eq!(contact.required_m, 0.0);
        assert!(matches!(part(contact.joint_a), Part::Leg(_)));
        // Sitting with the arm hanging forward onto the thigh: the arm presses into the body
        // less than the 3 cm allowed, so the default accepts it and a check that allows no
        // overlap refuses it.
        let mut sitting = arms(-85.0, 40.0, 0.0);
        sitting.set_joint(1, Vec3::new(-1.5, 0.0, 0.0));
        sitting.set_joint(2, Vec3::new(-1.5, 0.0, 0.0));
        sitting.set_joint(4, Vec3::new(1.5, 0.0, 0.0));
        sitting.set_joint(5, Vec3::new(1.5, 0.0, 0.0));
        assert!(check().worst(&sitting).is_none());
        let strict = SelfIntersection::new(&CapsuleBody::smpl_neutral(), 0.0).unwrap();
        let contact = strict
            .worst(&sitting)
            .expect("touching refused without overlap");
        assert!(
            contact.gap_m < 0.0 && contact.gap_m > DEFAULT_ARM_GAP,
            "{contact:?}"
        );
    }

    #[test]
    fn nan_and_bad_gaps_are_refused() {
        let mut pose = Pose::zero();
        pose.set_joint(18, Vec3::new(Real::NAN, 0.0, 0.0));
        assert!(check().worst(&pose).is_some());
        for bad in [-0.06, 0.2, Real::NAN, Real::INFINITY] {
            assert!(SelfIntersection::new(&CapsuleBody::smpl_neutral(), bad).is_err());
        }
    }
}
