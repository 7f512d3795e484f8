//! Foundations of garmatnet: the material space, triangle meshes and their files, Laplacian
//! smoothing and the displacement decomposition, SMPL's skeleton and poses, a procedural
//! capsule body and the procedural T-shirt template.
//!
//! Nothing here depends on Burn: the solver, the networks and the trainer all build on it.

mod body;
mod decompose;
pub mod error;
mod garment;
mod io;
mod material;
mod math;
mod mesh;
mod rng;

pub use body::anchor::{BodyAnchor, DisplacementFrame};
pub use body::capsule::Capsule;
pub use body::capsule_body::{
    CapsuleBody, DEFAULT_BLEND_RADIUS, POSED_MESH_TOLERANCE, PosedBody, REST_MESH_SPACING,
    SKIN_BLEND_RADIUS,
};
pub use body::capsule_union::{
    DEFAULT_LIMB_ROOTS, LimbRoot, MAX_LIMB_ROOTS, PINCH_HALF_WIDTH, PINCH_SMOOTHING,
    SHOULDER_BLEND_REACH,
};
pub use body::mesh_push::{
    FACE_DIVISIONS, MESH_PUSH_ROUNDS, MeshPush, deepest_point_inside, push_mesh_outside,
    triangle_samples,
};
pub use body::posable_body::PosableBody;
pub use body::pose::{
    A_POSE_SHOULDER_ANGLE, JointLimits, MAX_POSE_COMPONENT, POSE_DIM, Pose, SMPLH_POSE_DIM,
};
pub use body::sdf::{PUSH_SLACK, SignedDistance, SkinnedBody, Sphere, unit_normal};
pub use body::skeleton::{
    JOINT_COUNT, JOINT_NAMES, MIRRORED_JOINTS, PARENTS, Skeleton, blend_point, joint_index,
    mirror_joint,
};
pub use body::smpl_capsules::smpl_neutral_capsules;
pub use body::surface_nets::surface_nets;
pub use decompose::decomposition::{
    Decomposition, decompose, field_from_frame, field_to_frame, recompose,
};
pub use decompose::laplacian::{
    CORNER_ANGLE_DEGREES, LaplacianSmoother, LaplacianWeights, SmoothingSettings, VertexRole,
};
pub use error::{Error, Result};
pub use garment::openings::{BoundaryLoop, Opening};
pub use garment::pattern::Panel;
pub use garment::resolution::Resolution;
pub use garment::spring::{Spring, SpringKind};
pub use garment::style::GarmentStyle;
pub use garment::template::{
    FITTED_MIN_REST_FRACTION, Garment, MAX_FIT_PUSH, MIN_BODY_CLEARANCE, TemplateInfo,
};
pub use io::drape_output::{
    DrapeSequence, DrapeView, OutputFormat, SIMULATED_COLOR, compare_path, comparison_image,
    numbered_path, slug, vertex_errors_mm,
};
pub use io::files::{OutputLock, read_obj, write_atomic, write_bytes_atomic, write_obj, write_ply};
pub use io::gltf::{GlbAnimatedMesh, GlbMesh, GlbSkinnedMesh, write_glb, write_glb_animation};
pub use io::pose_file::{read_pose_frame_rate, read_poses, write_poses_json};
pub use io::{npy_guard, render};
pub use material::bounds::{COMPONENT_NAMES, COMPONENT_UNITS, MATERIAL_DIM, MaterialBounds};
pub use material::presets::{
    MaterialUnits, PAPER_TEST_MATERIALS, Preset, find_preset, parse_omega, preset_names, presets,
    resolve_material,
};
pub use material::space::Material;
pub use math::{Iso3, Mat3, Real, Rot3, UnitQuat, Vec3};
pub use mesh::{Aabb, Adjacency, TriMesh};
pub use rng::SplitMix64;
