//! A fixed, named suite of everyday poses, for evaluation only (never for training).
//!
//! Ground truth and predictions are compared on how people stand: arms at the sides, hands on
//! the hips, arms folded, a walking stride, and so on. Each pose lies within
//! [`garmatnet_core::JointLimits::everyday`] and is free of self-intersection at the default arm gap
//! ([`crate::SelfIntersection`]: an arm presses at most 3 cm into the torso). The poses marked symmetric are
//! their own mirror image exactly ([`Pose::mirrored`]), so their drapes must be too.

use garmatnet_core::{Pose, Real, Vec3};

use crate::error::{Error, Result};
use crate::motion::arm_placement::{ArmPlacement, Side};

/// One pose of the everyday suite.
#[derive(Debug, Clone, PartialEq)]
pub struct EverydayPose {
    /// A short kebab-case name (`arms-at-sides`).
    pub name: &'static str,
    /// The pose.
    pub pose: Pose,
    /// Whether the pose is left-right symmetric: `pose.mirrored() == pose`, bit for bit.
    pub symmetric: bool,
}

/// An arm placement in degrees (elevation, azimuth, twist) and radians (elbow).
fn arm(elevation_deg: Real, azimuth_deg: Real, twist_deg: Real, elbow_rad: Real) -> ArmPlacement {
    ArmPlacement {
        elevation_rad: elevation_deg.to_radians(),
        azimuth_rad: azimuth_deg.to_radians(),
        twist_rad: twist_deg.to_radians(),
        elbow_flex_rad: elbow_rad,
    }
}

/// Both arms placed alike: the pose stays symmetric.
fn both(pose: &mut Pose, placement: ArmPlacement) {
    placement.apply(pose, Side::Left);
    placement.apply(pose, Side::Right);
}

/// Sets the three spine joints to an even share of a bend (x), twist (y) and side bend (z).
fn spine(pose: &mut Pose, bend: Real, twist: Real, side_bend: Real) {
    for j in [3, 6, 9] {
        pose.set_joint(j, Vec3::new(bend, twist, side_bend) / 3.0);
    }
}

/// Sets both legs: hip (x flex, z abduction, as for the left leg) and knee, mirrored to the
/// right so the legs stay symmetric.
fn legs(pose: &mut Pose, hip_flex: Real, hip_abduct: Real, knee: Real) {
    pose.set_joint(1, Vec3::new(hip_flex, 0.0, hip_abduct));
    pose.set_joint(2, Vec3::new(hip_flex, 0.0, -hip_abduct));
    pose.set_joint(4, Vec3::new(knee, 0.0, 0.0));
    pose.set_joint(5, Vec3::new(knee, 0.0, 0.0));
}

/// The arms of an everyday stand: hanging at the sides 84° below the horizontal, elbows a
/// little bent, the upper arms pressing into the ribs.
fn arms_down() -> ArmPlacement {
    arm(-84.0, -10.0, 0.0, 0.15)
}

/// An arm with the hand on the hip: the elbow out and back, the wrist at the pelvis's side
/// (about 23 cm out, 22 cm below the chest), fingers down.
fn hand_on_hip() -> ArmPlacement {
    arm(-60.0, -58.0, 44.0, 1.0)
}

/// The everyday suite: at least 12 named poses, the symmetric ones marked. The order and the
/// poses are fixed: results on the suite stay comparable between versions.
#[must_use]
pub fn everyday_poses() -> Vec<EverydayPose> {
    let mut suite = Vec::new();
    let mut add = |name: &'static str, symmetric: bool, build: &dyn Fn(&mut Pose)| {
        let mut pose = Pose::zero();
        build(&mut pose);
        suite.push(EverydayPose {
            name,
            pose,
            symmetric,
        });
    };
    add("t-pose", true, &|_| {});
    add("a-pose", true, &|p| both(p, arm(-45.0, 0.0, 0.0, 0.0)));
    add("arms-at-sides", true, &|p| both(p, arms_down()));
    add("hands-on-hips", true, &|p| both(p, hand_on_hip()));
    add("left-arm-raised", false, &|p| {
        arm(75.0, 15.0, 0.0, 0.2).apply(p, Side::Left);
        arms_down().apply(p, Side::Right);
    });
    add("both-arms-raised", true, &|p| {
        both(p, arm(72.0, 15.0, 0.0, 0.3))
    });
    add("reaching-forward", true, &|p| {
        both(p, arm(-5.0, 80.0, 0.0, 0.15))
    });
    add("arms-crossed", false, &|p| {
        // The forearms cross in front of the chest, the right one lower and further out.
        arm(-38.0, 77.0, 36.0, 1.89).apply(p, Side::Left);
        arm(-49.0, 66.0, 42.0, 1.6).apply(p, Side::Right);
    });
    add("walking-stride", false, &|p| {
        p.set_joint(1, Vec3::new(-0.45, 0.0, 0.03));
        p.set_joint(2, Vec3::new(0.3, 0.0, -0.03));
        p.set_joint(4, Vec3::new(0.15, 0.0, 0.0));
        p.set_joint(5, Vec3::new(0.5, 0.0, 0.0));
        p.set_joint(7, Vec3::new(0.1, 0.0, 0.0));
        p.set_joint(8, Vec3::new(-0.3, 0.0, 0.0));
        arm(-72.0, -25.0, 0.0, 0.3).apply(p, Side::Left);
        arm(-68.0, 35.0, 0.0, 0.5).apply(p, Side::Right);
        spine(p, 0.05, -0.1, 0.0);
    });
    add("torso-bent-forward", true, &|p| {
        spine(p, 0.75, 0.0, 0.0);
        p.set_joint(0, Vec3::new(0.2, 0.0, 0.0));
        both(p, arm(-64.0, 15.0, 0.0, 0.3));
    });
    add("torso-twisted", false, &|p| {
        spine(p, 0.05, 0.6, 0.0);
        arm(-70.0, 20.0, 0.0, 0.4).apply(p, Side::Left);
        arm(-70.0, 20.0, 0.0, 0.4).apply(p, Side::Right);
    });
    add("sitting", true, &|p| {
        legs(p, -1.45, 0.12, 1.5);
        p.set_joint(7, Vec3::new(-0.1, 0.0, 0.0));
        p.set_joint(8, Vec3::new(-0.1, 0.0, 0.0));
        spine(p, 0.15, 0.0, 0.0);
        both(p, arm(-62.0, 30.0, 0.0, 0.8));
    });
    add("weight-shift", false, &|p| {
        p.set_joint(0, Vec3::new(0.0, 0.0, 0.12));
        p.set_joint(1, Vec3::new(0.0, 0.0, -0.12));
        p.set_joint(2, Vec3::new(-0.15, 0.0, -0.12));
        p.set_joint(5, Vec3::new(0.35, 0.0, 0.0));
        spine(p, 0.0, 0.0, -0.18);
        arm(-70.0, 0.0, 0.0, 0.2).apply(p, Side::Left);
        hand_on_hip().apply(p, Side::Right);
    });
    add("leaning-back", true, &|p| {
        spine(p, -0.4, 0.0, 0.0);
        legs(p, 0.0, 0.08, 0.1);
        both(p, arm(-68.0, -15.0, 0.0, 0.2));
    });
    add("phone-in-hand", false, &|p| {
        p.set_joint(12, Vec3::new(0.25, 0.0, 0.0));
        p.set_joint(15, Vec3::new(0.15, 0.0, 0.0));
        arms_down().apply(p, Side::Left);
        arm(-55.0, 45.0, 0.0, 1.9).apply(p, Side::Right);
    });
    suite
}

/// The file in a dataset directory made of the everyday suite (`simulate --poses everyday`)
/// that names its poses, in order (a JSON list of strings).
pub const POSE_NAMES_FILE: &str = "pose_names.json";

/// The names of [`everyday_poses`], in order.
#[must_use]
pub fn everyday_pose_names() -> Vec<&'static str> {
    everyday_poses().into_iter().map(|p| p.name).collect()
}

/// The everyday pose called `name`.
///
/// # Errors
/// [`Error::UnknownEverydayPose`] for an unknown name, listing the known ones.
pub fn everyday_pose(name: &str) -> Result<Pose> {
    everyday_poses()
        .into_iter()
        .find(|p| p.name.eq_ignore_ascii_case(name.trim()))
        .map(|p| p.pose)
        .ok_or_else(|| Error::UnknownEverydayPose {
            name: name.to_owned(),
            known: everyday_pose_names(),
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::self_intersection::{DEFAULT_ARM_GAP, SelfIntersection};
    use garmatnet_core::{CapsuleBody, JointLimits};

    #[test]
    fn the_suite_names_at_least_twelve_distinct_everyday_poses() {
        let suite = everyday_poses();
        assert!(suite.len() >= 12);
        let mut names = everyday_pose_names();
        for needed in [
            "t-pose",
            "a-pose",
            "arms-at-sides",
            "hands-on-hips",
            "left-arm-raised",
            "reaching-forward",
            "walking-stride",
            "torso-bent-forward",
            "torso-twisted",
        ] {
            assert!(names.contains(&needed), "{needed}");
        }
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), suite.len(), "names are unique");
        for (i, a) in suite.iter().enumerate() {
            for b in &suite[i + 1..] {
                assert!(
                    a.pose.max_joint_angle_to(&b.pose) > 0.1,
                    "{} ~ {}",
                    a.name,
                    b.name
                );
            }
        }
        assert_eq!(everyday_pose("Hands-On-Hips").unwrap(), suite[3].pose);
        let err = everyday_pose("cartwheel").unwrap_err();
        assert!(
            matches!(&err, Error::UnknownEverydayPose { name, known }
                if name == "cartwheel" && known.contains(&"arms-at-sides")),
            "{err}"
        );
        assert!(err.to_string().contains("arms-at-sides"), "{err}");
    }

    #[test]
    fn symmetric_poses_are_their_own_mirror_and_the_others_are_not() {
        for p in everyday_poses() {
            let mirrored = p.pose.mirrored();
            if p.symmetric {
                let bits = |q: &Pose| q.to_vec().into_iter().map(f64::to_bits).collect::<Vec<_>>();
                assert_eq!(bits(&mirrored), bits(&p.pose), "{}", p.name);
            } else {
                assert!(mirrored.max_joint_angle_to(&p.pose) > 0.05, "{}", p.name);
            }
        }
    }

    #[test]
    fn every_pose_is_within_the_everyday_limits_and_clear_of_itself() {
        let check = SelfIntersection::new(&CapsuleBody::smpl_neutral(), DEFAULT_ARM_GAP).unwrap();
        let limits = JointLimits::everyday();
        for p in everyday_poses() {
            limits
                .validate(&p.pose, 0.0)
                .unwrap_or_else(|e| panic!("{}: {e}", p.name));
            p.pose.validate().unwrap();
            assert!(
                check.worst(&p.pose).is_none(),
                "{}: {:?}",
                p.name,
                check.worst(&p.pose)
            );
        }
        // The arms really hang: 84° below the horizontal, measured on the posed skeleton.
        let sides = everyday_pose("arms-at-sides").unwrap();
        let joints = garmatnet_core::Skeleton::smpl_neutral().posed_joints(&sides);
        for (shoulder, elbow) in [(16, 18), (17, 19)] {
            let arm = (joints[elbow] - joints[shoulder]).normalize();
            assert!(arm.y.asin().to_degrees() < -83.0, "{arm:?}");
        }
    }
}
