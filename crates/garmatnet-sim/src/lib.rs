//! The mass-spring drape solver that makes garmatnet's ground truth, and dataset generation.
//!
//! [`ClothModel`] holds Provot's mass-spring cloth; [`DrapeSolver`] drapes it to static
//! equilibrium on any [`garmatnet_core::SignedDistance`] collider with projective dynamics
//! (Liu et al. 2013), contact and friction inside the implicit solve.

pub mod cloth_model;
pub mod contact;
pub mod drape_settings;
pub mod drape_solver;
pub mod error;
pub mod grid_sheet;

pub use cloth_model::{ClothModel, SpringSpec};
pub use contact::EmptySpace;
pub use drape_settings::DrapeSettings;
pub use drape_solver::{DrapeSolver, DrapeStats};
pub use error::{Error, Result};
pub use grid_sheet::{SheetStiffness, grid_sheet};
