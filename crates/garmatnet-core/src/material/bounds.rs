//! The bounds of the material space ω and the names and units of its six components.
//!
//! The networks are trained on materials inside these bounds; [`crate::material::space`] explains
//! the log-scale normalisation between them and tabulates them.

use crate::math::Real;

/// The number of material parameters (the length of ω).
pub const MATERIAL_DIM: usize = 6;

/// The field names of the components, in ω's order.
pub const COMPONENT_NAMES: [&str; MATERIAL_DIM] = [
    "structural_vertical",
    "structural_horizontal",
    "flexion_vertical",
    "flexion_horizontal",
    "shear",
    "density",
];

/// The physical unit of each component, in ω's order.
pub const COMPONENT_UNITS: [&str; MATERIAL_DIM] = ["N/m", "N/m", "N/m", "N/m", "N/m", "kg/m^2"];

/// Smallest structural (stretch) stiffness in the network's range, N/m (a very loose knit).
pub(crate) const STRUCTURAL_MIN: Real = 10.0;
/// Largest structural stiffness, N/m (fused interfacing, heavy leather).
pub(crate) const STRUCTURAL_MAX: Real = 20_000.0;
/// Smallest flexion (bending) stiffness, N/m (chiffon, tulle).
pub(crate) const FLEXION_MIN: Real = 0.01;
/// Largest flexion stiffness, N/m (rigid trims).
pub(crate) const FLEXION_MAX: Real = 2_000.0;
/// Smallest shear stiffness, N/m (open meshes shear almost freely).
pub(crate) const SHEAR_MIN: Real = 1.0;
/// Largest shear stiffness, N/m (isotropic sheets such as leather and fused trims).
pub(crate) const SHEAR_MAX: Real = 20_000.0;
/// Smallest areal density, kg/m^2 (20 g/m^2, lighter than tulle).
pub(crate) const DENSITY_MIN: Real = 0.02;
/// Largest areal density, kg/m^2 (1 kg/m^2, thick cowhide or neoprene).
pub(crate) const DENSITY_MAX: Real = 1.0;

/// Per-component bounds of the material space, in ω's order and physical units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MaterialBounds {
    /// Lower bounds (N/m for the five stiffnesses, kg/m^2 for density).
    pub min: [Real; MATERIAL_DIM],
    /// Upper bounds, same units.
    pub max: [Real; MATERIAL_DIM],
}

impl MaterialBounds {
    /// The bounds of the network's material space: each component's range, normalised
    /// logarithmically to [0, 1] by [`crate::Material::to_normalized`].
    pub const STANDARD: MaterialBounds = MaterialBounds {
        min: [
            STRUCTURAL_MIN,
            STRUCTURAL_MIN,
            FLEXION_MIN,
            FLEXION_MIN,
            SHEAR_MIN,
            DENSITY_MIN,
        ],
        max: [
            STRUCTURAL_MAX,
            STRUCTURAL_MAX,
            FLEXION_MAX,
            FLEXION_MAX,
            SHEAR_MAX,
            DENSITY_MAX,
        ],
    };
}
