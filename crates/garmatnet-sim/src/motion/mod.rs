//! Poses to drape: seeded motions, the independent pose sampler, the everyday suite, and
//! the checks that keep arms off the torso and the body out of itself.

pub(crate) mod arm_clearance;
pub(crate) mod arm_placement;
pub(crate) mod everyday_poses;
pub(crate) mod generator;
pub(crate) mod pose_sampler;
pub(crate) mod pose_spec;
pub(crate) mod self_intersection;
