//! The garment template: the T-shirt's pattern, its styles, its mesh and mass-spring springs.

pub(crate) mod openings;
pub(crate) mod pattern;
pub(crate) mod resolution;
pub(crate) mod shape;
pub(crate) mod spring;
pub(crate) mod style;
pub(crate) mod template;
