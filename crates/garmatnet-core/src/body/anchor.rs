//! Body correspondence: where on the body each garment vertex is measured from.
//!
//! GarMatNet predicts displacements from the posed body (paper §3.2–3.4). Each garment vertex
//! has a [`BodyAnchor`]: a point on the rest body surface with linear-blend-skinning weights.
//! Posing the skeleton moves the anchor with the body, and a displacement can be expressed
//! either in the world frame or in the anchor's canonical frame (the rotation of its blended
//! skinning transform), which removes most of the pose's rigid rotation from the label.

use serde::{Deserialize, Serialize};

use crate::body::skeleton::{JOINT_COUNT, blend_point};
use crate::math::{Iso3, Real, UnitQuat, Vec3};

/// The frame in which garment displacements are expressed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DisplacementFrame {
    /// World axes (the paper's choice).
    #[default]
    World,
    /// The canonical (unposed) frame of each vertex's blended skinning rotation.
    Canonical,
}

/// A garment vertex's body correspondence: a rest-pose body surface point and its skinning
/// weights (at most four joints, weights summing to one).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BodyAnchor {
    /// The body surface point in the rest pose (metres).
    pub rest_point: Vec3,
    /// `(joint, weight)` pairs, weights positive and summing to one.
    pub weights: Vec<(usize, Real)>,
}

impl BodyAnchor {
    /// The anchor's posed position, by linear blend skinning with `transforms`
    /// ([`crate::Skeleton::skinning_transforms`]).
    #[must_use]
    pub fn posed_point(&self, transforms: &[Iso3; JOINT_COUNT]) -> Vec3 {
        blend_point(transforms, &self.weights, &self.rest_point)
    }

    /// The anchor's canonical-frame rotation: the normalised weighted blend of its joints'
    /// skinning rotations (hemisphere-aligned quaternion blending, always a proper rotation).
    #[must_use]
    pub fn frame(&self, transforms: &[Iso3; JOINT_COUNT]) -> UnitQuat {
        let first = transforms[self.weights[0].0].rotation.into_inner();
        let mut sum = nalgebra::Quaternion::new(0.0, 0.0, 0.0, 0.0);
        for &(j, w) in &self.weights {
            let q = transforms[j].rotation.into_inner();
            let sign = if q.dot(&first) < 0.0 { -1.0 } else { 1.0 };
            sum += q * (w * sign);
        }
        UnitQuat::try_new(sum, 1e-12).unwrap_or_else(|| UnitQuat::new_normalize(first))
    }

    /// Expresses a world-frame displacement `d` in `frame`.
    #[must_use]
    pub fn to_frame(
        &self,
        d: &Vec3,
        frame: DisplacementFrame,
        transforms: &[Iso3; JOINT_COUNT],
    ) -> Vec3 {
        match frame {
            DisplacementFrame::World => *d,
            DisplacementFrame::Canonical => self.frame(transforms).inverse_transform_vector(d),
        }
    }

    /// Turns a displacement expressed in `frame` back into the world frame.
    #[must_use]
    pub fn from_frame(
        &self,
        d: &Vec3,
        frame: DisplacementFrame,
        transforms: &[Iso3; JOINT_COUNT],
    ) -> Vec3 {
        match frame {
            DisplacementFrame::World => *d,
            DisplacementFrame::Canonical => self.frame(transforms).transform_vector(d),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Pose, Skeleton};
    use approx::assert_relative_eq;

    fn anchor() -> BodyAnchor {
        BodyAnchor {
            rest_point: Vec3::new(0.3, 0.22, 0.05),
            weights: vec![(16, 0.7), (13, 0.2), (18, 0.1)],
        }
    }

    #[test]
    fn rest_pose_anchor_is_its_rest_point_and_identity_frame() {
        let t = Skeleton::smpl_neutral().skinning_transforms(&Pose::zero());
        let a = anchor();
        assert_relative_eq!(a.posed_point(&t), a.rest_point, epsilon = 1e-12);
        assert_relative_eq!(a.frame(&t).angle(), 0.0, epsilon = 1e-12);
    }

    #[test]
    fn canonical_frame_round_trips() {
        let mut pose = Pose::zero();
        pose.set_joint(16, Vec3::new(0.2, -0.5, -1.0));
        pose.set_joint(13, Vec3::new(0.0, 0.1, 0.2));
        let t = Skeleton::smpl_neutral().skinning_transforms(&pose);
        let a = anchor();
        let d = Vec3::new(0.01, -0.02, 0.03);
        let c = a.to_frame(&d, DisplacementFrame::Canonical, &t);
        assert!(
            (c - d).norm() > 1e-3,
            "a posed shoulder must rotate the displacement"
        );
        assert_relative_eq!(
            a.from_frame(&c, DisplacementFrame::Canonical, &t),
            d,
            epsilon = 1e-12
        );
        assert_relative_eq!(c.norm(), d.norm(), epsilon = 1e-12);
    }
}
