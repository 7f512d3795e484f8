//! The two GarMatNet networks in Burn, the typed predictor and model files.
//!
//! - [`GarMatNet`]: the paper's MLP (§3.4–3.6), used twice: the generally-fitting net and
//!   the locally-detailed net. [`BaselineNet`]: the TailorNet-style comparison (no material).
//! - [`GarMatNetModel`]: both nets, their [`OutputNormalizer`]s and metadata, saved as one
//!   self-describing `.safetensors` file.
//! - [`Predictor`] and [`Scene`]: typed, validated, batched inference; [`push_out`] keeps
//!   garments outside the body.
//!
//! Backends are chosen at run time with [`select_device`]; the CPU (`flex`) is always there,
//! the GPU with the `wgpu` feature.

pub mod baseline_net;
pub mod device;
pub mod error;
pub mod garmatnet_net;
pub mod model_file;
pub mod output_normalizer;
pub mod predictor;
pub mod push_out;
pub mod scene;
mod tensor_util;
#[cfg(test)]
mod test_util;

pub use baseline_net::{BaselineNet, BaselineNetConfig};
pub use device::select_device;
pub use error::{Error, Result};
pub use garmatnet_net::{GarMatNet, GarMatNetConfig, MATERIAL_DIM, OutputHead};
pub use model_file::{
    FORMAT_NAME, FORMAT_VERSION, GarMatNetModel, ModelMeta, TemplateInfo, TrainingProvenance,
};
pub use output_normalizer::{MIN_STD, OutputNormalizer};
pub use predictor::{Detail, GarmentMesh, Predictor};
pub use push_out::{PushOut, PushOutReport, push_out};
pub use scene::{Character, CharacterOutput, Scene, SceneUpdate};
