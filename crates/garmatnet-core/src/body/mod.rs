//! The posed body: SMPL's skeleton and poses, the procedural capsule body, its signed
//! distance and skinned surface, and the frames displacements are stored in.

pub(crate) mod anchor;
pub(crate) mod capsule;
pub(crate) mod capsule_body;
pub(crate) mod capsule_union;
pub(crate) mod joints;
pub(crate) mod mesh_push;
pub(crate) mod posable_body;
pub(crate) mod pose;
pub(crate) mod sdf;
pub(crate) mod skeleton;
pub(crate) mod smpl_capsules;
pub(crate) mod surface_nets;
