//! The mass-spring drape solver that makes garmatnet's ground truth, and dataset generation.

pub mod dataset;
pub mod dataset_reader;
pub mod manifest;
pub mod motion;
pub mod sample_arrays;
pub mod shard;

pub use dataset::{DatasetWriter, scan_samples};
pub use dataset_reader::{DatasetReader, DatasetReport, Summary, check};
pub use manifest::{
    BodyInfo, DATASET_FORMAT_VERSION, DatasetSpec, Manifest, MaterialEntry, SampleRecord,
    SampleStats, SmoothingInfo, TemplateInfo, sample_stem,
};
pub use motion::{
    MotionGenerator, MotionTheme, extreme_poses, interpolation_steps, rest_deviation,
};
pub use sample_arrays::SampleArrays;
pub use shard::{Shard, merge_shards};
