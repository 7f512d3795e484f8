//! Supervised training: the trainer and its loop, resumable checkpoints, the paper's baseline
//! and the weight-controller sweep. Physics-informed training is in `physics`.

pub(crate) mod alpha_sweep;
pub(crate) mod baseline;
pub(crate) mod checkpoint;
pub(crate) mod starting_model;
pub(crate) mod train_config;
pub(crate) mod trainer;
pub(crate) mod training_loop;
