//! garmatnet: predict how a garment drapes on a posed body, for a given fabric, in
//! milliseconds (GarMatNet, Luo, Li & Kanai, MIG '21).
//!
//! This facade re-exports the typed API of the `garmatnet-*` crates: the most used items at
//! the top level, each crate whole under its own name.

pub use garmatnet_core as core;
pub use garmatnet_sim as sim;

pub use garmatnet_core::{
    BodyAnchor, CapsuleBody, DisplacementFrame, Error, Garment, JointLimits, Material, Pose,
    PosedBody, Resolution, SignedDistance, Skeleton, TriMesh,
};
