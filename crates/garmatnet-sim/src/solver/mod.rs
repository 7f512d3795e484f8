//! The static-drape solver: the cloth as a mass-spring system, its energy and Newton system,
//! body contact with friction, and the protocols that drape a garment along poses.

pub(crate) mod canonical;
pub(crate) mod cloth_model;
pub(crate) mod contact;
pub(crate) mod drape_energy;
pub(crate) mod drape_settings;
pub(crate) mod drape_solver;
pub(crate) mod frame_stepper;
pub(crate) mod garment_drape;
pub(crate) mod grid_sheet;
pub(crate) mod mirror_symmetry;
pub(crate) mod nested_dissection;
pub(crate) mod newton_system;
pub(crate) mod simulated_drape;
