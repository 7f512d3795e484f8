//! Datasets on disk: generation (resumable, sharded, threaded), the manifest and per-sample
//! arrays, reading and checking, reuse and merging.

pub(crate) mod generator;
pub mod manifest;
pub(crate) mod reader;
pub(crate) mod reuse;
pub mod sample_arrays;
pub(crate) mod sample_deriver;
pub(crate) mod shard;
pub(crate) mod writer;
