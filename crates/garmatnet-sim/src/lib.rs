//! The mass-spring drape solver that makes garmatnet's ground truth, and dataset generation.
//!
//! [`ClothModel`] holds Provot's mass-spring cloth; [`DrapeSolver`] drapes it to static
//! equilibrium on any [`garmatnet_core::SignedDistance`] collider by Newton's method with
//! pseudo-transient continuation, penalty contact and smooth Coulomb friction measured
//! relative to the moving body.

mod arm_clearance;
mod arm_placement;
mod canonical;
mod cloth_model;
mod contact;
pub mod dataset;
mod dataset_generator;
mod dataset_reader;
mod drape_energy;
mod drape_settings;
mod drape_solver;
mod error;
mod everyday_poses;
mod garment_drape;
mod grid_sheet;
pub mod manifest;
mod mirror_symmetry;
mod motion;
mod nested_dissection;
mod newton_system;
mod pose_sampler;
mod reuse;
pub mod sample_arrays;
mod sample_deriver;
mod self_intersection;
mod shard;

pub use arm_clearance::{ArmClearance, DEFAULT_ARM_CLEARANCE};
pub use arm_placement::{ArmPlacement, Side};
pub use canonical::{CANONICAL_SURFACE_STEP, CanonicalDraper, DrapeProtocol, canonical_settings};
pub use cloth_model::{ClothModel, SpringSpec};
pub use contact::EmptySpace;
pub use dataset::{DatasetWriter, scan_samples};
pub use dataset_generator::{
    GenerateConfig, GenerateEvent, GenerateReport, SampleDone, dataset_spec, generate_dataset,
};
pub use dataset_reader::{DatasetReader, DatasetReport, SOUND_STRETCH, Summary, check};
pub use drape_energy::{
    EnergyTerms, HARDENING_DEPTH, contact_stiffness, drape_energy_and_gradient,
};
pub use drape_settings::{DrapeSettings, FactorPrecision};
pub use drape_solver::{DrapeSolver, DrapeStats};
pub use error::{Error, Result, SpecField};
pub use everyday_poses::{EverydayPose, everyday_pose, everyday_pose_names, everyday_poses};
pub use garment_drape::{
    FrameStepper, LANDING_ITERATIONS, SequenceResume, SequenceSettings, cloth_from_garment,
    drape_poses, drape_sequence, settle_at_rest, surface_steps,
};
pub use grid_sheet::{SheetStiffness, grid_sheet};
pub use manifest::{
    BodyInfo, DATASET_FORMAT_VERSION, DatasetSpec, GROUND_TRUTH_REVISION, Manifest, MaterialEntry,
    SampleRecord, SampleStats, SmoothingInfo, manifest_path, revision_label, sample_stem,
};
pub use mirror_symmetry::{MIRROR_TOLERANCE, MirrorMap, mirror_asymmetry, mirror_point};
pub use motion::{
    MIN_STEP_RAD, MotionGenerator, MotionPace, MotionTheme, extreme_poses, interpolation_steps,
    rest_deviation,
};
pub use pose_sampler::{
    DEFAULT_HANGING_FRACTION, DEFAULT_RAISED_FRACTION, PoseSampler, PoseSamplerConfig,
};
pub use reuse::{ImportReport, import_samples};
pub use sample_arrays::SampleArrays;
pub use sample_deriver::{BODY_NAME, SampleDeriver};
pub use self_intersection::{
    DEFAULT_ARM_GAP, SelfContact, SelfIntersection, THIGH_ROOT_FRACTION, UPPER_ARM_ROOT_FRACTION,
    self_intersection,
};
pub use shard::{MergeReport, Shard, merge_shards};
