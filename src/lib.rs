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
//! let model = GarMatNetModel::load("model.safetensors", &device)?; // checks format, checksum, shapes
//! let predictor = Predictor::for_garment(model, &shirt, body, &device)?; // refuses other templates
//! let pose = Pose::from_slice(&[0.0; 72])?; // SMPL axis-angle, root first
//! let mesh = predictor.predict(&pose, &Material::preset("denim heavy")?, Detail::Full)?;
//! garmatnet::core::write_obj("shirt.obj", &mesh.into_tri_mesh()?)?;
//! # Ok(())
//! # }
//! ```
//!
//! A whole motion, written as one animated glTF (the garment frame by frame, the body skinned
//! to its skeleton):
//!
//! ```no_run
//! use garmatnet::core::{
//!     GlbAnimatedMesh, GlbSkinnedMesh, SkinnedBody, read_poses, write_glb_animation,
//! };
//! use garmatnet::{Detail, GarmentMesh, Material, Predictor, TriMesh};
//!
//! # fn main() -> anyhow::Result<()> {
//! let device = garmatnet::select_device("cpu")?;
//! let predictor = Predictor::default_tshirt(&device)?; // the shipped model
//! let motion = read_poses("walk.npz")?; // AMASS .npz, .npy or a JSON list of poses
//! let denim = Material::preset("denim heavy")?;
//! let shirts = predictor
//!     .predict_sequence(&motion, &denim, Detail::Full)? // batched, pushed out of the body
//!     .into_iter()
//!     .map(GarmentMesh::into_tri_mesh)
//!     .collect::<Result<Vec<TriMesh>, _>>()?;
//! let body = predictor.body().expect("default_tshirt knows its body");
//! write_glb_animation(
//!     "walk.glb",
//!     &[GlbAnimatedMesh { name: "shirt", frames: &shirts, color: [70, 110, 170] }],
//!     &[GlbSkinnedMesh {
//!         name: "body",
//!         rest: body.rest_mesh(),
//!         weights: body.rest_mesh_weights(),
//!         skeleton: body.skeleton(),
//!         poses: &motion,
//!         color: [196, 186, 178],
//!     }],
//!     30.0, // frames a second
//! )?;
//! # Ok(())
//! # }
//! ```

// The README's quick start and the book's Rust snippets, compiled (and the `no_run` ones not
// run) as doctests by `cargo test --workspace --release --all-features`.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

#[cfg(doctest)]
#[doc = include_str!("../book/src/api.md")]
pub struct BookApiDoctests;

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
