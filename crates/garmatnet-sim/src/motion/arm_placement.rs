//! Arms placed in anatomical terms: where the upper arm points, its twist and the elbow's
//! bend, turned into SMPL's collar, shoulder and elbow rotations.

use serde::{Deserialize, Serialize};

use garmatnet_core::{Pose, Real, Skeleton, UnitQuat, Vec3};

/// A body side.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Side {
    /// The body's left (+x).
    Left,
    /// The body's right (−x).
    Right,
}

/// Where an arm is, in anatomical terms: the upper arm's direction in the chest's (spine3)
/// frame, its twist, and the elbow's bend. [`ArmPlacement::apply`] turns it into the
/// collar, shoulder and elbow rotations; a left and a right arm of the same placement are
/// exact mirror images.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ArmPlacement {
    /// The upper arm's angle above the horizontal (radians): 0 in the T-pose, −π/2 hanging
    /// straight down, π/2 straight up.
    pub elevation_rad: Real,
    /// The upper arm's direction about the vertical (radians): 0 out to the side, π/2
    /// straight forward, negative behind the shoulder line.
    pub azimuth_rad: Real,
    /// Twist of the upper arm about itself (radians) from the least rotation that carries the
    /// T-pose arm there; positive turns the elbow's bend from the front toward the top (for
    /// the left arm; mirrored for the right).
    pub twist_rad: Real,
    /// The elbow's bend (radians): 0 straight, up to 2.2.
    pub elbow_flex_rad: Real,
}

impl ArmPlacement {
    /// The arm of the T-pose.
    pub const T_POSE: ArmPlacement = ArmPlacement {
        elevation_rad: 0.0,
        azimuth_rad: 0.0,
        twist_rad: 0.0,
        elbow_flex_rad: 0.0,
    };

    /// The collar (shrug, lean), shoulder and elbow axis-angle vectors of the *left* arm.
    fn left_rotations(&self, skeleton: &Skeleton) -> [Vec3; 3] {
        let (e, a) = (self.elevation_rad, self.azimuth_rad);
        let target = Vec3::new(e.cos() * a.cos(), e.sin(), e.cos() * a.sin());
        // The collar (scapula) carries a part of the motion: up to 0.3 rad of shrug with
        // the arm overhead, 0.1 rad of drop with it hanging, and leans forward to reach.
        let shrug = if e > 0.0 { 0.3 * e } else { 0.07 * e } / std::f64::consts::FRAC_PI_2;
        let lean = -0.2 * a.sin().max(0.0) * e.cos();
        let collar = Vec3::new(0.0, lean, shrug);
        let joints = skeleton.rest_joints();
        let rest = (joints[18] - joints[16]).normalize();
        let swing = UnitQuat::rotation_between(&rest, &target).unwrap_or_else(UnitQuat::identity);
        let twist = UnitQuat::from_scaled_axis(target * self.twist_rad);
        let shoulder = UnitQuat::from_scaled_axis(collar).inverse() * twist * swing;
        [
            collar,
            shoulder.scaled_axis(),
            Vec3::new(0.0, -self.elbow_flex_rad, 0.0),
        ]
    }

    /// Sets `side`'s collar, shoulder and elbow in `pose` (SMPL's skeleton proportions, as
    /// in [`Skeleton::smpl_neutral`]). The right arm is the left one's
    /// mirror image ([`Pose::mirrored`]), component for component.
    pub fn apply(&self, pose: &mut Pose, side: Side) {
        self.apply_on(&Skeleton::smpl_neutral(), pose, side);
    }

    /// As [`ArmPlacement::apply`], on `skeleton`'s proportions.
    pub fn apply_on(&self, skeleton: &Skeleton, pose: &mut Pose, side: Side) {
        let rotations = self.left_rotations(skeleton);
        let (joints, mirror) = match side {
            Side::Left => ([13, 16, 18], false),
            Side::Right => ([14, 17, 19], true),
        };
        for (j, v) in joints.into_iter().zip(rotations) {
            // Zeros made +0.0 (`c + 0.0`), as `Pose::mirrored` makes them: symmetric poses
            // are their own mirror bit for bit.
            let v = v.map(|c| c + 0.0);
            let v = if mirror {
                Vec3::new(v.x, 0.0 - v.y, 0.0 - v.z)
            } else {
                v
            };
            pose.set_joint(j, v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_arm_placement_points_the_upper_arm_where_it_says() {
        let skeleton = Skeleton::smpl_neutral();
        for (e, a) in [
            (-80.0_f64, 10.0_f64),
            (0.0, 0.0),
            (30.0, 90.0),
            (70.0, -20.0),
        ] {
            let placement = ArmPlacement {
                elevation_rad: e.to_radians(),
                azimuth_rad: a.to_radians(),
                twist_rad: 0.3,
                elbow_flex_rad: 1.0,
            };
            let mut pose = Pose::zero();
            placement.apply(&mut pose, Side::Left);
            placement.apply(&mut pose, Side::Right);
            let joints = skeleton.posed_joints(&pose);
            let left = (joints[18] - joints[16]).normalize();
            let right = (joints[19] - joints[17]).normalize();
            let expected = Vec3::new(
                e.to_radians().cos() * a.to_radians().cos(),
                e.to_radians().sin(),
                e.to_radians().cos() * a.to_radians().sin(),
            );
            assert!((left - expected).norm() < 1e-9, "{e} {a}: {left:?}");
            // The right arm is the mirror image, up to the rest skeleton's own asymmetry
            // (about a degree).
            let mirrored = Vec3::new(-expected.x, expected.y, expected.z);
            assert!((right - mirrored).norm() < 0.03, "{e} {a}: {right:?}");
            assert_eq!(pose.mirrored(), pose);
        }
    }
}
