//! The two GarMatNet networks in Burn, the typed predictor and model files.
//!
//! - [`GarMatNet`]: the paper's MLP (§3.4–3.6), used twice: the generally-fitting net and
//!   the locally-detailed net. [`BaselineNet`]: the TailorNet-style comparison (no material).
//! - [`GarMatNetModel`]: both nets, their [`OutputNormalizer`]s and metadata, saved as one
//!   self-describing `.safetensors` file.
//! - [`GarMatNetModel::average`]: several trained models averaged into one
//!   wider model of the same architecture and file format.
//! - [`Predictor`] and [`Scene`]: typed, validated, batched inference; [`push_out()`] keeps
//!   garments outside the body.
//! - [`FabricCalibration`]: a fabric described by one simulated drape as
//!   a blend of the model's training fabrics, for fabrics far from them.
//!
//! Backends are chosen at run time with [`select_device`]; the CPU (`flex`) is always there,
//! the GPU with the `wgpu` feature.
//!
//! ```
//! use burn::prelude::*;
//! use garmatnet_model::{select_device, GarMatNetConfig};
//!
//! let device = select_device("cpu")?;
//! // 50 garment vertices; pose branch 32, material branch 16, merged hidden layer 32.
//! let net = GarMatNetConfig::new(50, 32, 16, 32).with_alpha(0.5).init(&device);
//! let pose = Tensor::<2>::zeros([2, 72], &device);
//! let material = Tensor::<2>::ones([2, 6], &device).mul_scalar(0.5);
//! assert_eq!(net.forward(pose, material).dims(), [2, 150]);
//! # Ok::<(), garmatnet_model::Error>(())
//! ```

mod device;
mod error;
mod file;
mod net;
mod predict;
#[cfg(test)]
mod test_util;

pub use device::select_device;
pub use error::{Error, Result};
pub use file::default_model::{MODEL_ENV, SHIPPED_MODEL, default_model_path};
pub use file::model_file::{
    FORMAT_NAME, FORMAT_VERSION, GarMatNetModel, ModelMeta, TrainingProvenance,
};
pub use net::baseline_net::{BaselineNet, BaselineNetConfig};
pub use net::garmatnet_net::{
    GarMatNet, GarMatNetConfig, MAX_PARAMETERS, OutputHead, PoseEncoding,
};
pub use net::output_normalizer::{MIN_STD, OutputNormalizer};
pub use predict::calibration::{
    CALIBRATION_VERSION, CalibrationSettings, DEFAULT_RIDGE, FabricCalibration,
    MAX_ABSOLUTE_WEIGHT_SUM, ReferenceDrape, WeightedFabric,
};
pub use predict::material_range;
pub use predict::material_range::{
    FAR_FROM_TRAINING, MaterialRange, OutsideComponent, TrainingFabric,
};
pub use predict::predictor::{Detail, GarmentMesh, Predictor};
pub use predict::push_out::{MAX_PUSH_OUT_EPSILON, PushOut, PushOutReport, push_out};
pub use predict::scene::{Character, CharacterOutput, Scene, SceneUpdate};
pub use predict::sequence::{SEQUENCE_BATCH, SequencePredictions};
