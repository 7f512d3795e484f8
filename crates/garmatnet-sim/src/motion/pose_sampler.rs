//! A seeded sampler of independent everyday poses.
//!
//! [`crate::MotionGenerator`] walks one smooth motion, so its frames are neighbours of each
//! other and its arms never hang lower than about 45° (see its docs). [`PoseSampler`] draws
//! every pose on its own, in an anatomically meaningful parametrisation rather than raw
//! axis-angle components:
//!
//! - **arms** ([`ArmPlacement`]): the upper arm's direction in the chest's frame (elevation
//!   above the horizontal and azimuth from the side toward the front), its twist about
//!   itself and the elbow's bend; the collar follows (shrugs as the arm rises, leans forward
//!   as it reaches). Each arm hangs at the side (elevation −88° … −60°; below about −75° the upper arm presses
//!   into the ribs, which the body allows up to 3 cm), lies in between
//!   (−60° … 45°, in front of the body to somewhat behind it) or is raised (45° … 85°), with
//!   the probabilities of [`PoseSamplerConfig`];
//! - **torso**: a bend forward or back, a twist and a side bend, each spread evenly over
//!   spine1–3;
//! - **legs**: standing, apart, mid-stride (one leg forward, the other back, the back knee
//!   bent) or sitting-ish (hips and knees bent), with a weight shift (pelvis tilted over one
//!   leg, the other knee bent) on some;
//! - head and neck look around a little; wrists bend.
//!
//! Every pose lies within [`PoseSamplerConfig::limits`] and is refused and redrawn when the
//! body passes through itself ([`SelfIntersection`], arms kept
//! [`PoseSamplerConfig::arm_gap_m`] off every other part). Pose `i` depends only on the seed
//! and `i` (each index draws from its own SplitMix64 stream), so the first N of N + k poses are
//! the N poses, whatever the thread count.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use garmatnet_core::{
    CapsuleBody, JOINT_COUNT, JointLimits, Pose, Real, SkinnedBody, SplitMix64, Vec3,
};

use crate::error::{Error, Result};
use crate::motion::arm_placement::{ArmPlacement, Side};
use crate::motion::self_intersection::{DEFAULT_ARM_GAP, SelfIntersection};

/// The default fraction of arms drawn hanging at the side.
pub const DEFAULT_HANGING_FRACTION: Real = 0.5;

/// The default fraction of arms drawn raised above 45°.
pub const DEFAULT_RAISED_FRACTION: Real = 0.2;

/// How far (degrees) a paired right arm's elevation lies from the left arm's
/// ([`PoseSamplerConfig::paired_fraction`]).
pub const PAIRED_ELEVATION_SPREAD_DEG: Real = 15.0;

/// How far (degrees) a paired right arm's azimuth lies from the left arm's
/// ([`PoseSamplerConfig::paired_fraction`]).
pub const PAIRED_AZIMUTH_SPREAD_DEG: Real = 25.0;

/// The elevations (degrees, lowest and highest) of an arm held out to the side
/// ([`PoseSamplerConfig::side_fraction`]).
pub const SIDE_ELEVATION_DEG: [Real; 2] = [-25.0, 25.0];

/// The azimuths (degrees from the side toward the front, lowest and highest) of an arm held
/// out to the side ([`PoseSamplerConfig::side_fraction`]).
pub const SIDE_AZIMUTH_DEG: [Real; 2] = [-25.0, 35.0];

/// Settings of [`PoseSampler`]. Missing fields take the defaults when read from JSON.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PoseSamplerConfig {
    /// Seed: the same seed and settings give bit-identical poses.
    pub seed: u64,
    /// Smallest gap (metres) kept between an arm and any other body part
    /// ([`SelfIntersection`]; default [`DEFAULT_ARM_GAP`], -3 cm: an arm may press 3 cm into
    /// another part).
    pub arm_gap_m: Real,
    /// Fraction ∈ [0, 1] of arms drawn hanging at the side, elevation −88° … −60° (default
    /// [`DEFAULT_HANGING_FRACTION`]). Hanging arms that would touch the torso are redrawn, so
    /// the fraction of poses with the arm that low comes out somewhat smaller.
    pub hanging_fraction: Real,
    /// Fraction ∈ [0, 1] of arms drawn raised, elevation 45° … 85° (default
    /// [`DEFAULT_RAISED_FRACTION`]); the rest lie in between. `hanging_fraction +
    /// raised_fraction` is at most 1.
    pub raised_fraction: Real,
    /// Fraction ∈ [0, 1] of poses whose arms are placed alike (default 0): the right arm
    /// points within [`PAIRED_ELEVATION_SPREAD_DEG`] of the left arm's elevation and
    /// [`PAIRED_AZIMUTH_SPREAD_DEG`] of its azimuth (mirrored), its twist and elbow drawn on
    /// their own. People often hold both arms alike (a T-pose, an A-pose, a walk's swing,
    /// both arms forward); with independent arms, poses with both arms near the horizontal
    /// (both within 20°) are rare (1.6 % of 1,000 with the default bands), and there a stiff
    /// shirt rides up most. 0 draws the revision-3 and -4 datasets' poses; any other
    /// fraction draws other poses for the same seed.
    pub paired_fraction: Real,
    /// Fraction ∈ [0, 1] of poses with both arms held out to the side near the horizontal
    /// (default 0): each arm's elevation within [`SIDE_ELEVATION_DEG`] and its azimuth
    /// within [`SIDE_AZIMUTH_DEG`], drawn on its own, as in a T-pose or a walk's arms
    /// spread for balance. There the arms lift a shirt most (a stiff one rides up about
    /// 5 cm), and without it such poses are rare: both arms within 20° of the horizontal and
    /// 35° of the shoulder line in 0.4 % of poses at the default settings, 5.4 % with
    /// hanging and raised fractions of 0.2 and `paired_fraction` 0.7, 36.7 % with this at
    /// 0.5 besides (1,000 poses of seed 9). These poses are drawn first; `paired_fraction`
    /// applies to the rest. 0 draws the poses of datasets made without it; any other
    /// fraction draws other poses for the same seed.
    pub side_fraction: Real,
    /// The limits every pose lies within (default [`JointLimits::everyday`]).
    pub limits: JointLimits,
    /// How many poses to draw for one index before giving up with
    /// [`Error::PoseSamplingExhausted`] (default 1000; about 1 in 3 draws is refused with
    /// the defaults).
    pub max_attempts: usize,
}

impl Default for PoseSamplerConfig {
    fn default() -> Self {
        Self {
            seed: 0,
            arm_gap_m: DEFAULT_ARM_GAP,
            hanging_fraction: DEFAULT_HANGING_FRACTION,
            raised_fraction: DEFAULT_RAISED_FRACTION,
            paired_fraction: 0.0,
            side_fraction: 0.0,
            limits: JointLimits::everyday(),
            max_attempts: 1000,
        }
    }
}

/// How often an arm is redrawn on its own, its body kept, before the whole pose is redrawn.
const ARM_RETRIES: usize = 16;

/// The seeded sampler of independent everyday poses. Each pose is drawn on its own in an
/// anatomical parametrisation (each arm's direction, twist and elbow bend; a torso bend,
/// twist and side bend; standing, stride or sitting-ish legs with a weight shift; head and
/// wrists), within [`PoseSamplerConfig::limits`], and redrawn when the body passes through
/// itself ([`SelfIntersection`]). Pose `i` depends only on the seed and `i`, so the first N
/// of N + k poses are the N poses, whatever the thread count.
///
/// ```
/// use garmatnet_sim::{PoseSampler, PoseSamplerConfig};
/// let sampler = PoseSampler::new(PoseSamplerConfig { seed: 7, ..Default::default() }).unwrap();
/// let poses = sampler.poses(3).unwrap();
/// assert_eq!(poses[2], sampler.pose(2).unwrap()); // pose i depends only on (seed, i)
/// ```
#[derive(Debug, Clone)]
pub struct PoseSampler {
    config: PoseSamplerConfig,
    body: CapsuleBody,
    check: SelfIntersection,
}

impl PoseSampler {
    /// A sampler on [`CapsuleBody::smpl_neutral`].
    ///
    /// # Errors
    /// As [`PoseSampler::with_body`].
    pub fn new(config: PoseSamplerConfig) -> Result<Self> {
        Self::with_body(config, CapsuleBody::smpl_neutral())
    }

    /// A sampler whose poses keep `body` free of self-intersection.
    ///
    /// # Errors
    /// [`garmatnet_core::Error::OutOfRange`] for fractions outside [0, 1] or summing past 1,
    /// `max_attempts` of 0, an arm gap outside -0.05 … 0.05 m, or limits without 24 joints or
    /// with a lower bound above its upper bound.
    pub fn with_body(config: PoseSamplerConfig, body: CapsuleBody) -> Result<Self> {
        let out_of_range = |what: &str, value: Real, min: Real, max: Real| {
            Error::from(garmatnet_core::Error::OutOfRange {
                what: what.into(),
                value,
                min,
                max,
                hint: String::new(),
            })
        };
        for (what, value) in [
            ("pose sampler's hanging_fraction", config.hanging_fraction),
            ("pose sampler's raised_fraction", config.raised_fraction),
            ("pose sampler's paired_fraction", config.paired_fraction),
            ("pose sampler's side_fraction", config.side_fraction),
            (
                "pose sampler's hanging_fraction + raised_fraction",
                config.hanging_fraction + config.raised_fraction,
            ),
        ] {
            if !(0.0..=1.0).contains(&value) {
                return Err(out_of_range(what, value, 0.0, 1.0));
            }
        }
        if config.max_attempts == 0 {
            return Err(out_of_range("pose sampler's max_attempts", 0.0, 1.0, 1e9));
        }
        let limits = &config.limits;
        if limits.min.len() != JOINT_COUNT || limits.max.len() != JOINT_COUNT {
            return Err(out_of_range(
                "pose sampler's joint limits (joints)",
                limits.min.len().min(limits.max.len()) as Real,
                JOINT_COUNT as Real,
                JOINT_COUNT as Real,
            ));
        }
        for j in 0..JOINT_COUNT {
            for c in 0..3 {
                let (lo, hi) = (limits.min[j][c], limits.max[j][c]);
                if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
                    return Err(out_of_range(
                        &format!("pose sampler's joint {j} lower limit, component {c}"),
                        lo,
                        Real::NEG_INFINITY,
                        hi,
                    ));
                }
            }
        }
        let check = SelfIntersection::new(&body, config.arm_gap_m)?;
        Ok(Self {
            config,
            body,
            check,
        })
    }

    /// The settings.
    #[must_use]
    pub fn config(&self) -> &PoseSamplerConfig {
        &self.config
    }

    /// The self-intersection check the poses pass.
    #[must_use]
    pub fn self_intersection(&self) -> &SelfIntersection {
        &self.check
    }

    /// Pose `index`: within the limits and free of self-intersection, a function of the seed,
    /// the settings and `index` alone.
    ///
    /// # Errors
    /// [`Error::PoseSamplingExhausted`] if `max_attempts` draws are all refused.
    pub fn pose(&self, index: u64) -> Result<Pose> {
        let mut rng = stream(self.config.seed, index);
        let skeleton = self.body.skeleton();
        let limits = &self.config.limits;
        let mut attempts = 0;
        while attempts < self.config.max_attempts {
            attempts += 1;
            let mut pose = self.draw_body(&mut rng);
            pose = limits.clamp(&pose);
            if self.check.worst(&pose).is_some() {
                continue;
            }
            // No draw at all for a fraction of 0: the poses of datasets made without side or
            // paired arms stay as they were.
            let mut chance = |fraction: Real| fraction > 0.0 && rng.next_f64() < fraction;
            let out_to_the_side = chance(self.config.side_fraction);
            let paired = !out_to_the_side && chance(self.config.paired_fraction);
            let mut left = None;
            let mut placed = true;
            for side in [Side::Left, Side::Right] {
                // The band is kept while the arm is redrawn: hanging arms, refused most
                // often, keep their share.
                let band = rng.next_f64();
                let mut ok = false;
                for _ in 0..ARM_RETRIES {
                    let mut candidate = pose.clone();
                    let placement = match left {
                        _ if out_to_the_side => side_arm(&mut rng),
                        Some(first) if paired => pair_arm(&mut rng, first),
                        _ => self.draw_arm(&mut rng, band),
                    };
                    placement.apply_on(skeleton, &mut candidate, side);
                    draw_forearm(&mut rng, limits, &mut candidate, side);
                    if limits.validate(&candidate, 0.0).is_ok()
                        && self.check.worst(&candidate).is_none()
                    {
                        pose = candidate;
                        left = Some(placement);
                        ok = true;
                        break;
                    }
                }
                if !ok {
                    placed = false;
                    break;
                }
            }
            if placed {
                return Ok(pose);
            }
        }
        Err(Error::PoseSamplingExhausted { index, attempts })
    }

    /// Poses `0..count`, drawn in parallel (the result does not depend on the thread count).
    ///
    /// # Errors
    /// As [`PoseSampler::pose`], for the first index that fails.
    pub fn poses(&self, count: usize) -> Result<Vec<Pose>> {
        (0..count as u64)
            .into_par_iter()
            .map(|i| self.pose(i))
            .collect()
    }

    /// One arm's placement, from the hanging, middle or raised band (`band` uniform in
    /// [0, 1) picks it).
    fn draw_arm(&self, rng: &mut SplitMix64, band: Real) -> ArmPlacement {
        let deg = |d: Real| d.to_radians();
        let (elevation, azimuth) = if band < self.config.hanging_fraction {
            (
                rng.uniform(deg(-88.0), deg(-60.0)),
                rng.uniform(deg(-40.0), deg(30.0)),
            )
        } else if band < self.config.hanging_fraction + self.config.raised_fraction {
            (
                rng.uniform(deg(45.0), deg(85.0)),
                rng.uniform(deg(-30.0), deg(100.0)),
            )
        } else {
            (
                rng.uniform(deg(-60.0), deg(45.0)),
                rng.uniform(deg(-45.0), deg(110.0)),
            )
        };
        place_arm(rng, elevation, azimuth)
    }

    /// Everything but the arms: torso, legs, weight shift, head.
    fn draw_body(&self, rng: &mut SplitMix64) -> Pose {
        let mut pose = Pose::zero();
        // Torso: a bend (mostly small, sometimes well forward, sometimes back), a twist and a
        // side bend, each spread evenly over the three spine joints.
        let bend_kind = rng.next_f64();
        let bend = if bend_kind < 0.6 {
            rng.uniform(-0.1, 0.25)
        } else if bend_kind < 0.85 {
            rng.uniform(0.25, 0.95)
        } else {
            rng.uniform(-0.45, -0.1)
        };
        let twist = rng.uniform(-0.65, 0.65);
        let side_bend = rng.uniform(-0.35, 0.35);
        for j in [3, 6, 9] {
            pose.set_joint(j, Vec3::new(bend, twist, side_bend) / 3.0);
        }
        // Legs: standing, apart, mid-stride or sitting-ish.
        let stance = rng.next_f64();
        let (mut left_hip, mut right_hip, mut left_knee, mut right_knee) = if stance < 0.35 {
            let mut hip = |abduct: Real| {
                Vec3::new(
                    rng.uniform(-0.15, 0.1),
                    rng.uniform(-0.1, 0.1),
                    abduct * rng.uniform(0.0, 0.12),
                )
            };
            let (left, right) = (hip(1.0), hip(-1.0));
            (left, right, rng.uniform(0.0, 0.2), rng.uniform(0.0, 0.2))
        } else if stance < 0.6 {
            let mut hip = |abduct: Real| {
                Vec3::new(
                    rng.uniform(-0.2, 0.1),
                    rng.uniform(-0.2, 0.2),
                    abduct * rng.uniform(0.15, 0.5),
                )
            };
            let (left, right) = (hip(1.0), hip(-1.0));
            (left, right, rng.uniform(0.0, 0.4), rng.uniform(0.0, 0.4))
        } else if stance < 0.9 {
            // Mid-stride: one leg forward, the other back with its knee bent.
            let mut hip = |lo: Real, hi: Real| {
                Vec3::new(
                    rng.uniform(lo, hi),
                    rng.uniform(-0.1, 0.1),
                    rng.uniform(0.0, 0.1),
                )
            };
            let (front, back) = (hip(-0.8, -0.2), hip(0.05, 0.45));
            let (front_knee, back_knee) = (rng.uniform(0.0, 0.5), rng.uniform(0.1, 0.9));
            let mirror = |v: Vec3| Vec3::new(v.x, -v.y, -v.z);
            if rng.next_f64() < 0.5 {
                (front, mirror(back), front_knee, back_knee)
            } else {
                (back, mirror(front), back_knee, front_knee)
            }
        } else {
            // Sitting-ish: hips and knees bent about equally.
            let hips = rng.uniform(-1.5, -0.8);
            let spread = rng.uniform(0.0, 0.35);
            let left = Vec3::new(hips + rng.uniform(-0.1, 0.1), 0.0, spread);
            let right = Vec3::new(hips + rng.uniform(-0.1, 0.1), 0.0, -spread);
            (
                left,
                right,
                -hips + rng.uniform(-0.2, 0.3),
                -hips + rng.uniform(-0.2, 0.3),
            )
        };
        // A weight shift on some: the pelvis tilts over one leg, both hips turn back so the
        // legs stay upright, the free knee bends.
        let mut pelvis = Vec3::new(rng.uniform(-0.12, 0.12), rng.uniform(-0.2, 0.2), 0.0);
        if rng.next_f64() < 0.4 {
            let tilt = rng.uniform(-0.15, 0.15);
            pelvis.z = tilt;
            left_hip.z -= tilt;
            right_hip.z -= tilt;
            let free_knee = rng.uniform(0.1, 0.4);
            if tilt > 0.0 {
                right_knee += free_knee;
            } else {
                left_knee += free_knee;
            }
        }
        pose.set_joint(0, pelvis);
        pose.set_joint(1, left_hip);
        pose.set_joint(2, right_hip);
        pose.set_joint(4, Vec3::new(left_knee, 0.0, 0.0));
        pose.set_joint(5, Vec3::new(right_knee, 0.0, 0.0));
        // Ankles keep the feet roughly level; feet, neck and head move a little.
        for (ankle, hip, knee) in [(7, left_hip.x, left_knee), (8, right_hip.x, right_knee)] {
            let level = -(hip + knee) * 0.4 + rng.uniform(-0.15, 0.15);
            pose.set_joint(ankle, Vec3::new(level, 0.0, 0.0));
        }
        pose.set_joint(
            12,
            Vec3::new(
                rng.uniform(-0.2, 0.25),
                rng.uniform(-0.3, 0.3),
                rng.uniform(-0.15, 0.15),
            ),
        );
        pose.set_joint(
            15,
            Vec3::new(
                rng.uniform(-0.15, 0.2),
                rng.uniform(-0.2, 0.2),
                rng.uniform(-0.1, 0.1),
            ),
        );
        pose
    }
}

/// The second arm of a paired pose: pointing near where `first` points (within
/// [`PAIRED_ELEVATION_SPREAD_DEG`] and [`PAIRED_AZIMUTH_SPREAD_DEG`], kept within the
/// bands' overall span), its own twist and elbow bend.
fn pair_arm(rng: &mut SplitMix64, first: ArmPlacement) -> ArmPlacement {
    let deg = |d: Real| d.to_radians();
    let spread = |rng: &mut SplitMix64, d: Real| rng.uniform(-deg(d), deg(d));
    let elevation = (first.elevation_rad + spread(rng, PAIRED_ELEVATION_SPREAD_DEG))
        .clamp(deg(-88.0), deg(85.0));
    let azimuth =
        (first.azimuth_rad + spread(rng, PAIRED_AZIMUTH_SPREAD_DEG)).clamp(deg(-45.0), deg(110.0));
    place_arm(rng, elevation, azimuth)
}

/// An arm held out to the side near the horizontal (within [`SIDE_ELEVATION_DEG`] and
/// [`SIDE_AZIMUTH_DEG`]), with a drawn twist and elbow bend.
fn side_arm(rng: &mut SplitMix64) -> ArmPlacement {
    let draw =
        |rng: &mut SplitMix64, [lo, hi]: [Real; 2]| rng.uniform(lo.to_radians(), hi.to_radians());
    let elevation = draw(rng, SIDE_ELEVATION_DEG);
    let azimuth = draw(rng, SIDE_AZIMUTH_DEG);
    place_arm(rng, elevation, azimuth)
}

/// An arm pointing at (`elevation`, `azimuth`) with a drawn twist and elbow bend (straight
/// or nearly so 3 times in 10).
fn place_arm(rng: &mut SplitMix64, elevation: Real, azimuth: Real) -> ArmPlacement {
    let elbow = if rng.next_f64() < 0.3 {
        rng.uniform(0.0, 0.25)
    } else {
        rng.uniform(0.25, 2.1)
    };
    ArmPlacement {
        elevation_rad: elevation,
        azimuth_rad: azimuth,
        twist_rad: rng.uniform(-0.6, 0.6),
        elbow_flex_rad: elbow,
    }
}

/// The forearm's twist and the wrist's bend of `side`, within 0.6 of the limits.
fn draw_forearm(rng: &mut SplitMix64, limits: &JointLimits, pose: &mut Pose, side: Side) {
    let (elbow, wrist) = match side {
        Side::Left => (18, 20),
        Side::Right => (19, 21),
    };
    let mut e = pose.joint(elbow);
    e.x = rng.uniform(-0.4, 0.4);
    pose.set_joint(elbow, e);
    let w =
        Vec3::from_fn(|c, _| rng.uniform(0.6 * limits.min[wrist][c], 0.6 * limits.max[wrist][c]));
    pose.set_joint(wrist, w);
}

/// The random stream of pose `index` under `seed`: two SplitMix64 outputs mixed, so streams
/// of different (seed, index) pairs do not overlap in practice.
fn stream(seed: u64, index: u64) -> SplitMix64 {
    let a = SplitMix64::new(seed).next_u64();
    let b = SplitMix64::new(index ^ 0xD1B5_4A32_D192_ED03).next_u64();
    SplitMix64::new(a ^ b.rotate_left(23))
}

#[cfg(test)]
mod tests {
    use super::*;
    use garmatnet_core::Skeleton;

    fn bits(poses: &[Pose]) -> Vec<u64> {
        poses
            .iter()
            .flat_map(Pose::to_vec)
            .map(f64::to_bits)
            .collect()
    }

    fn sampler(seed: u64) -> PoseSampler {
        PoseSampler::new(PoseSamplerConfig {
            seed,
            ..Default::default()
        })
        .unwrap()
    }

    #[test]
    fn poses_are_seeded_extend_and_do_not_depend_on_the_thread_count() {
        let s = sampler(42);
        let five = s.poses(5).unwrap();
        let eight = s.poses(8).unwrap();
        assert_eq!(bits(&five), bits(&eight[..5]));
        assert_eq!(bits(&[s.pose(6).unwrap()]), bits(&eight[6..7]));
        let in_pool = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| sampler(42).poses(8).unwrap())
        };
        assert_eq!(bits(&in_pool(1)), bits(&eight));
        assert_eq!(bits(&in_pool(3)), bits(&eight));
        let other = sampler(43).poses(8).unwrap();
        assert!(
            other
                .iter()
                .zip(&eight)
                .all(|(a, b)| a.max_joint_angle_to(b) > 0.05)
        );
        // Poses are independent: neighbours are as far apart as any two.
        assert!(
            eight
                .windows(2)
                .all(|w| w[0].max_joint_angle_to(&w[1]) > 0.2)
        );
    }

    #[test]
    fn bad_settings_are_typed_errors() {
        let bad = [
            PoseSamplerConfig {
                hanging_fraction: 1.5,
                ..Default::default()
            },
            PoseSamplerConfig {
                hanging_fraction: 0.7,
                raised_fraction: 0.6,
                ..Default::default()
            },
            PoseSamplerConfig {
                raised_fraction: Real::NAN,
                ..Default::default()
            },
            PoseSamplerConfig {
                max_attempts: 0,
                ..Default::default()
            },
            PoseSamplerConfig {
                paired_fraction: 1.2,
                ..Default::default()
            },
            PoseSamplerConfig {
                side_fraction: -0.1,
                ..Default::default()
            },
            PoseSamplerConfig {
                arm_gap_m: 0.5,
                ..Default::default()
            },
            PoseSamplerConfig {
                limits: JointLimits {
                    min: vec![[0.0; 3]; 3],
                    max: vec![[0.0; 3]; 3],
                },
                ..Default::default()
            },
        ];
        for config in bad {
            assert!(
                matches!(PoseSampler::new(config.clone()), Err(Error::Core(_))),
                "{config:?}"
            );
        }
        // Limits no pose can meet (the left shoulder pinned at the T-pose, so no arm ever
        // hangs, and the hanging band asked for always): the sampler gives up, typed.
        let mut limits = JointLimits::everyday();
        limits.min[16] = [0.0; 3];
        limits.max[16] = [0.0; 3];
        let pinned = PoseSampler::new(PoseSamplerConfig {
            limits,
            hanging_fraction: 1.0,
            raised_fraction: 0.0,
            max_attempts: 3,
            ..Default::default()
        })
        .unwrap();
        assert!(matches!(
            pinned.pose(0),
            Err(Error::PoseSamplingExhausted {
                index: 0,
                attempts: 3
            })
        ));
    }

    #[test]
    fn the_default_sampler_draws_the_revision_3_datasets_poses() {
        // Pose 0 of seed 0 as `simulate --poses 200 --seed 0` drew it for the revision-3
        // dataset (read from its manifest): a change to the sampler that moves the defaults'
        // poses would orphan those datasets (they would no longer resume, and `--reuse`
        // would find none of their samples). Exact equality on purpose: a platform whose
        // maths library rounds differently fails here, as it would fail to resume them.
        let pose = sampler(0).pose(0).unwrap();
        assert_eq!(
            pose.joint(0),
            Vec3::new(0.06975661072888842, -0.11642365319913868, 0.0)
        );
        assert_eq!(
            pose.joint(16),
            Vec3::new(
                0.019691786419549513,
                0.14309660708298946,
                0.9015199145394341
            )
        );
        // The right arm too: its shoulder, elbow and wrist come last in the random stream.
        assert_eq!(
            pose.joint(17),
            Vec3::new(
                -0.13407493562390238,
                0.15021057076816277,
                1.1341450571890572
            )
        );
        assert_eq!(
            pose.joint(19),
            Vec3::new(-0.02564065154906059, 0.17944440755024102, 0.0)
        );
        assert_eq!(
            pose.joint(21),
            Vec3::new(
                -0.21226400803476142,
                -0.13308342296560968,
                0.25647807131917216
            )
        );
    }

    #[test]
    fn the_revision_4_datasets_poses_stay_as_drawn() {
        // Both shoulders of a pose of `data-r4m`, `data-r4p` and `data-r4s`, read from their
        // manifests: a change to the bands, the pairing or the side share that moved them
        // would orphan those datasets as a change to the defaults would orphan revision 3's.
        let draw = |seed, bands: Real, paired_fraction, side_fraction, index| {
            let pose = PoseSampler::new(PoseSamplerConfig {
                seed,
                hanging_fraction: bands,
                raised_fraction: bands,
                paired_fraction,
                side_fraction,
                ..Default::default()
            })
            .unwrap()
            .pose(index)
            .unwrap();
            [pose.joint(16), pose.joint(17)]
        };
        assert_eq!(
            draw(2, 0.1, 0.0, 0.0, 0),
            [
                Vec3::new(
                    -0.6628600209373324,
                    -0.8868327661040407,
                    -0.8228088574620732
                ),
                Vec3::new(0.39019129705791217, 0.3323439630234299, -0.5302286454876103)
            ]
        );
        assert_eq!(
            draw(3, 0.2, 0.7, 0.0, 0),
            [
                Vec3::new(0.024869348467782756, -0.4164149591925291, 1.195048903560445),
                Vec3::new(
                    -0.3470157897315621,
                    0.44268953596864263,
                    -1.2749081514888307
                )
            ]
        );
        assert_eq!(
            draw(4, 0.2, 0.7, 0.5, 5),
            [
                Vec3::new(0.5533170295306986, 0.35006747861579957, 0.11475913308113514),
                Vec3::new(
                    0.30603133409397304,
                    0.06322024000373792,
                    -0.12827431473673814
                )
            ]
        );
    }

    /// Each arm's (elevation, azimuth) in degrees, measured on the posed skeleton in the
    /// chest's frame; the right arm's mirrored, so alike arms give alike numbers.
    fn arm_directions(skeleton: &Skeleton, pose: &Pose) -> [(Real, Real); 2] {
        let world = skeleton.world_transforms(pose);
        let joints = skeleton.posed_joints(pose);
        [(16, 18), (17, 19)].map(|(shoulder, elbow)| {
            let arm = world[9].rotation.inverse() * (joints[elbow] - joints[shoulder]).normalize();
            (
                arm.y.asin().to_degrees(),
                arm.z.atan2(arm.x.abs()).to_degrees(),
            )
        })
    }

    #[test]
    fn paired_arms_point_alike_and_cover_both_arms_near_the_horizontal() {
        let skeleton = Skeleton::smpl_neutral();
        let near_horizontal = |poses: &[Pose]| {
            poses
                .iter()
                .filter(|p| {
                    arm_directions(&skeleton, p)
                        .iter()
                        .all(|(elevation, _)| elevation.abs() < 20.0)
                })
                .count()
        };
        let draw = |paired_fraction: Real| {
            PoseSampler::new(PoseSamplerConfig {
                seed: 11,
                hanging_fraction: 0.2,
                raised_fraction: 0.2,
                paired_fraction,
                ..Default::default()
            })
            .unwrap()
            .poses(300)
            .unwrap()
        };
        let (paired, independent) = (draw(1.0), draw(0.0));
        for (i, pose) in paired.iter().enumerate() {
            let [(el, az), (er, ar)] = arm_directions(&skeleton, pose);
            // The spreads exactly (the rest skeleton is its own mirror image), up to rounding.
            assert!(
                (el - er).abs() <= PAIRED_ELEVATION_SPREAD_DEG + 1e-6,
                "pose {i}: elevations {el:.1} and {er:.1}"
            );
            assert!(
                (az - ar).abs() <= PAIRED_AZIMUTH_SPREAD_DEG + 1e-6,
                "pose {i}: azimuths {az:.1} and {ar:.1}"
            );
        }
        // Independent arms rarely both lie near the horizontal; paired ones often do.
        let (with, without) = (near_horizontal(&paired), near_horizontal(&independent));
        assert!(with > 2 * without, "{with} paired, {without} independent");
    }

    #[test]
    fn side_arms_lie_out_to_the_side_near_the_horizontal() {
        let skeleton = Skeleton::smpl_neutral();
        let draw = |side_fraction: Real, paired_fraction: Real| {
            PoseSampler::new(PoseSamplerConfig {
                seed: 5,
                hanging_fraction: 0.2,
                raised_fraction: 0.2,
                paired_fraction,
                side_fraction,
                ..Default::default()
            })
            .unwrap()
            .poses(200)
            .unwrap()
        };
        let within = |[lo, hi]: [Real; 2], value: Real| lo - 1e-6 <= value && value <= hi + 1e-6;
        let out_to_the_side = |pose: &Pose| {
            arm_directions(&skeleton, pose)
                .iter()
                .all(|&(elevation, azimuth)| {
                    within(SIDE_ELEVATION_DEG, elevation) && within(SIDE_AZIMUTH_DEG, azimuth)
                })
        };
        // Every arm of every pose exactly in the zone, measured on the posed skeleton.
        for (i, pose) in draw(1.0, 0.7).iter().enumerate() {
            assert!(
                out_to_the_side(pose),
                "pose {i}: {:?}",
                arm_directions(&skeleton, pose)
            );
        }
        // A share of them: about that share of poses (±4σ), and the rest as drawn without.
        let poses = draw(0.3, 0.7);
        let share = poses.iter().filter(|p| out_to_the_side(p)).count();
        assert!((35..=95).contains(&share), "{share} of 200");
        let without = draw(0.0, 0.7);
        assert!(without.iter().filter(|p| out_to_the_side(p)).count() < 20);
        assert_ne!(poses, without);
    }

    #[test]
    fn config_reads_from_partial_json() {
        let config: PoseSamplerConfig = serde_json::from_str(r#"{"seed": 5}"#).unwrap();
        assert_eq!(
            config,
            PoseSamplerConfig {
                seed: 5,
                ..Default::default()
            }
        );
        let text = serde_json::to_string(&config).unwrap();
        assert_eq!(
            serde_json::from_str::<PoseSamplerConfig>(&text).unwrap(),
            config
        );
    }

    /// Coverage of 2,000 poses, measured on the posed skeleton (world frame, y up), not on
    /// the sampler's own parameters.
    #[test]
    fn two_thousand_poses_cover_everyday_stances_and_none_self_intersects() {
        let s = sampler(2024);
        let poses = s.poses(2000).unwrap();
        let skeleton = Skeleton::smpl_neutral();
        let check = SelfIntersection::new(&CapsuleBody::smpl_neutral(), DEFAULT_ARM_GAP).unwrap();
        let limits = JointLimits::everyday();
        let (mut low, mut high, mut bent, mut twisted, mut apart) = (0, 0, 0, 0, 0);
        let (mut forward, mut behind) = (0, 0);
        for (i, pose) in poses.iter().enumerate() {
            assert!(
                check.worst(pose).is_none(),
                "pose {i}: {:?}",
                check.worst(pose)
            );
            limits.validate(pose, 0.0).unwrap();
            let world = skeleton.world_transforms(pose);
            let joints = skeleton.posed_joints(pose);
            for (shoulder, elbow) in [(16, 18), (17, 19)] {
                let arm = (joints[elbow] - joints[shoulder]).normalize();
                let elevation = arm.y.asin().to_degrees();
                low += usize::from(elevation < -60.0);
                high += usize::from(elevation > 45.0);
                bent += usize::from(pose.joint(elbow).norm() > 45f64.to_radians());
                // In the chest's frame: forward of the shoulder line, or behind it.
                let local = world[9].rotation.inverse() * arm;
                forward += usize::from(local.z > 0.5);
                behind += usize::from(local.z < -0.2);
            }
            // The chest's turn about the vertical relative to the pelvis.
            let relative = world[0].rotation.inverse() * world[9].rotation;
            let facing = relative * Vec3::z();
            twisted += usize::from(facing.x.atan2(facing.z).abs() > 0.2);
            let feet = joints[7] - joints[8];
            apart += usize::from(feet.x.hypot(feet.z) > 0.4);
        }
        let arms = 2.0 * poses.len() as Real;
        let n = poses.len() as Real;
        let fractions = [
            ("upper arm below -60°", low as Real / arms, 0.2, 0.5),
            ("upper arm above 45°", high as Real / arms, 0.1, 0.3),
            ("elbow bent past 45°", bent as Real / arms, 0.4, 0.8),
            ("arm forward", forward as Real / arms, 0.1, 0.5),
            ("arm behind", behind as Real / arms, 0.02, 0.3),
            ("torso twisted past 0.2 rad", twisted as Real / n, 0.3, 0.8),
            ("ankles over 40 cm apart", apart as Real / n, 0.25, 0.8),
        ];
        for (what, got, lo, hi) in fractions {
            println!("{what}: {got:.3}");
            assert!(
                (lo..=hi).contains(&got),
                "{what}: {got:.3} not in {lo}..{hi}"
            );
        }
    }
}
