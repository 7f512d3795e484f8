//! The material space ω (paper §3.1): six mass-spring parameters in physical units, their
//! bounds, and the normalised `[0, 1]^6` coordinates the networks see.
//!
//! # Components
//! Order is the paper's: structural vertical, structural horizontal, flexion vertical,
//! flexion horizontal, shear, density.
//!
//! | # | field                   | spring (Provot 1995)             | unit   | min   | max    |
//! |---|-------------------------|----------------------------------|--------|-------|--------|
//! | 0 | `structural_vertical`   | `[i,j]–[i+1,j]` (warp stretch)   | N/m    | 10    | 20,000 |
//! | 1 | `structural_horizontal` | `[i,j]–[i,j+1]` (weft stretch)   | N/m    | 10    | 20,000 |
//! | 2 | `flexion_vertical`      | `[i,j]–[i+2,j]` (skip-one bend)  | N/m    | 0.01  | 2,000  |
//! | 3 | `flexion_horizontal`    | `[i,j]–[i,j+2]` (skip-one bend)  | N/m    | 0.01  | 2,000  |
//! | 4 | `shear`                 | `[i,j]–[i+1,j+1]` and `[i+1,j]–[i,j+1]` | N/m | 1 | 20,000 |
//! | 5 | `density`               | mass per area                    | kg/m^2 | 0.02  | 1.0    |
//!
//! Stiffnesses are *membrane* stiffnesses. On a square grid a structural spring of constant
//! `k` across a cell of width `h` carries force `k·δ` for an extension `δ = ε·h` over a
//! cross-section `h`, i.e. a membrane tension of `k·ε` N/m — independent of `h`. The solver
//! therefore uses these values directly as spring constants at any resolution.
//!
//! # Normalisation
//! Every component is mapped to `[0, 1]` on a log scale between its bounds,
//! `n = (ln v − ln lo) / (ln hi − ln lo)`, inverted by `v = exp(ln lo + n·(ln hi − ln lo))`.
//! Fabrics span four to five decades of stiffness, so a linear scale would crush every
//! drapey fabric into the first percent of the range. Interpolation ([`Material::lerp`]) is
//! linear in these coordinates, hence geometric in physical units.
//!
//! The named fabrics live in [`crate::material::presets`].
//!
//! ```
//! use garmatnet_core::Material;
//!
//! let satin: Material = "silk_duchess_satin".parse()?;
//! let custom: Material = "1200,900,0.5,0.4,12,0.09".parse()?;
//! let n = satin.to_normalized(); // what the networks see, in [0, 1]^6
//! let back = Material::from_normalized(n)?;
//! assert!((back.shear - satin.shear).abs() < 1e-9 * satin.shear);
//! let blend = Material::lerp(&satin, &custom, 0.5)?; // geometric mean of each value
//! assert!((blend.density - (satin.density * custom.density).sqrt()).abs() < 1e-12);
//! # Ok::<(), garmatnet_core::Error>(())
//! ```

use std::fmt;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::material::bounds::{COMPONENT_NAMES, COMPONENT_UNITS, MATERIAL_DIM, MaterialBounds};
use crate::math::Real;

/// A fabric in the mass-spring material space ω, in physical units.
///
/// The fields are public so that tables can be written as literals; a literal is not
/// checked. Use [`Material::new`] (within [`MaterialBounds::STANDARD`]) or
/// [`Material::physical`] (any positive finite values, for solver stress tests), or call
/// [`Material::validate`] before handing a material to the networks. Deserialisation does
/// not validate either, so that datasets may store stress-test materials.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Material {
    /// Stretch stiffness along the warp (vertical, `[i,j]–[i+1,j]`), N/m.
    pub structural_vertical: Real,
    /// Stretch stiffness along the weft (horizontal, `[i,j]–[i,j+1]`), N/m.
    pub structural_horizontal: Real,
    /// Bending stiffness of the vertical skip-one springs (`[i,j]–[i+2,j]`), N/m.
    pub flexion_vertical: Real,
    /// Bending stiffness of the horizontal skip-one springs (`[i,j]–[i,j+2]`), N/m.
    pub flexion_horizontal: Real,
    /// Stiffness of the diagonal springs, N/m.
    pub shear: Real,
    /// Mass per area, kg/m^2.
    pub density: Real,
}

impl Material {
    /// A material inside the network's range.
    ///
    /// # Errors
    /// As [`Material::validate`].
    pub fn new(
        structural_vertical: Real,
        structural_horizontal: Real,
        flexion_vertical: Real,
        flexion_horizontal: Real,
        shear: Real,
        density: Real,
    ) -> Result<Self> {
        let m = Self::from_array_unchecked([
            structural_vertical,
            structural_horizontal,
            flexion_vertical,
            flexion_horizontal,
            shear,
            density,
        ]);
        m.validate()?;
        Ok(m)
    }

    /// A material the solver can simulate but the networks were not trained on: every
    /// value need only be finite and positive. Meant for stress tests such as stiffness
    /// ×0.01 or ×100 and density ×0.1 or ×10.
    ///
    /// # Errors
    /// [`Error::NonFinite`] for NaN or infinity; [`Error::OutOfRange`] for a value ≤ 0.
    pub fn physical(
        structural_vertical: Real,
        structural_horizontal: Real,
        flexion_vertical: Real,
        flexion_horizontal: Real,
        shear: Real,
        density: Real,
    ) -> Result<Self> {
        let m = Self::from_array_unchecked([
            structural_vertical,
            structural_horizontal,
            flexion_vertical,
            flexion_horizontal,
            shear,
            density,
        ]);
        m.check_physical()?;
        Ok(m)
    }

    /// A material from its six values in ω's order (see [`COMPONENT_NAMES`]), validated
    /// against the standard bounds.
    ///
    /// # Errors
    /// As [`Material::validate`].
    pub fn from_array(values: [Real; MATERIAL_DIM]) -> Result<Self> {
        let m = Self::from_array_unchecked(values);
        m.validate()?;
        Ok(m)
    }

    const fn from_array_unchecked(v: [Real; MATERIAL_DIM]) -> Self {
        Self {
            structural_vertical: v[0],
            structural_horizontal: v[1],
            flexion_vertical: v[2],
            flexion_horizontal: v[3],
            shear: v[4],
            density: v[5],
        }
    }

    /// The six values in ω's order, physical units.
    #[must_use]
    pub const fn as_array(&self) -> [Real; MATERIAL_DIM] {
        [
            self.structural_vertical,
            self.structural_horizontal,
            self.flexion_vertical,
            self.flexion_horizontal,
            self.shear,
            self.density,
        ]
    }

    /// Checks that every component is finite and within [`MaterialBounds::STANDARD`].
    ///
    /// # Errors
    /// [`Error::NonFinite`] naming the first NaN or infinite component;
    /// [`Error::OutOfRange`] naming the first component outside its bounds, with its unit.
    pub fn validate(&self) -> Result<()> {
        let b = MaterialBounds::STANDARD;
        for (i, v) in self.as_array().into_iter().enumerate() {
            if !v.is_finite() {
                return Err(non_finite(i));
            }
            if v < b.min[i] || v > b.max[i] {
                return Err(Error::OutOfRange {
                    what: component_label(i),
                    value: v,
                    min: b.min[i],
                    max: b.max[i],
                    hint: "; the networks only know this range: use .clamped() to move it \
                           inside, or Material::physical for a solver-only stress test"
                        .into(),
                });
            }
        }
        Ok(())
    }

    /// Whether the solver can simulate this material: every component finite and > 0.
    #[must_use]
    pub fn is_physical(&self) -> bool {
        self.as_array().iter().all(|v| v.is_finite() && *v > 0.0)
    }

    fn check_physical(&self) -> Result<()> {
        for (i, v) in self.as_array().into_iter().enumerate() {
            if !v.is_finite() {
                return Err(non_finite(i));
            }
            if v <= 0.0 {
                return Err(Error::OutOfRange {
                    what: component_label(i),
                    value: v,
                    min: Real::MIN_POSITIVE,
                    max: Real::MAX,
                    hint: "; springs and masses must be strictly positive".into(),
                });
            }
        }
        Ok(())
    }

    /// This material with every component clamped into [`MaterialBounds::STANDARD`]
    /// (±infinity go to the bound; NaN stays NaN so [`Material::validate`] still rejects it).
    #[must_use]
    pub fn clamped(&self) -> Material {
        let b = MaterialBounds::STANDARD;
        let v = self.as_array();
        Self::from_array_unchecked(std::array::from_fn(|i| v[i].clamp(b.min[i], b.max[i])))
    }

    /// The five stiffnesses multiplied by `stiffness_factor` and the density by
    /// `density_factor`; the result is not bounds-checked, so stress variants (e.g. ×0.01,
    /// ×100) are allowed.
    ///
    /// # Errors
    /// [`Error::NonFinite`] or [`Error::OutOfRange`] when a factor is not finite and
    /// positive or the result is not [physical](Material::is_physical).
    pub fn scaled(&self, stiffness_factor: Real, density_factor: Real) -> Result<Material> {
        for (what, f) in [
            ("stiffness factor", stiffness_factor),
            ("density factor", density_factor),
        ] {
            if !f.is_finite() {
                return Err(Error::NonFinite {
                    what: what.into(),
                    index: 0,
                });
            }
            if f <= 0.0 {
                return Err(Error::OutOfRange {
                    what: what.into(),
                    value: f,
                    min: Real::MIN_POSITIVE,
                    max: Real::MAX,
                    hint: "; a scale factor must be positive".into(),
                });
            }
        }
        let v = self.as_array();
        let m = Self::from_array_unchecked(std::array::from_fn(|i| {
            v[i] * if i == 5 {
                density_factor
            } else {
                stiffness_factor
            }
        }));
        m.check_physical()?;
        Ok(m)
    }

    /// The normalised coordinates the networks see, `n = (ln v − ln lo) / (ln hi − ln lo)`.
    ///
    /// A material inside the bounds maps into `[0, 1]^6`; a stress-test material outside
    /// them maps outside (the log scale extends), so callers can tell. Components must be
    /// positive for the logarithm; a non-physical material yields NaN there.
    #[must_use]
    pub fn to_normalized(&self) -> [Real; MATERIAL_DIM] {
        let b = MaterialBounds::STANDARD;
        let v = self.as_array();
        std::array::from_fn(|i| {
            let (lo, hi) = (b.min[i], b.max[i]);
            let n = (v[i].ln() - lo.ln()) / (hi.ln() - lo.ln());
            // Rounding at the bounds must not push an in-range value outside [0, 1].
            if (lo..=hi).contains(&v[i]) {
                n.clamp(0.0, 1.0)
            } else {
                n
            }
        })
    }

    /// The unit direction in normalised coordinates along which a material moves when every
    /// stiffness and the density are multiplied by one common factor `c`: each coordinate
    /// shifts by `ln c / (ln hi − ln lo)`.
    ///
    /// Moving along it leaves the static drape (nearly) unchanged: springs, gravity and the
    /// Coulomb cone all scale by `c`, so the equilibrium is the same; only the fixed contact
    /// penalty breaks the symmetry, by the sub-millimetre penetration it allows. A network
    /// that ignores this direction (GarMatNet's `scale_free_material`) sees the 5-d space of
    /// stiffness-to-weight ratios instead of the 6-d ω.
    ///
    /// ```
    /// use garmatnet_core::Material;
    ///
    /// let m = Material::preset("Cotton Poplin")?;
    /// let (a, b) = (m.to_normalized(), m.scaled(2.0, 2.0)?.to_normalized());
    /// let u = Material::uniform_scaling_direction();
    /// let t = (b[0] - a[0]) / u[0];
    /// for i in 0..6 {
    ///     assert!((b[i] - a[i] - t * u[i]).abs() < 1e-12);
    /// }
    /// # Ok::<(), garmatnet_core::Error>(())
    /// ```
    #[must_use]
    pub fn uniform_scaling_direction() -> [Real; MATERIAL_DIM] {
        let b = MaterialBounds::STANDARD;
        let v: [Real; MATERIAL_DIM] = std::array::from_fn(|i| 1.0 / (b.max[i] / b.min[i]).ln());
        let norm = v.iter().map(|x| x * x).sum::<Real>().sqrt();
        v.map(|x| x / norm)
    }

    /// The material at normalised coordinates `n` (inverse of [`Material::to_normalized`]).
    ///
    /// # Errors
    /// [`Error::NonFinite`] for NaN or infinity; [`Error::OutOfRange`] for a coordinate
    /// outside `[0, 1]`, naming the component.
    pub fn from_normalized(n: [Real; MATERIAL_DIM]) -> Result<Material> {
        let b = MaterialBounds::STANDARD;
        for (i, x) in n.into_iter().enumerate() {
            if !x.is_finite() {
                return Err(Error::NonFinite {
                    what: format!("normalised material coordinates ({})", COMPONENT_NAMES[i]),
                    index: i,
                });
            }
            if !(0.0..=1.0).contains(&x) {
                return Err(Error::OutOfRange {
                    what: format!("normalised {} (dimensionless)", COMPONENT_NAMES[i]),
                    value: x,
                    min: 0.0,
                    max: 1.0,
                    hint: "; normalised coordinates are log-scaled between the bounds".into(),
                });
            }
        }
        Ok(Self::from_array_unchecked(std::array::from_fn(|i| {
            let (lo, hi) = (b.min[i], b.max[i]);
            // exp(ln lo + n·(ln hi − ln lo)) written as lo^(1−n)·hi^n, which hits the bounds
            // exactly at n = 0 and n = 1; the clamp removes rounding in between.
            (lo.powf(1.0 - n[i]) * hi.powf(n[i])).clamp(lo, hi)
        })))
    }

    /// Linear interpolation in normalised coordinates, i.e. the geometric interpolation
    /// `a^(1−t) · b^t` of each physical component: `t = 0` gives `a`, `t = 1` gives `b`,
    /// `t = 0.5` the geometric mean.
    ///
    /// # Errors
    /// [`Error::OutOfRange`] or [`Error::NonFinite`] when `t` is not in `[0, 1]` or either
    /// material is not [physical](Material::is_physical).
    pub fn lerp(a: &Material, b: &Material, t: Real) -> Result<Material> {
        if !t.is_finite() {
            return Err(Error::NonFinite {
                what: "interpolation parameter t".into(),
                index: 0,
            });
        }
        if !(0.0..=1.0).contains(&t) {
            return Err(Error::OutOfRange {
                what: "interpolation parameter t".into(),
                value: t,
                min: 0.0,
                max: 1.0,
                hint: String::new(),
            });
        }
        a.check_physical()?;
        b.check_physical()?;
        let (va, vb) = (a.as_array(), b.as_array());
        Ok(Self::from_array_unchecked(std::array::from_fn(|i| {
            let (lo, hi) = (va[i].min(vb[i]), va[i].max(vb[i]));
            // Geometric interpolation never leaves [lo, hi]; the clamp removes rounding so
            // that blends of in-bounds materials always validate.
            (va[i].powf(1.0 - t) * vb[i].powf(t)).clamp(lo, hi)
        })))
    }
}

fn component_label(i: usize) -> String {
    let kind = match i {
        0 | 1 => "structural (stretch) stiffness",
        2 | 3 => "flexion (bending) stiffness",
        4 => "shear stiffness",
        _ => "areal density",
    };
    format!(
        "material {} ({kind}, {})",
        COMPONENT_NAMES[i], COMPONENT_UNITS[i]
    )
}

fn non_finite(i: usize) -> Error {
    Error::NonFinite {
        what: format!("material ({} = component {i})", COMPONENT_NAMES[i]),
        index: i,
    }
}

impl fmt::Display for Material {
    /// `a,b,c,d,e,f` in ω's order and physical units: the format `Material::from_str` ([`std::str::FromStr`])
    /// reads back exactly (Rust prints the shortest round-tripping decimal).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.as_array();
        write!(f, "{},{},{},{},{},{}", v[0], v[1], v[2], v[3], v[4], v[5])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::bounds::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    fn cotton() -> Material {
        Material::new(1200.0, 900.0, 0.5, 0.4, 12.0, 0.09).unwrap()
    }

    proptest! {
        #[test]
        fn normalized_round_trip(n in proptest::array::uniform6(0.0f64..=1.0)) {
            let m = Material::from_normalized(n).unwrap();
            prop_assert!(m.validate().is_ok());
            let back = m.to_normalized();
            for i in 0..MATERIAL_DIM {
                prop_assert!((back[i] - n[i]).abs() < 1e-12, "component {i}: {} vs {}", back[i], n[i]);
            }
        }

        #[test]
        fn physical_round_trip(u in proptest::array::uniform6(0.0f64..=1.0)) {
            let b = MaterialBounds::STANDARD;
            let v: [Real; 6] = std::array::from_fn(|i| b.min[i] + u[i] * (b.max[i] - b.min[i]));
            let m = Material::from_array(v).unwrap();
            let back = Material::from_normalized(m.to_normalized()).unwrap().as_array();
            for i in 0..MATERIAL_DIM {
                prop_assert!((back[i] - v[i]).abs() <= 1e-12 * v[i]);
            }
        }
    }

    #[test]
    fn bounds_map_to_unit_cube_corners() {
        let lo = Material::from_array(MaterialBounds::STANDARD.min).unwrap();
        let hi = Material::from_array(MaterialBounds::STANDARD.max).unwrap();
        assert_eq!(lo.to_normalized(), [0.0; 6]);
        assert_eq!(hi.to_normalized(), [1.0; 6]);
        assert_eq!(Material::from_normalized([1.0; 6]).unwrap(), hi);
        assert_eq!(Material::from_normalized([0.0; 6]).unwrap(), lo);
    }

    #[test]
    fn normalisation_is_logarithmic() {
        // The geometric mean of the structural bounds sits at the middle of the scale.
        let mid = (STRUCTURAL_MIN * STRUCTURAL_MAX).sqrt();
        let m = Material {
            structural_vertical: mid,
            ..cotton()
        };
        assert_relative_eq!(m.to_normalized()[0], 0.5, epsilon = 1e-12);
    }

    #[test]
    fn out_of_range_names_component_unit_and_range() {
        let err = Material::new(1200.0, 900.0, 0.5, 0.4, 50_000.0, 0.09).unwrap_err();
        match &err {
            Error::OutOfRange {
                what,
                value,
                min,
                max,
                ..
            } => {
                assert!(what.contains("shear") && what.contains("N/m"), "{what}");
                assert_eq!((*value, *min, *max), (50_000.0, SHEAR_MIN, SHEAR_MAX));
            }
            other => panic!("expected OutOfRange, got {other:?}"),
        }
        let msg = err.to_string();
        assert!(msg.contains("20000") && msg.contains("clamped"), "{msg}");

        let err = Material::new(1200.0, 900.0, 0.5, 0.4, 12.0, 3.0).unwrap_err();
        assert!(err.to_string().contains("density") && err.to_string().contains("kg/m^2"));
    }

    #[test]
    fn nan_and_infinity_are_rejected() {
        let err = Material::new(1200.0, Real::NAN, 0.5, 0.4, 12.0, 0.09).unwrap_err();
        assert!(matches!(err, Error::NonFinite { index: 1, .. }), "{err:?}");
        assert!(Material::physical(1.0, 1.0, 1.0, Real::INFINITY, 1.0, 1.0).is_err());
        assert!(Material::from_normalized([0.5, 0.5, Real::NAN, 0.5, 0.5, 0.5]).is_err());
        let nan = Material {
            density: Real::NAN,
            ..cotton()
        };
        assert!(!nan.is_physical());
        assert!(nan.clamped().validate().is_err());
        assert!(Material::lerp(&cotton(), &cotton(), Real::NAN).is_err());
    }

    #[test]
    fn from_normalized_rejects_outside_unit_cube() {
        let err = Material::from_normalized([0.5, 0.5, 0.5, 0.5, 0.5, 1.01]).unwrap_err();
        assert!(err.to_string().contains("density"), "{err}");
    }

    #[test]
    fn physical_allows_stress_variants_but_not_zero() {
        let c = cotton();
        let stiff = c.scaled(100.0, 10.0).unwrap();
        assert!(stiff.is_physical());
        // 1200 N/m x100 = 120,000 N/m is beyond the networks' range.
        assert!(stiff.validate().is_err());
        let soft = c.scaled(0.01, 0.1).unwrap();
        assert!(soft.validate().is_err());
        assert_relative_eq!(soft.structural_vertical, 12.0, max_relative = 1e-12);
        assert_relative_eq!(soft.density, 0.009, max_relative = 1e-12);
        assert!(c.scaled(0.0, 1.0).is_err());
        assert!(c.scaled(1.0, -1.0).is_err());
        assert!(Material::physical(1e6, 1e6, 1e5, 1e5, 1e6, 20.0).is_ok());
        assert!(Material::physical(1.0, 1.0, 0.0, 1.0, 1.0, 1.0).is_err());
    }

    #[test]
    fn clamped_moves_inside_only_when_needed() {
        let c = cotton();
        assert_eq!(c.clamped(), c);
        let wild = Material::physical(1.0, 1e9, 1e-9, 1.0, 1e9, 10.0).unwrap();
        let cl = wild.clamped();
        cl.validate().unwrap();
        assert_eq!(cl.structural_vertical, STRUCTURAL_MIN);
        assert_eq!(cl.structural_horizontal, STRUCTURAL_MAX);
        assert_eq!(cl.flexion_vertical, FLEXION_MIN);
        assert_eq!(cl.flexion_horizontal, 1.0);
        assert_eq!(cl.density, DENSITY_MAX);
    }

    #[test]
    fn stress_variant_normalises_outside_unit_cube() {
        let n = cotton().scaled(100.0, 1.0).unwrap().to_normalized();
        // Shear 12 -> 1200 N/m stays inside; structural 1200 -> 120,000 N/m does not.
        assert!(n[0] > 1.0 && (0.0..=1.0).contains(&n[4]));
    }

    #[test]
    fn lerp_endpoints_and_geometric_midpoint() {
        let a = cotton();
        let b = Material::new(9000.0, 5000.0, 40.0, 28.0, 150.0, 0.5).unwrap();
        assert_eq!(Material::lerp(&a, &b, 0.0).unwrap(), a);
        assert_eq!(Material::lerp(&a, &b, 1.0).unwrap(), b);
        let mid = Material::lerp(&a, &b, 0.5).unwrap();
        for ((m, x), y) in mid.as_array().iter().zip(a.as_array()).zip(b.as_array()) {
            assert_relative_eq!(*m, (x * y).sqrt(), max_relative = 1e-12);
        }
        // Linear in normalised space.
        let (na, nb, nm) = (a.to_normalized(), b.to_normalized(), mid.to_normalized());
        for i in 0..MATERIAL_DIM {
            assert_relative_eq!(nm[i], 0.5 * (na[i] + nb[i]), epsilon = 1e-12);
        }
        assert!(Material::lerp(&a, &b, 1.5).is_err());
        assert!(Material::lerp(&a, &b, -0.1).is_err());
    }

    #[test]
    fn lerp_of_bounds_stays_valid() {
        let hi = Material::from_array(MaterialBounds::STANDARD.max).unwrap();
        for t in [0.1, 0.3, 0.5, 0.77] {
            Material::lerp(&hi, &hi, t).unwrap().validate().unwrap();
        }
    }

    #[test]
    fn parses_values_and_round_trips_display() {
        let m: Material = " 1200, 900,0.5 ,0.4,12,0.09".parse().unwrap();
        assert_eq!(m, cotton());
        let back: Material = m.to_string().parse().unwrap();
        assert_eq!(back, m);
    }

    #[test]
    fn parse_errors_are_typed() {
        let short = "1,2,3".parse::<Material>().unwrap_err();
        assert!(
            matches!(short, Error::WrongLength { got: 3, .. }),
            "{short:?}"
        );
        let word = "1200,900,soft,0.4,12,0.09".parse::<Material>().unwrap_err();
        assert!(
            matches!(&word, Error::NotANumber { what, .. } if what.contains("flexion_vertical"))
        );
        let range = "1200,900,0.5,0.4,12,5".parse::<Material>().unwrap_err();
        assert!(matches!(range, Error::OutOfRange { .. }), "{range:?}");
        let name = "no such fabric".parse::<Material>().unwrap_err();
        assert!(matches!(name, Error::UnknownMaterial { .. }), "{name:?}");
    }

    #[test]
    fn serde_uses_field_names() {
        let json = serde_json::to_string(&cotton()).unwrap();
        for name in COMPONENT_NAMES {
            assert!(json.contains(&format!("\"{name}\"")), "{json}");
        }
        let back: Material = serde_json::from_str(&json).unwrap();
        assert_eq!(back, cotton());
    }

    #[test]
    fn array_order_matches_component_names() {
        let m = Material::from_array([11.0, 12.0, 0.3, 0.4, 5.0, 0.06]).unwrap();
        assert_eq!(m.as_array(), [11.0, 12.0, 0.3, 0.4, 5.0, 0.06]);
        assert_eq!(
            (m.structural_horizontal, m.flexion_vertical, m.shear),
            (12.0, 0.3, 5.0)
        );
    }
}
