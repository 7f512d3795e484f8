//! Data for training: a dataset loaded and validated, the paper's split, the principal
//! components of the displacements, and the paths a run writes beside its model.

pub(crate) mod files;
pub(crate) mod loader;
pub(crate) mod pca;
pub(crate) mod split;
pub(crate) mod split_config;
pub(crate) mod stored_sequence;
