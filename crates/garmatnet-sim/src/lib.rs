//! The mass-spring drape solver that makes garmatnet's ground truth, and dataset generation.

pub mod motion;

pub use motion::{extreme_poses, interpolation_steps, rest_deviation, MotionGenerator, MotionTheme};
