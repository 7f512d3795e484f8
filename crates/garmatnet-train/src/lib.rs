//! Training and evaluation of GarMatNet that reproduce the paper's protocol (§4).
//!
//! - [`TrainingDataset`]: a validated dataset, its rebuilt garment template, preloaded
//!   inputs and labels (eqs. 4–5) in the model's displacement frame.
//! - [`Split`]: unseen materials and poses to test, the rest 90/10 train/dev (§4.1).
//! - [`train`]: Adam, MSE on normalised outputs, early stopping, resumable checkpoints
//!   ([`CheckpointDir`]), a model file in `garmatnet-model`'s format.
//! - [`train_baseline`]: the per-material TailorNet-style baseline.
//! - [`evaluate`]: Table 2's errors, per-pose plots (Figs. 7–8), heat maps (Figs. 11–12),
//!   push-out, timing and sizes, written as a [`Report`].
//! - [`sweep_alpha`]: Table 3.
//! - [`ClothTensors::energy`]: the solver's drape energy in tensors, for
//!   physics-informed training.
//! - [`evaluate_calibration`]: how much calibrating each fabric with one of its drapes
//!   ([`garmatnet_model::FabricCalibration`]) helps at its other poses.
//!
//! Every run is described by a serde configuration, so a CLI or a JSON file can set it:
//!
//! ```
//! use garmatnet_train::TrainConfig;
//!
//! let config: TrainConfig = serde_json::from_str(r#"{ "alpha": 0.3, "hidden": 256 }"#)?;
//! assert_eq!(config.alpha, 0.3);
//! assert_eq!(config.patience_local, 200, "unset fields keep the paper's defaults");
//! assert_eq!(config.split.test_materials.len(), 4);
//! config.validate()?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod data;
mod error;
mod evaluation;
mod harness;
mod physics;
mod progress;
#[cfg(test)]
mod test_util;
mod training;

pub use data::files::split_path;
pub use data::loader::{
    BODY_POINT_TOLERANCE, LoadedSamples, SampleKey, SampleTruth, TrainingDataset,
};
pub use data::split::{Split, material_indices};
pub use data::split_config::SplitConfig;
pub use data::stored_sequence::{StoredSequence, stored_sequence};
pub use error::DIVERGENCE_LOSS;
pub use error::{Error, Result};
pub use evaluation::calibration_eval::{CalibrationEval, CalibrationRow, evaluate_calibration};
pub use evaluation::evaluate::{
    EvalConfig, EvalInputs, HeldOutInputs, evaluate, evaluate_held_out,
};
pub use evaluation::plots::{ParetoPoint, Series, line_chart, pareto_chart};
pub use evaluation::report::{
    ErrorStats, FabricLookup, FrameComparison, HeldOutReport, HeldOutSet, MaterialErrors,
    MaterialSupport, MirrorSymmetry, ModelSizes, NearestTraining, NewtonFromPrediction, PartErrors,
    PenetrationStats, PhysicalQuality, Report, SampleErrors, TestParts, Timing,
};
pub use harness::bench::{BenchConfig, BenchInputs, BenchReport, BenchRow, run_bench};
pub use harness::stress::{FAR_FROM_BODY, MAX_STRESS_BATCH, StressReport, stress_predictor};
pub use physics::{
    BodyField, ClothTensors, EnergyTensors, JointLimitsPoses, NormalizerTensors, PhysicsBatch,
    PhysicsConfig, PhysicsOnlyConfig, PhysicsOnlySummary, PhysicsPoses, PoseSource, SampledPoses,
    TwoNetPhysicsLoss, rest_offset_normalizers, train_physics_only, uniform_fabric,
};
pub use progress::{
    DEFAULT_LOG_INTERVAL_SECS, LOG_INTERVAL_VAR, Progress, SharedLog, log_interval,
};
pub use training::alpha_sweep::{AlphaSweepRow, PAPER_ALPHAS, sweep_alpha};
pub use training::baseline::{
    BASELINE_MANIFEST, BASELINE_VERSION, Baseline, BaselineConfig, BaselineManifest,
    BaselineMaterial, BaselineMaterialEntry, train_baseline,
};
pub use training::checkpoint::{
    CHECKPOINT_VERSION, CheckpointDir, CheckpointState, LearningRateChange, NetProgress, Phase,
};
pub use training::train_config::{RunOptions, TrainConfig};
pub use training::trainer::{NetSummary, TrainSummary, train};
pub use training::training_loop::{COSINE_FINAL_FRACTION, LearningRateSchedule, STD_FLOOR};
