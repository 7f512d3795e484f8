//! The union of a body's capsules: smooth within each part (the torso, each limb), smooth
//! between parts only near the joints where limbs join, hard everywhere else.
//!
//! One smooth union of every capsule fills the gap wherever two surfaces come within the
//! blend radius of each other, so an arm hanging 1 cm beside the ribs fused into the torso
//! and swallowed the cloth between them. Here the capsules are split into parts: a limb is
//! the capsules carried by a [`LimbRoot`]'s joint and its descendants, the rest is the trunk.
//! With `s` the smooth union of all capsules, `u` the hard minimum of the parts' own smooth
//! unions, each part cut back where another presses into it (below), and `j` the distance to
//! the nearest limb root's ball (`|p - joint| - reach`), the field is
//!
//! `f = max(s, smin(u, j))`,
//!
//! `smin` a quadratic smooth-min of radius 2 cm that rounds the edge where the fill ends.
//!
//! Inside a root's ball (`j ≤ s`) it is the old smooth union `s`: the armpit and the shoulder
//! fill as before. Away from every ball (`j ≥ u + 2 cm`) it is `u`: a limb beside the
//! torso keeps its own surface, and the gap between them stays open however narrow. In
//! between it follows the ball's surface, so the blend's fill ends at the ball. `s ≤ u`
//! always (the fold of quadratic smooth-mins over more capsules is lower), so `f` lies
//! between the two unions. Maxima, minima and quadratic smooth-minima of 1-Lipschitz
//! functions are 1-Lipschitz and continuous, so the field keeps the smooth union's contract: a continuous distance bound,
//! never steeper than one, whose gradient is the active term's exact derivative wherever it
//! is differentiable.
//!
//! **The pinch.** An arm hanging at the side presses into the ribs as a real one does: the
//! capsules overlap by up to a few centimetres, and cloth caught between them had nowhere to
//! go (a sleeve is a tube around the arm; outside the union it must go round the torso too,
//! so it tore). Soft tissue flattens where two parts press together, and cloth lies in the
//! seam between them. So each part is cut back to [`PINCH_HALF_WIDTH`] short of the surface
//! midway between it and any other part, leaving a channel about 1 cm wide through the
//! overlap, open to the outside where the surfaces cross. The channel's lips and the crease
//! where two parts meet are rounded ([`PINCH_SMOOTHING`]), so the contact normal turns
//! smoothly there. Parts more than 2 cm apart are unchanged.

use crate::body::capsule::PreparedCapsule;
use crate::body::skeleton::{JOINT_COUNT, PARENTS};
use crate::error::{Error, Result};
use crate::math::{Real, Vec3};

/// The most limb roots a body may have (each limb is a part of the union, the trunk one more).
pub const MAX_LIMB_ROOTS: usize = 7;

/// Where a limb joins the trunk: the capsules carried by `joint` and its descendants form
/// the limb, and they blend with other parts only within `reach` metres of the joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LimbRoot {
    /// The joint (SMPL index) at the limb's root, e.g. a shoulder or a hip.
    pub joint: usize,
    /// Radius (metres) of the ball around the joint (posed with it) within which the limb
    /// blends into the rest of the body.
    pub reach: Real,
}

/// The reach (metres) of the shoulders' blend balls. Every blend between an arm and the
/// trunk in the T-pose lies within 9 cm of the shoulder joint (measured: with a reach of
/// 9 cm or more the T-pose field is unchanged at 400,000 points within 2 cm of the surface,
/// with 8 cm it moves by up to 0.5 mm); 10 cm leaves a margin. With the arm hanging down,
/// the fill between the upper arm and the chest stops 10 cm from the shoulder, about where
/// a real armpit ends.
pub const SHOULDER_BLEND_REACH: Real = 0.10;

/// The neutral body's limb roots: both shoulders (the arms: upper arm, forearm and hand; the
/// collar capsules stay with the trunk). The legs stay in the trunk's smooth union: in the
/// T-pose the fill between the inner thighs reaches 30 cm below the hips, so keeping them
/// apart would change the rest body the garments are fitted to.
pub const DEFAULT_LIMB_ROOTS: [LimbRoot; 2] = [
    LimbRoot {
        joint: 16,
        reach: SHOULDER_BLEND_REACH,
    },
    LimbRoot {
        joint: 17,
        reach: SHOULDER_BLEND_REACH,
    },
];

/// Checks `roots` and assigns each capsule carrier joint to its part: 0 for the trunk, `r + 1`
/// for the limb of `roots[r]` (the nearest root among the joint and its ancestors).
///
/// # Errors
/// [`Error::OutOfRange`] for more than [`MAX_LIMB_ROOTS`] roots, a joint index past 23 or a
/// reach that is not finite and at least 0; [`Error::DuplicateLimbRoot`] for a joint
/// listed twice.
pub(crate) fn parts_of_joints(roots: &[LimbRoot]) -> Result<[u8; JOINT_COUNT]> {
    if roots.len() > MAX_LIMB_ROOTS {
        return Err(Error::OutOfRange {
            what: "number of limb roots".into(),
            value: roots.len() as Real,
            min: 0.0,
            max: MAX_LIMB_ROOTS as Real,
            hint: "; the neutral body has two (the shoulders)".into(),
        });
    }
    for (i, r) in roots.iter().enumerate() {
        if r.joint >= JOINT_COUNT {
            return Err(Error::OutOfRange {
                what: "limb root joint index".into(),
                value: r.joint as Real,
                min: 0.0,
                max: (JOINT_COUNT - 1) as Real,
                hint: "; use an SMPL joint index (see JOINT_NAMES)".into(),
            });
        }
        if !(r.reach.is_finite() && r.reach >= 0.0) {
            return Err(Error::OutOfRange {
                what: "limb root blend reach (metres)".into(),
                value: r.reach,
                min: 0.0,
                max: Real::INFINITY,
                hint: format!("; the shoulders' default is {SHOULDER_BLEND_REACH}"),
            });
        }
        if roots[..i].iter().any(|o| o.joint == r.joint) {
            return Err(Error::DuplicateLimbRoot { joint: r.joint });
        }
    }
    Ok(std::array::from_fn(|joint| {
        let mut j = Some(joint);
        while let Some(k) = j {
            if let Some(r) = roots.iter().position(|r| r.joint == k) {
                return (r + 1) as u8;
            }
            j = PARENTS[k];
        }
        0
    }))
}

/// The smooth-min radius (metres) between the parts' hard union and the limb roots' balls.
/// A hard minimum there left a crease where the field falls along the gradient of the side
/// that is not active, and [`crate::SignedDistance::push_outside`]'s Newton steps crawled
/// along it without reaching the clearance.
const JOIN_SMOOTHING: Real = 0.02;

/// One step of the quadratic polynomial smooth-min fold:
/// `smin(a, b) = mix(b, a, h) - k h (1 - h)`, `h = clamp(1/2 + (b - a) / 2k, 0, 1)`, whose
/// gradient is `mix(∇b, ∇a, h)` exactly (so the fold is 1-Lipschitz).
#[inline]
fn fold(acc: &mut (Real, Vec3), d: Real, g: Vec3, k: Real) {
    let excess = d - acc.0;
    if excess >= k {
        return;
    }
    if excess <= -k {
        *acc = (d, g);
        return;
    }
    let h = 0.5 + 0.5 * excess / k;
    acc.0 = d + h * (acc.0 - d) - k * h * (1.0 - h);
    acc.1 = g + (acc.1 - g) * h;
}

/// The half-width (metres) of the channel left where two parts press into each other: each
/// part is cut back to `PINCH_HALF_WIDTH` short of the surface midway between them. The
/// rounding ([`PINCH_SMOOTHING`]) lowers the channel's middle by a quarter of its radius,
/// to 5 mm from either wall: room for two layers of cloth with the solver's 3 mm contact
/// margin on each.
pub const PINCH_HALF_WIDTH: Real = 0.006;

/// The radius (metres) of the smooth maximum and minimum that round the channel's lips
/// (where a part's cut meets its own surface) and the crease where two parts meet. With hard
/// ones the contact normal jumped there: cloth lying across the lip or in the crease flipped
/// between two normals from one Newton step to the next and never settled (a third of the
/// first revision-3 samples stopped at the iteration cap, with the largest forces on cloth
/// pressed between a forearm and the belly).
pub const PINCH_SMOOTHING: Real = 0.004;

/// The union of the parts' own fields `by_part` (infinite for a part with nothing near),
/// with a channel wherever two parts press into each other (see the module docs).
///
/// Each part `P` is cut by the bisector with every other part `Q`:
/// `d'_P = smax(d_P, (d_P - d_Q) / 2 + PINCH_HALF_WIDTH, ...)`, and the union is the smooth
/// minimum of the cut parts, both of radius [`PINCH_SMOOTHING`] (`smax(a, b) =
/// -smin(-a, -b)`). The surface moves only where two parts come within
/// `2 (PINCH_HALF_WIDTH + PINCH_SMOOTHING)` of each other (outside `P` the cut term is
/// `PINCH_SMOOTHING` or more below `d_P` unless `Q` is that near, and the smooth minimum
/// equals the hard one wherever the parts' fields differ by more than its radius). Inside
/// `P`, a point nearer to `Q` than its depth plus `2 PINCH_HALF_WIDTH` reads its distance to
/// the seam instead, a smaller depth. Smooth maxima and minima of 1-Lipschitz terms are
/// 1-Lipschitz, so the result is too, and its gradient is continuous across the lips.
fn pinched_union(by_part: &[(Real, Vec3); MAX_LIMB_ROOTS + 1]) -> (Real, Vec3) {
    let mut best = (Real::INFINITY, Vec3::y());
    for (i, &(d, g)) in by_part.iter().enumerate() {
        if !d.is_finite() {
            continue;
        }
        // The smooth maximum as the smooth minimum of the negated terms.
        let mut cut = (-d, -g);
        for (j, &(e, h)) in by_part.iter().enumerate() {
            if j == i || !e.is_finite() {
                continue;
            }
            let c = 0.5 * (d - e) + PINCH_HALF_WIDTH;
            fold(&mut cut, -c, (h - g) * 0.5, PINCH_SMOOTHING);
        }
        fold(&mut best, -cut.0, -cut.1, PINCH_SMOOTHING);
    }
    best
}

/// The union at `p` of `capsules` (in fold order, `parts[i]` the part of capsule `i`) with
/// blend radius `k` and limb-root balls `joins` (centre, reach): see the module docs.
///
/// A capsule whose bounding sphere lies `k` past both running values it could change (the
/// whole fold's and its part's) is skipped without being evaluated. With no joins it is the
/// plain smooth union of every capsule.
pub(crate) fn capsule_union(
    capsules: &[PreparedCapsule],
    parts: &[u8],
    k: Real,
    joins: &[(Vec3, Real)],
    p: &Vec3,
) -> (Real, Vec3) {
    let far = (Real::INFINITY, Vec3::y());
    let mut whole = far;
    let mut by_part = [far; MAX_LIMB_ROOTS + 1];
    let split = !joins.is_empty();
    for (c, &part) in capsules.iter().zip(parts) {
        // The part's fold is never below the whole's, so it decides whether to skip.
        let running = if split {
            by_part[part as usize].0
        } else {
            whole.0
        };
        let reach = running + k + c.bound_radius;
        if reach <= 0.0 || (p - c.bound_centre).norm_squared() >= reach * reach {
            continue;
        }
        let (d, g) = c.distance_and_gradient(p);
        fold(&mut whole, d, g, k);
        if split {
            fold(&mut by_part[part as usize], d, g, k);
        }
    }
    if !split {
        return whole;
    }
    let mut join = far;
    for (centre, reach) in joins {
        let offset = p - centre;
        let n = offset.norm();
        if n - reach < join.0 {
            join = (n - reach, if n > 1e-12 { offset / n } else { Vec3::y() });
        }
    }
    let mut apart = pinched_union(&by_part);
    fold(&mut apart, join.0, join.1, JOIN_SMOOTHING);
    if whole.0 >= apart.0 { whole } else { apart }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::capsule::Capsule;
    use crate::body::capsule_body::{CapsuleBody, DEFAULT_BLEND_RADIUS};
    use crate::body::pose::Pose;
    use crate::body::sdf::SignedDistance;
    use crate::body::skeleton::{Skeleton, joint_index};
    use crate::body::smpl_capsules::smpl_neutral_capsules;
    use crate::rng::SplitMix64;

    fn index(name: &str) -> usize {
        joint_index(name).unwrap()
    }

    /// The neutral body from the neutral capsules whose carrier passes `keep`, with the
    /// default limb roots or none (one smooth union, as before limbs were kept apart).
    fn body_of(keep: impl Fn(usize) -> bool, roots: &[LimbRoot]) -> CapsuleBody {
        let skeleton = Skeleton::smpl_neutral();
        let capsules: Vec<Capsule> = smpl_neutral_capsules(&skeleton)
            .into_iter()
            .filter(|c| keep(c.joint))
            .collect();
        CapsuleBody::with_limb_roots(skeleton, capsules, DEFAULT_BLEND_RADIUS, roots).unwrap()
    }

    /// Both shoulders turned `angle` radians about the forward axis: the left arm (along +x
    /// in the T-pose) towards -y, the right one likewise.
    fn arms_lowered(angle: Real) -> Pose {
        let mut pose = Pose::zero();
        pose.set_joint(index("left_shoulder"), Vec3::new(0.0, 0.0, -angle));
        pose.set_joint(index("right_shoulder"), Vec3::new(0.0, 0.0, angle));
        pose
    }

    const LEFT_ARM: [usize; 4] = [16, 18, 20, 22];
    const ARMS: [usize; 8] = [16, 17, 18, 19, 20, 21, 22, 23];

    #[test]
    fn parts_follow_the_skeleton_from_each_root() {
        let parts = parts_of_joints(&DEFAULT_LIMB_ROOTS).unwrap();
        for (name, part) in [
            ("pelvis", 0),
            ("spine3", 0),
            ("head", 0),
            ("left_collar", 0),
            ("left_shoulder", 1),
            ("left_hand", 1),
            ("right_elbow", 2),
            ("left_knee", 0),
            ("right_foot", 0),
        ] {
            assert_eq!(parts[index(name)], part, "{name}");
        }
        assert_eq!(parts_of_joints(&[]).unwrap(), [0; JOINT_COUNT]);
    }

    #[test]
    fn bad_limb_roots_are_refused() {
        let root = |joint, reach| LimbRoot { joint, reach };
        let too_many: Vec<LimbRoot> = (1..=8).map(|j| root(j, 0.1)).collect();
        for roots in [
            too_many,
            vec![root(24, 0.1)],
            vec![root(16, -0.1)],
            vec![root(16, Real::NAN)],
            vec![root(16, 0.1), root(16, 0.2)],
        ] {
            assert!(parts_of_joints(&roots).is_err(), "{roots:?}");
            let skeleton = Skeleton::smpl_neutral();
            let capsules = smpl_neutral_capsules(&skeleton);
            assert!(CapsuleBody::with_limb_roots(skeleton, capsules, 0.03, &roots).is_err());
        }
    }

    /// With the arms hanging at the sides, wherever the upper arm or forearm is at least
    /// 1 cm from the ribs, the point midway between them is outside the body. One smooth
    /// union of every capsule fused such points into the torso.
    #[test]
    fn arms_at_the_sides_keep_the_gap_to_the_ribs_open() {
        let body = body_of(|_| true, &DEFAULT_LIMB_ROOTS);
        let fused = body_of(|_| true, &[]);
        let trunk = body_of(|j| !ARMS.contains(&j), &[]);
        let arm = body_of(|j| LEFT_ARM.contains(&j), &[]);
        let skeleton = Skeleton::smpl_neutral();
        let (mut open, mut fused_before) = (0, 0);
        for angle in [1.3, 1.35, 1.4] {
            let pose = arms_lowered(angle);
            let joints = skeleton.posed_joints(&pose);
            let (shoulder, elbow) = (joints[index("left_shoulder")], joints[index("left_elbow")]);
            assert!(elbow.y < shoulder.y - 0.2, "the left arm must hang down");
            let [body, fused, trunk, arm] = [&body, &fused, &trunk, &arm].map(|b| b.pose(&pose));
            for k in 1..=30 {
                // Along the arm's axis, from the armpit to past the elbow, moving inwards
                // (-x) from the axis to the arm's surface, then on to the ribs.
                let c = shoulder + (elbow - shoulder) * (0.05 * Real::from(k));
                let at = |x: Real| Vec3::new(x, c.y, c.z);
                let mut x = c.x;
                while arm.distance(&at(x)) < 0.0 {
                    x -= 1e-4;
                }
                let arm_side = x;
                while trunk.distance(&at(x)) > 0.0 && x > 0.0 {
                    x -= 1e-4;
                }
                let gap = arm_side - x;
                if gap < 0.01 || x <= 0.0 {
                    continue;
                }
                let mid = at(0.5 * (arm_side + x));
                let d = body.distance(&mid);
                assert!(
                    d > 0.0,
                    "arms at {angle} rad, {:.2} of the way to the elbow: a {:.1} mm gap is \
                     closed ({:.2} mm)",
                    0.05 * Real::from(k),
                    gap * 1e3,
                    d * 1e3
                );
                open += 1;
                fused_before += usize::from(fused.distance(&mid) < 0.0);
            }
        }
        assert!(open >= 30, "{open} gaps of 1 cm or more");
        // What the limbs' separation changes: gaps the one smooth union closed.
        assert!(fused_before >= 3, "{fused_before} gaps were closed before");
    }

    /// With the arms hanging 86° below the horizontal, the upper arm presses up to 3 cm into
    /// the ribs. Where arm and trunk overlap, outside the shoulder's blend ball, the surface
    /// midway between them lies in a channel [`PINCH_HALF_WIDTH`] from either wall; the one
    /// smooth union filled it (cloth caught there had nowhere to go and tore).
    #[test]
    fn arms_pressed_into_the_ribs_leave_the_cloth_a_channel() {
        let body = body_of(|_| true, &DEFAULT_LIMB_ROOTS);
        let fused = body_of(|_| true, &[]);
        let trunk = body_of(|j| !ARMS.contains(&j), &[]);
        let arm = body_of(|j| LEFT_ARM.contains(&j), &[]);
        let skeleton = Skeleton::smpl_neutral();
        let pose = arms_lowered(1.5);
        let shoulder = skeleton.posed_joints(&pose)[index("left_shoulder")];
        let [body, fused, trunk, arm] = [&body, &fused, &trunk, &arm].map(|b| b.pose(&pose));
        let mut rng = SplitMix64::new(8);
        let (mut channel, mut deepest) = (0, 0.0_f64);
        for _ in 0..200_000 {
            let p = shoulder
                + Vec3::new(
                    rng.uniform(-0.08, 0.02),
                    rng.uniform(-0.35, -0.05),
                    rng.uniform(-0.08, 0.08),
                );
            let (a, t) = (arm.distance(&p), trunk.distance(&p));
            if a >= 0.0 || t >= 0.0 || (a - t).abs() > 2e-3 {
                continue;
            }
            if (p - shoulder).norm() < SHOULDER_BLEND_REACH + 0.03 {
                continue;
            }
            let d = body.distance(&p);
            // Within 1 mm of the middle, less the rounding's quarter radius.
            assert!(
                d >= PINCH_HALF_WIDTH - 1e-3 - PINCH_SMOOTHING / 4.0 - 1e-9,
                "{p:?}: {d} inside the channel"
            );
            assert!(fused.distance(&p) < 0.0, "{p:?} was inside the fused body");
            channel += 1;
            deepest = deepest.max(-a.max(t));
        }
        assert!(channel >= 50, "{channel} channel points");
        assert!(deepest > 0.005, "the overlap is {deepest} m deep");
    }

    /// In the T-pose every blend between an arm and the trunk lies within the shoulders'
    /// reach: the body, armpits included, is exactly the old smooth union outside and in the
    /// 5 mm below the surface where cloth and its contact live. (Deeper inside, a point
    /// nearer another part than its own depth reads the distance to the seam between them.)
    #[test]
    fn the_t_pose_body_is_the_smooth_union_of_every_capsule() {
        let body = body_of(|_| true, &DEFAULT_LIMB_ROOTS);
        let fused = body_of(|_| true, &[]);
        let mut rng = SplitMix64::new(21);
        let mut count = 0;
        while count < 20_000 {
            let p = Vec3::new(
                rng.uniform(-0.9, 0.9),
                rng.uniform(-1.3, 0.6),
                rng.uniform(-0.2, 0.25),
            );
            let d = fused.distance(&p);
            if !(-0.005..=0.03).contains(&d) {
                continue;
            }
            count += 1;
            assert!((body.distance(&p) - d).abs() < 1e-12, "{p:?}");
        }
        // The armpit is filled: the arm and the trunk blend there, below their hard union.
        let armpit = Vec3::new(0.17, 0.16, -0.02);
        let trunk = body_of(|j| !ARMS.contains(&j), &[]);
        let arm = body_of(|j| LEFT_ARM.contains(&j), &[]);
        let hard = trunk.distance(&armpit).min(arm.distance(&armpit));
        let filled = body.distance(&armpit);
        assert!(filled < hard - 1e-3, "{filled} vs {hard}");
    }

    /// The field is continuous and never steeper than one (a distance bound) around arms
    /// at every angle from the T-pose to the sides, the limb balls' edges included.
    #[test]
    fn the_union_is_continuous_and_one_lipschitz() {
        let body = body_of(|_| true, &DEFAULT_LIMB_ROOTS);
        let skeleton = Skeleton::smpl_neutral();
        let mut rng = SplitMix64::new(5);
        for step in 0..=8 {
            let pose = arms_lowered(0.18 * Real::from(step));
            let posed = body.pose(&pose);
            let shoulder = skeleton.posed_joints(&pose)[index("left_shoulder")];
            for _ in 0..4000 {
                let p = shoulder
                    + Vec3::new(
                        rng.uniform(-0.25, 0.15),
                        rng.uniform(-0.4, 0.1),
                        rng.uniform(-0.12, 0.12),
                    );
                let dir = Vec3::new(rng.normal(), rng.normal(), rng.normal()).normalize();
                let q = p + dir * rng.uniform(1e-5, 3e-3);
                let change = (posed.distance(&p) - posed.distance(&q)).abs();
                assert!(
                    change <= (p - q).norm() * (1.0 + 1e-9) + 1e-15,
                    "at {p:?}: {change} over {}",
                    (p - q).norm()
                );
            }
        }
    }
}
