//! The cloth as Provot's mass-spring system: rest positions, springs and per-vertex masses;
//! [`cloth_from_garment`] builds one for a garment and a fabric.

use garmatnet_core::error::ensure_finite;
use garmatnet_core::{Error as CoreError, Garment, Material, Real, SpringKind, Vec3};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// One linear spring between two vertices (Provot 1995): force `stiffness * (l - rest_length)`
/// along the segment, resisting both stretch and compression.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpringSpec {
    /// First vertex index.
    pub a: usize,
    /// Second vertex index (different from `a`).
    pub b: usize,
    /// Rest length (metres, >= 0).
    pub rest_length: Real,
    /// Stiffness (N/m, > 0).
    pub stiffness: Real,
}

/// A validated mass-spring cloth: what the drape solver simulates.
#[derive(Debug, Clone, PartialEq)]
pub struct ClothModel {
    rest_positions: Vec<Vec3>,
    springs: Vec<SpringSpec>,
    masses: Vec<Real>,
}

impl ClothModel {
    /// A cloth from rest positions (metres), springs and per-vertex masses (kg).
    ///
    /// # Errors
    /// - [`CoreError::WrongLength`] if `masses` and `positions_rest` differ in length or the
    ///   cloth has no vertex;
    /// - [`CoreError::NonFinite`] for NaN or infinite positions, masses, rest lengths or
    ///   stiffnesses;
    /// - [`CoreError::OutOfRange`] for a spring index past the vertices, a non-positive mass
    ///   or stiffness, or a negative rest length;
    /// - [`Error::DegenerateSpring`] for a spring joining a vertex to itself.
    pub fn new(positions_rest: &[Vec3], springs: &[SpringSpec], masses: &[Real]) -> Result<Self> {
        let n = positions_rest.len();
        if n == 0 || masses.len() != n {
            return Err(CoreError::WrongLength {
                what: "per-vertex masses".into(),
                expected: format!("{n} (one per rest position, at least one)"),
                got: masses.len(),
            }
            .into());
        }
        ensure_finite(
            "cloth rest positions (metres)",
            positions_rest.iter().flat_map(|v| [v.x, v.y, v.z]),
        )?;
        ensure_finite("cloth vertex masses (kg)", masses.iter().copied())?;
        if let Some((i, &m)) = masses.iter().enumerate().find(|(_, m)| **m <= 0.0) {
            return Err(out_of_range(
                format!("mass of vertex {i} (kg)"),
                m,
                Real::MIN_POSITIVE,
                Real::MAX,
            ));
        }
        ensure_finite(
            "spring rest lengths (metres)",
            springs.iter().map(|s| s.rest_length),
        )?;
        ensure_finite(
            "spring stiffnesses (N/m)",
            springs.iter().map(|s| s.stiffness),
        )?;
        let last = (n - 1) as Real;
        for (k, s) in springs.iter().enumerate() {
            for end in [s.a, s.b] {
                if end >= n {
                    return Err(out_of_range(
                        format!("vertex index of spring {k}"),
                        end as Real,
                        0.0,
                        last,
                    ));
                }
            }
            if s.a == s.b {
                return Err(Error::DegenerateSpring {
                    spring: k,
                    vertex: s.a,
                });
            }
            if s.stiffness <= 0.0 {
                let what = format!("stiffness of spring {k} (N/m)");
                return Err(out_of_range(
                    what,
                    s.stiffness,
                    Real::MIN_POSITIVE,
                    Real::MAX,
                ));
            }
            if s.rest_length < 0.0 {
                let what = format!("rest length of spring {k} (metres)");
                return Err(out_of_range(what, s.rest_length, 0.0, Real::MAX));
            }
        }
        Ok(Self {
            rest_positions: positions_rest.to_vec(),
            springs: springs.to_vec(),
            masses: masses.to_vec(),
        })
    }

    /// The number of vertices.
    #[must_use]
    pub fn vertex_count(&self) -> usize {
        self.rest_positions.len()
    }

    /// Rest positions (metres).
    #[must_use]
    pub fn rest_positions(&self) -> &[Vec3] {
        &self.rest_positions
    }

    /// The springs.
    #[must_use]
    pub fn springs(&self) -> &[SpringSpec] {
        &self.springs
    }

    /// Per-vertex masses (kg).
    #[must_use]
    pub fn masses(&self) -> &[Real] {
        &self.masses
    }

    /// The largest strain `|x_a - x_b| / L - 1` over the springs of positive rest length at
    /// positions `x` (metres): what [`crate::DrapeStats::max_strain`] and `dataset check`
    /// record. Negative when every spring is compressed.
    ///
    /// # Errors
    /// [`CoreError::WrongLength`] unless `x` has one position per vertex.
    pub fn max_strain(&self, x: &[Vec3]) -> Result<Real> {
        if x.len() != self.vertex_count() {
            return Err(CoreError::WrongLength {
                what: "cloth positions".into(),
                expected: format!("{} (one per vertex)", self.vertex_count()),
                got: x.len(),
            }
            .into());
        }
        Ok(self
            .springs
            .iter()
            .filter(|s| s.rest_length > 0.0)
            .map(|s| ((x[s.a] - x[s.b]).norm() - s.rest_length) / s.rest_length)
            .fold(Real::NEG_INFINITY, Real::max))
    }

    /// Total mass (kg).
    #[must_use]
    pub fn total_mass(&self) -> Real {
        self.masses.iter().sum()
    }

    /// Whether `other` has the same vertices count and spring endpoints, in the same order
    /// (so a solver's symbolic factorisation can be reused for it).
    #[must_use]
    pub fn same_topology(&self, other: &ClothModel) -> bool {
        self.vertex_count() == other.vertex_count()
            && self.springs.len() == other.springs.len()
            && self
                .springs
                .iter()
                .zip(&other.springs)
                .all(|(s, t)| s.a == t.a && s.b == t.b)
    }
}

fn out_of_range(what: String, value: Real, min: Real, max: Real) -> crate::error::Error {
    CoreError::OutOfRange {
        what,
        value,
        min,
        max,
        hint: String::new(),
    }
    .into()
}

/// The garment as a mass-spring cloth of `material`.
///
/// Every spring's constant is the material's stiffness for its [`SpringKind`], unscaled: the
/// material's stiffnesses are membrane stiffnesses (N/m), equal to the spring constant on a
/// square grid at any resolution (see [`garmatnet_core::Material`]); shear and flexion are
/// used as given. Masses are [`Garment::vertex_masses`] at the material's density.
/// Out-of-bounds but [physical](Material::is_physical) materials are accepted, for stress
/// tests.
///
/// # Errors
/// [`CoreError::OutOfRange`] or [`CoreError::NonFinite`] if the material is not physical;
/// as [`ClothModel::new`] for a broken garment.
pub fn cloth_from_garment(garment: &Garment, material: &Material) -> Result<ClothModel> {
    Material::physical(
        material.structural_vertical,
        material.structural_horizontal,
        material.flexion_vertical,
        material.flexion_horizontal,
        material.shear,
        material.density,
    )?;
    let springs: Vec<SpringSpec> = garment
        .springs
        .iter()
        .map(|s| SpringSpec {
            a: s.a as usize,
            b: s.b as usize,
            rest_length: s.rest_length,
            stiffness: match s.kind {
                SpringKind::StructuralVertical => material.structural_vertical,
                SpringKind::StructuralHorizontal => material.structural_horizontal,
                SpringKind::Shear => material.shear,
                SpringKind::FlexionVertical => material.flexion_vertical,
                SpringKind::FlexionHorizontal => material.flexion_horizontal,
            },
        })
        .collect();
    let masses = garment.vertex_masses(material.density);
    ClothModel::new(&garment.rest.vertices, &springs, &masses)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_vertices() -> Vec<Vec3> {
        vec![Vec3::zeros(), Vec3::x()]
    }

    fn spring(a: usize, b: usize, stiffness: Real) -> SpringSpec {
        SpringSpec {
            a,
            b,
            rest_length: 1.0,
            stiffness,
        }
    }

    #[test]
    fn valid_model_is_accepted() {
        let m = ClothModel::new(&two_vertices(), &[spring(0, 1, 10.0)], &[1.0, 2.0]).unwrap();
        assert_eq!(m.vertex_count(), 2);
        assert_eq!(m.total_mass(), 3.0);
    }

    #[test]
    fn nan_position_is_a_typed_error() {
        let p = vec![Vec3::zeros(), Vec3::new(Real::NAN, 0.0, 0.0)];
        let e = ClothModel::new(&p, &[spring(0, 1, 10.0)], &[1.0, 1.0]).unwrap_err();
        assert!(
            matches!(e, Error::Core(CoreError::NonFinite { index: 3, .. })),
            "{e}"
        );
    }

    #[test]
    fn negative_mass_is_a_typed_error() {
        let e = ClothModel::new(&two_vertices(), &[spring(0, 1, 10.0)], &[1.0, -1.0]).unwrap_err();
        assert!(
            matches!(e, Error::Core(CoreError::OutOfRange { .. })),
            "{e}"
        );
        assert!(e.to_string().contains("mass of vertex 1"));
    }

    #[test]
    fn bad_spring_index_is_a_typed_error() {
        let e = ClothModel::new(&two_vertices(), &[spring(0, 2, 10.0)], &[1.0, 1.0]).unwrap_err();
        assert!(
            matches!(e, Error::Core(CoreError::OutOfRange { .. })),
            "{e}"
        );
        let e = ClothModel::new(&two_vertices(), &[spring(1, 1, 10.0)], &[1.0, 1.0]).unwrap_err();
        assert!(
            matches!(
                e,
                Error::DegenerateSpring {
                    spring: 0,
                    vertex: 1
                }
            ),
            "{e}"
        );
    }

    #[test]
    fn non_positive_stiffness_and_wrong_mass_count_are_typed_errors() {
        let e = ClothModel::new(&two_vertices(), &[spring(0, 1, 0.0)], &[1.0, 1.0]).unwrap_err();
        assert!(
            matches!(e, Error::Core(CoreError::OutOfRange { .. })),
            "{e}"
        );
        let e = ClothModel::new(&two_vertices(), &[spring(0, 1, 1.0)], &[1.0]).unwrap_err();
        assert!(
            matches!(e, Error::Core(CoreError::WrongLength { .. })),
            "{e}"
        );
    }
}
