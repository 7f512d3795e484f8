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

mod alpha_sweep;
mod baseline;
mod bench_report;
mod calibration_eval;
mod checkpoint;
mod dataset_loader;
mod error;
mod evaluation;
mod fabric_reference;
mod figures;
mod files;
mod harness;
mod pca;
mod physical_quality;
mod physics;
mod plots;
mod prediction_errors;
mod progress;
mod report;
mod showcase;
mod split;
mod stress;
#[cfg(test)]
mod test_util;
mod trainer;
mod training_loop;

pub use alpha_sweep::{AlphaSweepRow, PAPER_ALPHAS, sweep_alpha};
pub use baseline::{
    BASELINE_MANIFEST, BASELINE_VERSION, Baseline, BaselineConfig, BaselineManifest,
    BaselineMaterial, BaselineMaterialEntry, train_baseline,
};
pub use calibration_eval::{CalibrationEval, CalibrationRow, evaluate_calibration};
pub use checkpoint::{
    CHECKPOINT_VERSION, CheckpointDir, CheckpointState, LearningRateChange, NetProgress, Phase,
};
pub use dataset_loader::{
    BODY_POINT_TOLERANCE, LoadedSamples, SampleKey, SampleTruth, TrainingDataset,
};
pub use error::DIVERGENCE_LOSS;
pub use error::{Error, Result};
pub use evaluation::{EvalConfig, EvalInputs, evaluate};
pub use files::split_path;
pub use harness::{BenchConfig, BenchInputs, BenchReport, BenchRow, run_bench};
pub use physics::{
    BodyField, ClothTensors, EnergyTensors, JointLimitsPoses, NormalizerTensors, PhysicsBatch,
    PhysicsConfig, PhysicsOnlyConfig, PhysicsOnlySummary, PhysicsPoses, PoseSource, SampledPoses,
    TwoNetPhysicsLoss, rest_offset_normalizers, train_physics_only, uniform_fabric,
};
pub use plots::{ParetoPoint, Series, line_chart, pareto_chart};
pub use progress::{
    DEFAULT_LOG_INTERVAL_SECS, LOG_INTERVAL_VAR, Progress, SharedLog, log_interval,
};
pub use report::{
    ErrorStats, FabricLookup, FrameComparison, HeldOutSet, MaterialErrors, MaterialSupport,
    ModelSizes, NearestTraining, NewtonFromPrediction, PartErrors, PenetrationStats,
    PhysicalQuality, Report, SampleErrors, TestParts, Timing,
};
pub use showcase::{
    DEFAULT_MOTION_FRAMES, DEFAULT_MOTION_SEED, DrapeSequence, DrapeView, EVERYDAY_POSES,
    OutputFormat, SHIPPED_TRAINING_FRAMES, SIMULATED_COLOR, SimulatedDrape, StoredSequence,
    compare_path, comparison_image, material_from_omega, numbered_path, resolve_frames,
    resolve_material, resolve_pose, simulate_drape, simulate_sequence, slug, stored_sequence,
    training_motion_frames, vertex_errors_mm,
};
pub use split::{Split, SplitConfig, material_indices};
pub use stress::{FAR_FROM_BODY, MAX_STRESS_BATCH, StressReport, stress_predictor};
pub use trainer::{NetSummary, RunOptions, TrainConfig, TrainSummary, train};
pub use training_loop::{COSINE_FINAL_FRACTION, LearningRateSchedule, STD_FLOOR};
