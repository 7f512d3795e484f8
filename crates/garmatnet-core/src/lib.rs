//! Foundations of garmatnet: the material space, triangle meshes and their files, Laplacian
//! smoothing and the displacement decomposition, SMPL's skeleton and poses, a procedural
//! capsule body and the procedural T-shirt template.
//!
//! Nothing here depends on Burn: the solver, the networks and the trainer all build on it.

mod anchor;
mod capsule;
mod capsule_body;
mod capsule_union;
mod decompose;
pub mod error;
pub mod garment;
mod garment_style;
mod gltf;
mod io;
mod joints;
mod laplacian;
mod material;
pub mod material_bounds;
mod material_presets;
mod math;
mod mesh;
pub mod npy_guard;
mod posable_body;
mod pose;
mod pose_file;
pub mod render;
mod rng;
mod sdf;
mod skeleton;
mod smpl_capsules;
mod spring;
mod surface_nets;
mod tshirt_pattern;

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
    TemplateInfo,
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
