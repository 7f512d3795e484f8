//! The mass-spring drape solver that makes garmatnet's ground truth, and dataset generation.
//!
//! [`ClothModel`] holds Provot's mass-spring cloth; [`DrapeSolver`] drapes it to static
//! equilibrium on any [`garmatnet_core::SignedDistance`] collider by Newton's method with
//! pseudo-transient continuation, penalty contact and smooth Coulomb friction measured
//! relative to the moving body.

mod dataset;
mod error;
mod motion;
mod solver;

pub use dataset::generator::{
    GenerateConfig, GenerateEvent, GenerateReport, SampleDone, dataset_spec, generate_dataset,
};
pub use dataset::manifest::{
    BodyInfo, DATASET_FORMAT_VERSION, DatasetSpec, GROUND_TRUTH_REVISION, Manifest, MaterialEntry,
    SamplePlan, SampleRecord, SampleStats, SmoothingInfo, manifest_path, read_poses_or_dataset,
    revision_label, sample_stem,
};
pub use dataset::reader::{
    DatasetReader, DatasetReport, SOUND_ASYMMETRY_M, SOUND_PENETRATION_M, SOUND_STRETCH, Summary,
    check,
};
pub use dataset::reuse::{ImportReport, import_samples};
pub use dataset::sample_arrays::SampleArrays;
pub use dataset::sample_deriver::{BODY_NAME, SampleDeriver};
pub use dataset::shard::{MergeReport, Shard, merge_shards};
pub use dataset::writer::{DatasetWriter, samples_dir, scan_samples};
pub use dataset::{manifest, sample_arrays};
pub use error::{Error, Result, SpecField, StepParameter};
pub use motion::arm_clearance::{ArmClearance, DEFAULT_ARM_CLEARANCE};
pub use motion::arm_placement::{ArmPlacement, Side};
pub use motion::everyday_poses::{
    EverydayPose, POSE_NAMES_FILE, everyday_pose, everyday_pose_names, everyday_poses,
};
pub use motion::generator::{
    MIN_STEP_RAD, MotionGenerator, MotionPace, MotionTheme, extreme_poses, interpolation_steps,
    rest_deviation,
};
pub use motion::pose_sampler::{
    DEFAULT_HANGING_FRACTION, DEFAULT_RAISED_FRACTION, PAIRED_AZIMUTH_SPREAD_DEG,
    PAIRED_ELEVATION_SPREAD_DEG, PoseSampler, PoseSamplerConfig, SIDE_AZIMUTH_DEG,
    SIDE_ELEVATION_DEG,
};
pub use motion::pose_spec::{
    DEFAULT_MOTION_FRAMES, DEFAULT_MOTION_SEED, EVERYDAY_POSES, SHIPPED_TRAINING_FRAMES,
    frame_range, resolve_frames, resolve_pose, training_motion_frames,
};
pub use motion::self_intersection::{
    DEFAULT_ARM_GAP, SelfContact, SelfIntersection, THIGH_ROOT_FRACTION, UPPER_ARM_ROOT_FRACTION,
    self_intersection,
};
pub use solver::canonical::{
    CANONICAL_SURFACE_STEP, CanonicalDraper, DrapeProtocol, canonical_settings,
};
pub use solver::cloth_model::{ClothModel, SpringSpec, cloth_from_garment};
pub use solver::contact::EmptySpace;
pub use solver::drape_energy::{
    EnergyTerms, HARDENING_DEPTH, contact_stiffness, drape_energy_and_gradient,
};
pub use solver::drape_settings::{DrapeSettings, FactorPrecision};
pub use solver::drape_solver::{DrapeSolver, DrapeStats, force_residual};
pub use solver::frame_stepper::FrameStepper;
pub use solver::garment_drape::{
    LANDING_ITERATIONS, SequenceResume, SequenceSettings, drape_poses, drape_sequence,
    settle_at_rest, settle_rest_drape, surface_steps,
};
pub use solver::grid_sheet::{SheetStiffness, grid_sheet};
pub use solver::mirror_symmetry::{MIRROR_TOLERANCE, MirrorMap, mirror_asymmetry, mirror_point};
pub use solver::simulated_drape::{SimulatedDrape, simulate_drape, simulate_sequence};
