//! Foundations of garmatnet: the material space, triangle meshes and their files, Laplacian
//! smoothing and the displacement decomposition, SMPL's skeleton and poses, a procedural
//! capsule body and the procedural T-shirt template.
//!
//! Nothing here depends on Burn: the solver, the networks and the trainer all build on it.

pub mod anchor;
pub mod error;
pub mod garment;
pub mod math;
pub mod mesh;
pub mod pose;
pub mod rng;
pub mod sdf;
pub mod skeleton;
pub mod spring;
pub mod tshirt_pattern;

pub use anchor::{BodyAnchor, DisplacementFrame};
pub use error::{Error, Result};
pub use garment::{BoundaryLoop, Garment, MIN_BODY_CLEARANCE, Opening, Resolution};
pub use math::{Iso3, Mat3, Real, Rot3, UnitQuat, Vec3};
pub use mesh::TriMesh;
pub use pose::{JointLimits, Pose, POSE_DIM, SMPLH_POSE_DIM};
pub use rng::SplitMix64;
pub use sdf::{SignedDistance, SkinnedBody, Sphere};
pub use skeleton::{blend_point, joint_index, Skeleton, JOINT_COUNT, JOINT_NAMES, PARENTS};
pub use spring::{Spring, SpringKind};
pub use tshirt_pattern::Panel;
