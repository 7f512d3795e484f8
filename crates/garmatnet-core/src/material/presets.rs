//! The preset library: named fabrics from tulle to rigid fused trim, with name lookup, and
//! the one parser of fabrics written as text: a preset name, six physical values or six
//! normalised ω values ([`Material::parse_values`], [`parse_omega`], [`resolve_material`]).
//!
//! The paper takes its 67 materials from Marvelous Designer's library, whose values are not
//! public. These presets are **our own physically reasoned estimates**, not measurements
//! and not Marvelous Designer's numbers. The reasoning, applied throughout:
//! - *density* is the fabric's usual weight (e.g. chiffon ≈ 35 g/m², heavy denim ≈ 500
//!   g/m², cowhide ≈ 900 g/m²);
//! - *structural* stiffness is high for tight wovens (linen, canvas, denim), low for knits
//!   (jersey, rib, spandex) whose loops straighten before the yarn stretches;
//! - *flexion* grows steeply with thickness (bending ∝ t³): sheer silks sit near the bottom,
//!   leather, neoprene and fused trims near the top;
//! - *shear* is small for wovens (yarns scissor at the crossings) and for knits, but
//!   comparable to stretch for isotropic sheets (leather, felt, neoprene, fused interfacing);
//! - *woven anisotropy*: the warp (vertical) is usually stiffer than the weft; knits stretch
//!   most along the course (horizontal).
//!
//! Each preset's `description` gives its one-sentence rationale. The four unseen test
//! materials of the paper are present under their exact names: "Sherpa Fleece 160",
//! "Silk Duchess Satin", "Trim Fusible Rigid" and "Cashmere".

use std::str::FromStr;

use crate::error::{Error, Result};
use crate::material::bounds::{COMPONENT_NAMES, COMPONENT_UNITS, MATERIAL_DIM};
use crate::material::space::Material;
use crate::math::Real;

/// A named fabric of the library.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Preset {
    /// Display name, e.g. `"Silk Duchess Satin"`.
    pub name: &'static str,
    /// One sentence on what the fabric is and why its values are what they are.
    pub description: &'static str,
    /// Its parameters (within the standard bounds).
    pub material: Material,
}

/// The four materials the paper holds out as unseen test fabrics (§4).
pub const PAPER_TEST_MATERIALS: [&str; 4] = [
    "Sherpa Fleece 160",
    "Silk Duchess Satin",
    "Trim Fusible Rigid",
    "Cashmere",
];

/// `[structural V, structural H, flexion V, flexion H, shear]` in N/m, density in kg/m^2.
const fn p(name: &'static str, description: &'static str, v: [Real; 6]) -> Preset {
    Preset {
        name,
        description,
        material: Material {
            structural_vertical: v[0],
            structural_horizontal: v[1],
            flexion_vertical: v[2],
            flexion_horizontal: v[3],
            shear: v[4],
            density: v[5],
        },
    }
}

#[rustfmt::skip]
static PRESETS: [Preset; 40] = [
    // Sheers and silks: light, thin, drapey.
    p("Tulle", "Open hexagonal net: the mesh shears almost freely and barely resists bending; lightest of all.", [300.0, 250.0, 0.05, 0.04, 1.5, 0.025]),
    p("Silk Chiffon", "Sheer plain weave of twisted silk: very low bending and shear, ~35 g/m^2.", [400.0, 300.0, 0.03, 0.025, 2.5, 0.035]),
    p("Polyester Chiffon", "Synthetic chiffon: like silk chiffon but a little stiffer and heavier.", [600.0, 450.0, 0.05, 0.04, 4.0, 0.045]),
    p("Silk Organza", "Crisp sheer of hard-twisted filament: light yet springy, so bending is high for its weight.", [1500.0, 1200.0, 0.6, 0.5, 25.0, 0.04]),
    p("Silk Georgette", "Crepe-twisted sheer: soft, springy stretch and very fluid drape.", [250.0, 200.0, 0.06, 0.05, 3.0, 0.055]),
    p("Silk Habotai", "Smooth lightweight plain weave (lining silk): tight, so stiffer in stretch than chiffon, still very soft in bending.", [900.0, 700.0, 0.08, 0.07, 6.0, 0.04]),
    p("Silk Charmeuse", "Satin-weave silk with long floats: fluid drape, low shear, ~80 g/m^2.", [800.0, 500.0, 0.1, 0.08, 4.0, 0.08]),
    p("Crepe de Chine", "Light crepe silk: soft hand, between habotai and georgette.", [700.0, 500.0, 0.15, 0.12, 4.5, 0.06]),
    p("Silk Duchess Satin", "Heavy, tightly woven silk satin for gowns: lustrous, full-bodied, holds shape; ~200 g/m^2.", [3000.0, 2200.0, 8.0, 6.0, 60.0, 0.2]),
    p("Polyester Satin", "Mid-weight satin: smoother and softer than duchess satin, warp-faced so stiffer vertically.", [1800.0, 1300.0, 1.5, 1.2, 20.0, 0.12]),
    p("Taffeta", "Crisp plain-weave filament fabric that rustles: light but stiff in bending and stretch.", [2500.0, 2000.0, 3.0, 2.5, 40.0, 0.09]),
    // Cotton and linen wovens.
    p("Cotton Voile", "Sheer cotton plain weave: light and soft, stiffer than silk sheers in stretch.", [700.0, 550.0, 0.2, 0.18, 8.0, 0.07]),
    p("Cotton Lawn", "Fine, tightly woven cotton: crisp-light shirting.", [1200.0, 900.0, 0.5, 0.4, 12.0, 0.09]),
    p("Cotton Poplin", "Shirting with fine ribs across the weft: warp noticeably stiffer than weft.", [2500.0, 1500.0, 1.5, 1.1, 30.0, 0.12]),
    p("Cotton Oxford", "Basket-weave shirting: nearly balanced, thicker and stiffer than poplin.", [3000.0, 2500.0, 3.0, 2.6, 45.0, 0.15]),
    p("Cotton Twill", "Diagonal-weave chino cloth: firm, medium weight, ~220 g/m^2.", [4000.0, 2500.0, 5.0, 4.0, 50.0, 0.22]),
    p("Denim Light", "Shirt-weight denim (~8 oz): warp-faced twill, stiff and medium-heavy.", [5000.0, 3000.0, 10.0, 7.0, 80.0, 0.3]),
    p("Denim Heavy", "Jeans-weight denim (~14 oz): very stiff warp, thick, ~500 g/m^2.", [9000.0, 5000.0, 40.0, 28.0, 150.0, 0.5]),
    p("Canvas", "Heavy duck canvas: dense balanced plain weave, among the stiffest wovens.", [10000.0, 8000.0, 60.0, 50.0, 250.0, 0.45]),
    p("Linen", "Flax plain weave: low-elongation fibre, so high stretch stiffness and crisp shear for its weight.", [4500.0, 3500.0, 6.0, 5.0, 100.0, 0.18]),
    // Wools.
    p("Wool Crepe", "Springy crepe-twisted wool: soft stretch, fluid drape, medium weight.", [600.0, 450.0, 1.2, 1.0, 8.0, 0.2]),
    p("Wool Gabardine", "Tight steep-twill suiting: firm warp, crisp, ~260 g/m^2.", [2500.0, 1600.0, 4.0, 3.0, 35.0, 0.26]),
    p("Wool Flannel", "Brushed woollen twill: soft, lofty, heavier than gabardine, softer in stretch.", [1200.0, 900.0, 3.0, 2.5, 15.0, 0.3]),
    p("Tweed", "Thick, coarse woollen: bulky yarns give high bending and weight.", [1800.0, 1400.0, 12.0, 10.0, 30.0, 0.42]),
    p("Cashmere", "Fine soft cashmere knit: low stretch stiffness, gentle drape, medium weight.", [250.0, 180.0, 0.8, 0.7, 6.0, 0.22]),
    // Knits.
    p("Cotton Jersey", "T-shirt single jersey: loops stretch easily, most along the course (horizontal).", [120.0, 60.0, 0.3, 0.25, 5.0, 0.15]),
    p("Viscose Jersey", "Fluid rayon jersey: softer and heavier for its thickness than cotton jersey.", [70.0, 35.0, 0.1, 0.08, 3.0, 0.17]),
    p("Rib Knit", "1x1 rib for cuffs and collars: extremely stretchy across, firmer along the wales.", [100.0, 20.0, 0.5, 0.3, 4.0, 0.25]),
    p("Interlock", "Double-knit: thicker and more stable than jersey, less curl.", [180.0, 110.0, 0.6, 0.5, 8.0, 0.2]),
    p("Spandex", "Lycra-rich stretch knit: the softest stretch of the library, clings and barely bends.", [20.0, 15.0, 0.05, 0.05, 1.2, 0.19]),
    p("Sherpa Fleece 160", "Knit-backed pile fleece: soft stretch like a knit, but the thick pile resists bending and adds weight.", [150.0, 100.0, 5.0, 4.5, 10.0, 0.28]),
    p("Polar Fleece", "Brushed polyester knit: lofty, soft stretch, lighter and softer in bending than sherpa.", [200.0, 140.0, 2.0, 1.8, 12.0, 0.25]),
    // Pile wovens.
    p("Velvet", "Cut-pile woven: drapes heavily, moderate stretch, warp-faced.", [1500.0, 800.0, 2.0, 1.5, 12.0, 0.28]),
    p("Corduroy", "Wale-ribbed cut pile: the vertical wales make it much stiffer in vertical bending.", [4000.0, 1500.0, 15.0, 5.0, 60.0, 0.35]),
    // Isotropic sheets.
    p("Neoprene", "2-3 mm foam rubber laminated with jersey: stretchy but thick, so bending is very high and it is heavy.", [300.0, 280.0, 150.0, 140.0, 100.0, 0.7]),
    p("Lambskin Leather", "Thin garment leather: isotropic, so shear is comparable to stretch; supple for a leather.", [3000.0, 2500.0, 60.0, 50.0, 1500.0, 0.45]),
    p("Cowhide Leather", "Thick cowhide: very stiff in stretch, shear and bending, near the heaviest.", [12000.0, 9000.0, 500.0, 400.0, 6000.0, 0.9]),
    p("Suede", "Napped split leather: softer and more drapey than grain leather, similar weight.", [2500.0, 2000.0, 30.0, 25.0, 900.0, 0.5]),
    p("Felt", "Pressed non-woven wool: weak in stretch, no grain, and resists shear like a sheet.", [800.0, 800.0, 40.0, 40.0, 500.0, 0.35]),
    p("Trim Fusible Rigid", "Rigid fused interfacing for collars and trims: near the stiff end of every stiffness, light.", [16000.0, 14000.0, 1200.0, 1000.0, 8000.0, 0.16]),
];

/// Every preset, in library order (soft sheers first, rigid trim last).
#[must_use]
pub fn presets() -> &'static [Preset] {
    &PRESETS
}

/// The display names of every preset, in library order.
pub fn preset_names() -> impl ExactSizeIterator<Item = &'static str> {
    PRESETS.iter().map(|p| p.name)
}

/// The preset called `name`, ignoring case, spaces, hyphens and underscores
/// (`"sherpa_fleece_160"` finds `"Sherpa Fleece 160"`).
///
/// # Errors
/// [`Error::UnknownMaterial`] with the three closest preset names.
pub fn find_preset(name: &str) -> Result<&'static Preset> {
    let key = lookup_key(name);
    if let Some(p) = PRESETS.iter().find(|p| lookup_key(p.name) == key) {
        return Ok(p);
    }
    let mut ranked: Vec<(usize, usize)> = PRESETS
        .iter()
        .enumerate()
        .map(|(i, p)| (name_distance(&key, &lookup_key(p.name)), i))
        .collect();
    // Stable sort: equally close names keep library order.
    ranked.sort_by_key(|&(d, _)| d);
    Err(Error::UnknownMaterial {
        name: name.to_owned(),
        suggestions: ranked
            .iter()
            .take(3)
            .map(|&(_, i)| PRESETS[i].name.to_owned())
            .collect(),
    })
}

fn lookup_key(name: &str) -> Vec<char> {
    name.chars()
        .filter(|c| !c.is_whitespace() && *c != '-' && *c != '_')
        .flat_map(char::to_lowercase)
        .collect()
}

/// How far a typed name is from a preset key: the edit distance to the whole key, or to
/// its best-matching stretch of the same length plus one, so that "denimm" is close to
/// "denimlight" and "duchess" to "silkduchesssatin".
fn name_distance(query: &[char], key: &[char]) -> usize {
    let whole = levenshtein(query, key);
    let n = query.len().min(key.len());
    let part = (0..=key.len() - n)
        .map(|s| levenshtein(query, &key[s..s + n]))
        .min()
        .unwrap_or(whole);
    whole.min(part + 1)
}

fn levenshtein(a: &[char], b: &[char]) -> usize {
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.iter().enumerate() {
        let mut diag = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let next = (diag + usize::from(ca != cb))
                .min(row[j] + 1)
                .min(row[j + 1] + 1);
            diag = row[j + 1];
            row[j + 1] = next;
        }
    }
    row[b.len()]
}

impl Material {
    /// The preset with this name (case-, space-, hyphen- and underscore-insensitive).
    ///
    /// # Errors
    /// [`Error::UnknownMaterial`] with the three closest preset names.
    pub fn preset(name: &str) -> Result<Material> {
        find_preset(name).map(|p| p.material)
    }
}

impl FromStr for Material {
    type Err = Error;

    /// A preset name (see [`presets`]) or six comma-separated physical
    /// values in ω's order, e.g. `"1200,900,0.5,0.4,12,0.09"`; the result is validated
    /// against the standard bounds (build stress-test materials with
    /// [`Material::physical`]).
    ///
    /// # Errors
    /// [`Error::UnknownMaterial`] for an unknown name; [`Error::WrongLength`] unless there
    /// are six values; [`Error::NotANumber`] for a value that is not a number; then as
    /// [`Material::validate`].
    fn from_str(s: &str) -> Result<Self> {
        let s = s.trim();
        if !s.contains(',') {
            return Material::preset(s);
        }
        Material::from_array(six_values(s, MaterialUnits::Physical)?)
    }
}

/// The units six comma-separated material values are written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MaterialUnits {
    /// Physical values (N/m for the five stiffnesses, kg/m² for density, as
    /// [`COMPONENT_UNITS`] names them), as
    /// [`Material::from_array`] takes them.
    Physical,
    /// Normalised ω in [0, 1], as [`Material::from_normalized`] takes it.
    Normalized,
}

impl Material {
    /// Parses six comma-separated values in `units`, e.g. normalised ω
    /// `"0.5, 0.5, 0.5, 0.5, 0.5, 0.5"` (structural V/H, flexion V/H, shear, density on the
    /// library's log scale; see [`Material::to_normalized`]).
    ///
    /// ```
    /// use garmatnet_core::{Material, MaterialUnits};
    /// let m = Material::parse_values("0.5, 0.5, 0.5, 0.5, 0.5, 0.5", MaterialUnits::Normalized)?;
    /// assert!((m.to_normalized()[0] - 0.5).abs() < 1e-12);
    /// # Ok::<(), garmatnet_core::Error>(())
    /// ```
    ///
    /// # Errors
    /// [`Error::WrongLength`] unless there are six values; [`Error::NotANumber`] (naming the
    /// component) for one that does not parse; then as [`Material::from_normalized`] or
    /// [`Material::from_array`]: [`Error::OutOfRange`] / [`Error::NonFinite`] for a value
    /// outside its range or NaN.
    pub fn parse_values(text: &str, units: MaterialUnits) -> Result<Self> {
        let values = six_values(text, units)?;
        match units {
            MaterialUnits::Physical => Material::from_array(values),
            MaterialUnits::Normalized => Material::from_normalized(values),
        }
    }
}

/// Parses normalised ω (six comma-separated numbers in [0, 1], as
/// [`Material::parse_values`] reads them with [`MaterialUnits::Normalized`]) and returns the
/// six values as written, checked, for APIs that take ω itself (e.g. the predictor's
/// `predict_normalized` and `sequence_normalized`): no round trip through physical units.
///
/// # Errors
/// As [`Material::parse_values`].
pub fn parse_omega(text: &str) -> Result<[Real; MATERIAL_DIM]> {
    let values = six_values(text, MaterialUnits::Normalized)?;
    Material::from_normalized(values)?;
    Ok(values)
}

/// The six comma-separated numbers of `text`, unchecked.
fn six_values(text: &str, units: MaterialUnits) -> Result<[Real; MATERIAL_DIM]> {
    let (what, each, range, hint) = match units {
        MaterialUnits::Physical => (
            "material value list",
            "material value",
            "",
            "; give six numbers separated by commas, or a preset name",
        ),
        MaterialUnits::Normalized => (
            "normalised material ω",
            "ω component",
            " in [0, 1]",
            "; give six numbers in [0, 1] separated by commas",
        ),
    };
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != MATERIAL_DIM {
        return Err(Error::WrongLength {
            what: format!("{what} `{text}`"),
            expected: format!(
                "{MATERIAL_DIM} comma-separated numbers{range} ({})",
                COMPONENT_NAMES.join(", ")
            ),
            got: parts.len(),
        });
    }
    let mut values = [0.0; MATERIAL_DIM];
    for (i, p) in parts.iter().enumerate() {
        values[i] = p.parse::<Real>().map_err(|_| Error::NotANumber {
            what: match units {
                MaterialUnits::Physical => {
                    format!(
                        "{each} {} ({}, {})",
                        i + 1,
                        COMPONENT_NAMES[i],
                        COMPONENT_UNITS[i]
                    )
                }
                MaterialUnits::Normalized => format!("{each} {} ({})", i + 1, COMPONENT_NAMES[i]),
            },
            text: (*p).to_owned(),
            hint: hint.into(),
        })?;
    }
    Ok(values)
}

/// The material of a `--material` / `--omega` pair: `omega` (normalised ω, see
/// [`Material::parse_values`]) when given, else `material` (a preset name or six physical
/// values, see [`Material::from_str`](std::str::FromStr)), else the preset named `default`.
///
/// # Errors
/// As [`Material::parse_values`] and [`Material::from_str`](std::str::FromStr): unknown
/// names (with the closest presets), wrong counts, values out of range.
pub fn resolve_material(
    material: Option<&str>,
    omega: Option<&str>,
    default: &str,
) -> Result<Material> {
    match (omega, material) {
        (Some(o), _) => Material::parse_values(o, MaterialUnits::Normalized),
        (None, Some(m)) => m.parse::<Material>(),
        (None, None) => Material::preset(default),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::bounds::MATERIAL_DIM;

    #[test]
    fn library_is_large_and_names_are_unique() {
        assert!(PRESETS.len() >= 34);
        for (i, a) in PRESETS.iter().enumerate() {
            for b in &PRESETS[i + 1..] {
                assert_ne!(
                    lookup_key(a.name),
                    lookup_key(b.name),
                    "{} / {}",
                    a.name,
                    b.name
                );
            }
            assert!(!a.description.is_empty());
        }
    }

    #[test]
    fn every_preset_is_within_bounds() {
        for p in presets() {
            p.material
                .validate()
                .unwrap_or_else(|e| panic!("{}: {e}", p.name));
        }
    }

    #[test]
    fn paper_test_materials_are_present_by_exact_name() {
        for name in PAPER_TEST_MATERIALS {
            assert!(preset_names().any(|n| n == name), "{name} missing");
        }
    }

    #[test]
    fn presets_span_the_space() {
        for i in 0..MATERIAL_DIM {
            let n: Vec<Real> = presets()
                .iter()
                .map(|p| p.material.to_normalized()[i])
                .collect();
            let lo = n.iter().copied().fold(Real::INFINITY, Real::min);
            let hi = n.iter().copied().fold(Real::NEG_INFINITY, Real::max);
            assert!(
                hi - lo >= 0.6,
                "component {i} covers only [{lo:.3}, {hi:.3}]"
            );
        }
    }

    #[test]
    fn presets_do_not_collide() {
        for (i, a) in PRESETS.iter().enumerate() {
            let na = a.material.to_normalized();
            for b in &PRESETS[i + 1..] {
                let nb = b.material.to_normalized();
                let d = na
                    .iter()
                    .zip(nb)
                    .map(|(x, y)| (x - y).powi(2))
                    .sum::<Real>()
                    .sqrt();
                assert!(d > 0.03, "{} and {} are only {d:.4} apart", a.name, b.name);
            }
        }
    }

    #[test]
    fn ordering_follows_physics() {
        let m = |n: &str| Material::preset(n).unwrap();
        let (chiffon, denim, trim) = (m("Silk Chiffon"), m("Denim Heavy"), m("Trim Fusible Rigid"));
        assert!(chiffon.flexion_vertical < denim.flexion_vertical);
        assert!(denim.flexion_vertical < trim.flexion_vertical);
        assert!(chiffon.density < denim.density);
        assert!(m("Cotton Jersey").structural_vertical < m("Cotton Poplin").structural_vertical);
        // Woven anisotropy: warp at least as stiff as weft.
        for name in [
            "Cotton Poplin",
            "Cotton Twill",
            "Denim Light",
            "Denim Heavy",
            "Canvas",
        ] {
            assert!(
                m(name).structural_vertical > m(name).structural_horizontal,
                "{name}"
            );
        }
    }

    #[test]
    fn lookup_ignores_case_spaces_hyphens_underscores() {
        let want = Material::preset("Sherpa Fleece 160").unwrap();
        for alias in [
            "sherpa_fleece_160",
            "SHERPA-FLEECE-160",
            "sherpafleece160",
            " Sherpa  Fleece_160 ",
        ] {
            assert_eq!(Material::preset(alias).unwrap(), want, "{alias}");
        }
        assert_eq!(
            "silk-duchess-satin".parse::<Material>().unwrap(),
            Material::preset("Silk Duchess Satin").unwrap()
        );
    }

    #[test]
    fn typo_gets_close_suggestions() {
        match find_preset("denimm").unwrap_err() {
            Error::UnknownMaterial { name, suggestions } => {
                assert_eq!(name, "denimm");
                assert_eq!(suggestions.len(), 3);
                assert!(
                    suggestions[..2].iter().all(|s| s.starts_with("Denim")),
                    "{suggestions:?}"
                );
            }
            other => panic!("expected UnknownMaterial, got {other:?}"),
        }
        match find_preset("cashmeer").unwrap_err() {
            Error::UnknownMaterial { suggestions, .. } => assert_eq!(suggestions[0], "Cashmere"),
            other => panic!("{other:?}"),
        }
        match find_preset("duchess").unwrap_err() {
            Error::UnknownMaterial { suggestions, .. } => {
                assert_eq!(suggestions[0], "Silk Duchess Satin")
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn levenshtein_basics() {
        let l = |a: &str, b: &str| levenshtein(&lookup_key(a), &lookup_key(b));
        assert_eq!(l("kitten", "sitting"), 3);
        assert_eq!(l("", "abc"), 3);
        assert_eq!(l("felt", "felt"), 0);
    }

    #[test]
    fn omega_round_trips_and_bad_omega_says_what_to_fix() {
        let omega = |t: &str| Material::parse_values(t, MaterialUnits::Normalized);
        let m = omega("0.1,0.2,0.3,0.4,0.5,0.6").expect("valid ω");
        let n = m.to_normalized();
        for (k, want) in [0.1, 0.2, 0.3, 0.4, 0.5, 0.6].iter().enumerate() {
            assert!((n[k] - want).abs() < 1e-9, "component {k}: {}", n[k]);
        }
        let few = omega("0.1,0.2").expect_err("two numbers");
        assert!(matches!(few, Error::WrongLength { got: 2, .. }), "{few}");
        assert!(
            few.to_string()
                .contains("6 comma-separated numbers in [0, 1]"),
            "{few}"
        );
        let word = omega("0.1,0.2,x,0.4,0.5,0.6").expect_err("not a number");
        assert!(
            matches!(&word, Error::NotANumber { what, text, .. }
                if what.starts_with("ω component 3") && text == "x"),
            "{word}"
        );
        assert!(omega("0.1,0.2,1.5,0.4,0.5,0.6").is_err());
        assert!(omega("0.1,0.2,NaN,0.4,0.5,0.6").is_err());
    }

    #[test]
    fn omega_parses_to_the_values_written() -> anyhow::Result<()> {
        let text = "0.1, 0.25, 0.3333333333333333, 0.4, 0.5, 0.6";
        assert_eq!(
            parse_omega(text)?,
            [0.1, 0.25, 0.3333333333333333, 0.4, 0.5, 0.6]
        );
        assert!(matches!(
            parse_omega("0.1,0.2,1.5,0.4,0.5,0.6"),
            Err(Error::OutOfRange { .. })
        ));
        assert!(matches!(
            parse_omega("0.1,0.2"),
            Err(Error::WrongLength { got: 2, .. })
        ));
        Ok(())
    }

    #[test]
    fn materials_resolve_from_omega_names_values_or_the_default() -> anyhow::Result<()> {
        let silk = Material::preset("Silk Chiffon")?;
        assert_eq!(resolve_material(None, None, "silk chiffon")?, silk);
        assert_eq!(
            resolve_material(Some("Silk Chiffon"), None, "denim heavy")?,
            silk
        );
        let from_values = resolve_material(Some(&silk.to_string()), None, "denim heavy")?;
        assert_eq!(from_values, silk);
        let omega = "0.5,0.5,0.5,0.5,0.5,0.5";
        assert_eq!(
            resolve_material(Some("Silk Chiffon"), Some(omega), "x")?,
            Material::parse_values(omega, MaterialUnits::Normalized)?,
            "ω wins over a name"
        );
        let err = resolve_material(Some("sillk chifon"), None, "x").expect_err("typo");
        assert!(
            matches!(&err, Error::UnknownMaterial { suggestions, .. }
                if suggestions.iter().any(|s| s == "Silk Chiffon")),
            "{err}"
        );
        Ok(())
    }
}
