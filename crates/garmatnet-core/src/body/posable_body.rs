//! Bodies that can be posed: what a garment dressed in a pose other than the skeleton's rest
//! pose needs to fit itself around the body.

use crate::body::capsule_body::CapsuleBody;
use crate::body::pose::Pose;
use crate::body::sdf::{SignedDistance, SkinnedBody};

/// A [`SkinnedBody`] whose surface can be posed: the fitted T-shirt is dressed in
/// [`Pose::a_pose`], so it measures its clearance against the body in that pose.
pub trait PosableBody: SkinnedBody {
    /// The body's signed distance field (metres) in `pose`.
    fn posed_field(&self, pose: &Pose) -> Box<dyn SignedDistance + '_>;
}

impl PosableBody for CapsuleBody {
    fn posed_field(&self, pose: &Pose) -> Box<dyn SignedDistance + '_> {
        Box::new(self.pose(pose))
    }
}
