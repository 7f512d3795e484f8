//! Prediction: pose and material in, garment mesh out, for one character or a scene of
//! many; the body push-out, fabric calibration and the trained material range.

pub(crate) mod calibrated;
pub(crate) mod calibration;
pub mod material_range;
pub(crate) mod on_body;
pub(crate) mod predictor;
pub(crate) mod push_out;
pub(crate) mod scene;
pub(crate) mod sequence;
