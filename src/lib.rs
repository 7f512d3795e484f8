//! garmatnet: predict how a garment drapes on a posed body, for a given fabric, in
//! milliseconds (GarMatNet, Luo, Li & Kanai, MIG '21).
//!
//! This facade re-exports the typed API of the `garmatnet-*` crates: the most used items at
//! the top level, each crate whole under its own name.
//!
//! ```no_run
//! use garmatnet::{CapsuleBody, Detail, Garment, GarMatNetModel, Material, Pose, Predictor, Resolution};
//!
//! # fn main() -> anyhow::Result<()> {
//! let device = garmatnet::select_device("cpu")?; // or "gpu" with --features wgpu
//! let body = CapsuleBody::smpl_neutral();
//! let shirt = Garment::tshirt(Resolution::Default, &body)?;
//! let model = GarMatNetModel::load("model.safetensors", &device)?; // refuses other templates
//! let predictor = Predictor::for_garment(model, &shirt, body, &device)?;
//! let pose = Pose::from_slice(&[0.0; 72])?; // SMPL axis-angle, root first
//! let mesh = predictor.predict(&pose, &Material::preset("denim heavy")?, Detail::Full)?;
//! garmatnet::core::write_obj("shirt.obj", &mesh.into_tri_mesh()?)?;
//! # Ok(())
//! # }
//! ```

pub use garmatnet_core as core;
pub use garmatnet_model as model;
pub use garmatnet_sim as sim;
pub use garmatnet_train as train;

pub use garmatnet_core::{
    BodyAnchor, CapsuleBody, DisplacementFrame, Garment, JointLimits, Material, Pose, PosedBody,
    Resolution, SignedDistance, Skeleton, TriMesh,
};
pub use garmatnet_model::{
    Detail, GarMatNetConfig, GarMatNetModel, GarmentMesh, Predictor, PushOut, Scene, select_device,
};
pub use garmatnet_sim::{
    DrapeSettings, DrapeSolver, FrameStepper, GenerateConfig, generate_dataset,
};
pub use garmatnet_train::{EvalConfig, TrainConfig, evaluate, train};
