//! Foundations of garmatnet: the material space, triangle meshes and their files, Laplacian
//! smoothing and the displacement decomposition, SMPL's skeleton and poses, a procedural
//! capsule body and the procedural T-shirt template.
//!
//! Nothing here depends on Burn: the solver, the networks and the trainer all build on it.

pub mod anchor;
pub mod capsule;
pub mod capsule_body;
pub mod capsule_union;
pub mod decompose;
pub mod error;
pub mod garment;
pub mod garment_style;
pub mod gltf;
pub mod io;
mod joints;
pub mod laplacian;
pub mod material;
pub mod material_bounds;
pub mod material_presets;
pub mod math;
pub mod mesh;
pub mod npy_guard;
pub mod posable_body;
pub mod pose;
pub mod pose_file;
pub mod render;
pub mod rng;
pub mod sdf;
pub mod skeleton;
pub mod smpl_capsules;
pub mod spring;
pub mod surface_nets;
pub mod tshirt_pattern;

pub use anchor::{BodyAnchor, DisplacementFrame};
pub use capsule::Capsule;
pub use capsule_body::{
    CapsuleBody, DEFAULT_BLEND_RADIUS, PosedBody, REST_MESH_SPACING, SKIN_BLEND_RADIUS,
};
pub use capsule_union::{
    DEFAULT_LIMB_ROOTS, LimbRoot, MAX_LIMB_ROOTS, PINCH_HALF_WIDTH, PINCH_SMOOTHING,
    SHOULDER_BLEND_REACH,
};
pub use decompose::{Decomposition, decompose, field_from_frame, field_to_frame, recompose};
pub use error::{Error, Result};
pub use garment::{
    BoundaryLoop, FITTED_MIN_REST_FRACTION, Garment, MIN_BODY_CLEARANCE, Opening, Resolution,
};
pub use garment_style::GarmentStyle;
pub use gltf::{GlbAnimatedMesh, GlbMesh, GlbSkinnedMesh, write_glb, write_glb_animation};
pub use io::{OutputLock, read_obj, write_atomic, write_bytes_atomic, write_obj, write_ply};
pub use laplacian::{
    CORNER_ANGLE_DEGREES, LaplacianSmoother, LaplacianWeights, SmoothingSettings, VertexRole,
};
pub use material::Material;
pub use material_bounds::{COMPONENT_NAMES, COMPONENT_UNITS, MATERIAL_DIM, MaterialBounds};
pub use material_presets::{PAPER_TEST_MATERIALS, Preset, find_preset, preset_names, presets};
pub use math::{Iso3, Mat3, Real, Rot3, UnitQuat, Vec3};
pub use mesh::{Aabb, Adjacency, TriMesh};
pub use posable_body::PosableBody;
pub use pose::{
    A_POSE_SHOULDER_ANGLE, JointLimits, MAX_POSE_COMPONENT, POSE_DIM, Pose, SMPLH_POSE_DIM,
};
pub use pose_file::{read_pose_frame_rate, read_poses, write_poses_json};
pub use rng::SplitMix64;
pub use sdf::{PUSH_SLACK, SignedDistance, SkinnedBody, Sphere, unit_normal};
pub use skeleton::{
    JOINT_COUNT, JOINT_NAMES, MIRRORED_JOINTS, PARENTS, Skeleton, blend_point, joint_index,
    mirror_joint,
};
pub use smpl_capsules::smpl_neutral_capsules;
pub use spring::{Spring, SpringKind};
pub use surface_nets::surface_nets;
pub use tshirt_pattern::Panel;
