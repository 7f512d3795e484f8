//! SMPL's 24-joint kinematic tree: names, order, parents, rest joints and forward kinematics.
//!
//! Coordinates follow SMPL: metres, y up, the body faces +z, its left side is +x. The rest
//! joints are those of SMPL's mean neutral body (the `J_regressor` applied to the neutral
//! template, rounded to the millimetre), so SMPL/AMASS poses drive our skeleton as they
//! drive SMPL. No SMPL file is shipped or read.

use crate::body::pose::Pose;
use crate::math::{Iso3, Real, Vec3};

pub use crate::body::joints::{
    JOINT_COUNT, JOINT_NAMES, MIRRORED_JOINTS, PARENTS, joint_index, mirror_joint,
};

/// SMPL's mean neutral rest joints (metres), T-pose.
const SMPL_NEUTRAL_JOINTS: [[Real; 3]; JOINT_COUNT] = [
    [-0.002, -0.223, 0.028],
    [0.068, -0.315, 0.015],
    [-0.069, -0.314, 0.022],
    [-0.004, -0.114, 0.004],
    [0.103, -0.705, 0.012],
    [-0.105, -0.704, 0.009],
    [0.005, 0.024, 0.026],
    [0.087, -1.129, -0.030],
    [-0.088, -1.125, -0.031],
    [0.003, 0.077, 0.031],
    [0.118, -1.185, 0.094],
    [-0.116, -1.184, 0.099],
    [-0.007, 0.289, -0.013],
    [0.079, 0.194, -0.004],
    [-0.078, 0.193, -0.007],
    [0.012, 0.352, 0.039],
    [0.173, 0.227, -0.017],
    [-0.177, 0.226, -0.023],
    [0.433, 0.214, -0.036],
    [-0.432, 0.213, -0.042],
    [0.690, 0.218, -0.040],
    [-0.692, 0.219, -0.044],
    [0.777, 0.210, -0.054],
    [-0.779, 0.211, -0.057],
];

/// A kinematic tree with SMPL's topology and given rest joint positions.
#[derive(Debug, Clone, PartialEq)]
pub struct Skeleton {
    rest_joints: [Vec3; JOINT_COUNT],
}

impl Default for Skeleton {
    fn default() -> Self {
        Self::smpl_neutral()
    }
}

impl Skeleton {
    /// SMPL's mean neutral body's skeleton (metres, y up, facing +z), made exactly
    /// left-right mirror-symmetric about `x = 0`: each joint is the mean of its own position
    /// and its twin's mirrored ([`mirror_joint`]; centre joints get `x = 0`). SMPL's table
    /// is asymmetric by millimetres (the head sits 12 mm left of the centre, the neck 7 mm
    /// right, the shoulders' x differ by 4 mm, the elbows' z by 6 mm); the T-shirt hangs on the raised arms in a lateral mode so
    /// soft that this slid every drape at the T-pose 29–40 mm toward the body's left.
    #[must_use]
    pub fn smpl_neutral() -> Self {
        let table = SMPL_NEUTRAL_JOINTS.map(|[x, y, z]| Vec3::new(x, y, z));
        Self {
            rest_joints: std::array::from_fn(|j| {
                let (own, twin) = (table[j], table[mirror_joint(j)]);
                Vec3::new(
                    0.5 * (own.x - twin.x),
                    0.5 * (own.y + twin.y),
                    0.5 * (own.z + twin.z),
                )
            }),
        }
    }

    /// SMPL's mean neutral joints as measured, before [`Skeleton::smpl_neutral`] makes them
    /// mirror-symmetric. The boxy T-shirt ([`crate::GarmentStyle::Boxy`]) is cut from them,
    /// so its template is the one of earlier versions, and the models shipped up to version
    /// 0.3 (revision 2's the last) that were trained on it still load.
    #[must_use]
    pub fn smpl_neutral_measured() -> Self {
        Self {
            rest_joints: SMPL_NEUTRAL_JOINTS.map(|[x, y, z]| Vec3::new(x, y, z)),
        }
    }

    /// A skeleton with custom rest joints (world positions in the rest pose, metres).
    #[must_use]
    pub fn with_rest_joints(rest_joints: [Vec3; JOINT_COUNT]) -> Self {
        Self { rest_joints }
    }

    /// The rest (T-pose) joint positions.
    #[must_use]
    pub fn rest_joints(&self) -> &[Vec3; JOINT_COUNT] {
        &self.rest_joints
    }

    /// Forward kinematics: each joint's world transform (rotation = accumulated joint
    /// rotations, translation = the posed joint position).
    ///
    /// The zero pose returns identity rotations at the rest joints.
    #[must_use]
    pub fn world_transforms(&self, pose: &Pose) -> [Iso3; JOINT_COUNT] {
        let mut world = [Iso3::identity(); JOINT_COUNT];
        for j in 0..JOINT_COUNT {
            let local_rotation = pose.joint_rotation(j);
            let (parent_world, offset) = match PARENTS[j] {
                Some(p) => (world[p], self.rest_joints[j] - self.rest_joints[p]),
                None => (Iso3::identity(), self.rest_joints[j]),
            };
            let local = Iso3::from_parts(offset.into(), local_rotation);
            world[j] = parent_world * local;
        }
        world
    }

    /// Posed joint positions (world, metres).
    #[must_use]
    pub fn posed_joints(&self, pose: &Pose) -> [Vec3; JOINT_COUNT] {
        self.world_transforms(pose).map(|t| t.translation.vector)
    }

    /// Skinning transforms: `A_j = G_j · translate(-J_j)`, mapping a rest-pose point rigidly
    /// attached to joint `j` to its posed position. Linear blend skinning sums these with
    /// per-point weights; the zero pose gives identities.
    #[must_use]
    pub fn skinning_transforms(&self, pose: &Pose) -> [Iso3; JOINT_COUNT] {
        let world = self.world_transforms(pose);
        std::array::from_fn(|j| {
            world[j]
                * Iso3::translation(
                    -self.rest_joints[j].x,
                    -self.rest_joints[j].y,
                    -self.rest_joints[j].z,
                )
        })
    }
}

/// Linear blend skinning of one rest point with sparse weights `(joint, weight)`.
///
/// Weights are expected to sum to one; they are not renormalised here.
#[must_use]
pub fn blend_point(
    transforms: &[Iso3; JOINT_COUNT],
    weights: &[(usize, Real)],
    rest: &Vec3,
) -> Vec3 {
    let p = nalgebra::Point3::from(*rest);
    weights.iter().fold(Vec3::zeros(), |acc, &(j, w)| {
        acc + (transforms[j] * p).coords * w
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn mirrored_joints_swap_left_and_right_names_and_parents() {
        for (j, name) in JOINT_NAMES.iter().enumerate() {
            let twin = MIRRORED_JOINTS[j];
            assert_eq!(MIRRORED_JOINTS[twin], j, "not an involution at {name}");
            let expected = if name.starts_with("left_") {
                name.replacen("left_", "right_", 1)
            } else if name.starts_with("right_") {
                name.replacen("right_", "left_", 1)
            } else {
                (*name).to_owned()
            };
            assert_eq!(JOINT_NAMES[twin], expected);
            // The twin's parent is the parent's twin: the map respects the tree.
            assert_eq!(PARENTS[twin], PARENTS[j].map(|p| MIRRORED_JOINTS[p]));
        }
    }

    #[test]
    fn parents_precede_children() {
        for (j, p) in PARENTS.iter().enumerate() {
            if let Some(p) = p {
                assert!(*p < j, "joint {j}'s parent {p} comes after it");
            }
        }
    }

    #[test]
    fn the_neutral_skeleton_is_its_own_mirror_image() {
        let s = Skeleton::smpl_neutral();
        let j = s.rest_joints();
        for k in 0..JOINT_COUNT {
            let twin = mirror_joint(k);
            assert_eq!(mirror_joint(twin), k);
            assert_eq!(
                JOINT_NAMES[twin],
                JOINT_NAMES[k]
                    .replace("left_", "@")
                    .replace("right_", "left_")
                    .replace('@', "right_")
            );
            assert_eq!(
                j[k],
                Vec3::new(-j[twin].x, j[twin].y, j[twin].z),
                "{}",
                JOINT_NAMES[k]
            );
            // Within SMPL's millimetres of the table.
            let [x, y, z] = SMPL_NEUTRAL_JOINTS[k];
            assert!(
                (j[k] - Vec3::new(x, y, z)).norm() < 13e-3,
                "{} moved {:?}",
                JOINT_NAMES[k],
                j[k]
            );
        }
    }

    #[test]
    fn zero_pose_returns_rest_joints() {
        let s = Skeleton::smpl_neutral();
        let posed = s.posed_joints(&Pose::zero());
        for (a, b) in posed.iter().zip(s.rest_joints()) {
            assert_relative_eq!(a, b, epsilon = 1e-12);
        }
        for t in s.skinning_transforms(&Pose::zero()) {
            assert_relative_eq!(
                t.to_homogeneous(),
                Iso3::identity().to_homogeneous(),
                epsilon = 1e-12
            );
        }
    }

    #[test]
    fn bending_the_left_elbow_moves_only_the_forearm_chain() {
        let s = Skeleton::smpl_neutral();
        let mut pose = Pose::zero();
        pose.set_joint(
            joint_index("left_elbow").unwrap(),
            Vec3::new(0.0, -1.2, 0.0),
        );
        let posed = s.posed_joints(&pose);
        let wrist = joint_index("left_wrist").unwrap();
        let elbow = joint_index("left_elbow").unwrap();
        assert_relative_eq!(posed[elbow], s.rest_joints()[elbow], epsilon = 1e-12);
        // Bone length is preserved, and a negative y rotation brings the forearm forward (+z).
        let rest_len = (s.rest_joints()[wrist] - s.rest_joints()[elbow]).norm();
        assert_relative_eq!(
            (posed[wrist] - posed[elbow]).norm(),
            rest_len,
            epsilon = 1e-12
        );
        assert!(posed[wrist].z > s.rest_joints()[wrist].z + 0.1);
        let right_wrist = joint_index("right_wrist").unwrap();
        assert_relative_eq!(
            posed[right_wrist],
            s.rest_joints()[right_wrist],
            epsilon = 1e-12
        );
    }

    #[test]
    fn skinning_a_joint_position_gives_the_posed_joint() {
        let s = Skeleton::smpl_neutral();
        let mut pose = Pose::zero();
        pose.set_joint(0, Vec3::new(0.1, 0.4, -0.2));
        pose.set_joint(16, Vec3::new(0.3, -0.2, -0.9));
        let a = s.skinning_transforms(&pose);
        let posed = s.posed_joints(&pose);
        for (j, expected) in posed.iter().enumerate() {
            let p = blend_point(&a, &[(j, 1.0)], &s.rest_joints()[j]);
            assert_relative_eq!(p, *expected, epsilon = 1e-12);
        }
    }
}
