//! garmatnet: predict how a garment drapes on a posed body, for a given fabric, in
//! milliseconds (GarMatNet, Luo, Li & Kanai, MIG '21).
//!
//! This facade re-exports the typed API of the `garmatnet-*` crates.

pub use garmatnet_core as core;
