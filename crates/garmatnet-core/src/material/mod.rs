//! The material space: a fabric's 6-d mass-spring material ω, its physical bounds and
//! normalisation, and the named presets.

pub(crate) mod bounds;
pub(crate) mod presets;
pub(crate) mod space;
