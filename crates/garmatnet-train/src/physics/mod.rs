//! Physics-informed training (issue 49): the solver's drape energy in tensors
//! ([`ClothTensors::energy`]) over the posed body's own distance field, linearised where
//! the garment is ([`BodyField`]), differentiable in the garment's positions; (pose, fabric) pairs
//! drawn continuously ([`PhysicsBatch`]); and the two nets' physics-informed loss
//! ([`TwoNetPhysicsLoss`]).

mod batch;
mod body_field;
mod energy;
mod hybrid;
mod physics_only;
mod two_net_loss;

pub use batch::{
    JointLimitsPoses, PhysicsBatch, PhysicsPoses, PoseSource, SampledPoses, uniform_fabric,
};
pub use body_field::BodyField;
pub use energy::{ClothTensors, EnergyTensors};
pub(crate) use hybrid::LocalPhysics;
pub use hybrid::PhysicsConfig;
pub use physics_only::{PhysicsOnlyConfig, PhysicsOnlySummary, train_physics_only};
pub use two_net_loss::{NormalizerTensors, TwoNetPhysicsLoss, rest_offset_normalizers};
