//! Rectangular mass-spring sheets with Provot's five spring kinds, for tests, benches and
//! examples.

use garmatnet_core::{Real, Vec3};
use serde::{Deserialize, Serialize};

use crate::error::Result;
use crate::solver::cloth_model::{ClothModel, SpringSpec};

/// Spring stiffnesses of a sheet (N/m), per Provot kind.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SheetStiffness {
    /// Structural springs along the rows (x).
    pub structural_warp: Real,
    /// Structural springs along the columns (z).
    pub structural_weft: Real,
    /// Both diagonals of every quad.
    pub shear: Real,
    /// Skip-one flexion springs along the rows.
    pub flexion_warp: Real,
    /// Skip-one flexion springs along the columns.
    pub flexion_weft: Real,
}

impl SheetStiffness {
    /// Every stiffness multiplied by `factor`.
    #[must_use]
    pub fn scaled(self, factor: Real) -> Self {
        Self {
            structural_warp: self.structural_warp * factor,
            structural_weft: self.structural_weft * factor,
            shear: self.shear * factor,
            flexion_warp: self.flexion_warp * factor,
            flexion_weft: self.flexion_weft * factor,
        }
    }
}

/// A flat `columns x rows` sheet in the x-z plane (y = 0), centred on the origin, with
/// vertex `r * columns + c` at `(c, r)`; vertex masses share `areal_density` (kg/m^2) by
/// the area each vertex covers.
///
/// # Errors
/// As [`ClothModel::new`] (non-positive density or stiffness, non-finite values);
/// [`garmatnet_core::Error::OutOfRange`] for fewer than 3 columns or rows or a
/// non-positive spacing.
pub fn grid_sheet(
    columns: usize,
    rows: usize,
    spacing: Real,
    areal_density: Real,
    stiffness: SheetStiffness,
) -> Result<ClothModel> {
    for (what, v) in [("sheet columns", columns), ("sheet rows", rows)] {
        if v < 3 {
            return Err(garmatnet_core::Error::OutOfRange {
                what: what.into(),
                value: v as Real,
                min: 3.0,
                max: Real::MAX,
                hint: "; flexion springs need three vertices in a line".into(),
            }
            .into());
        }
    }
    if spacing.is_nan() || spacing <= 0.0 {
        return Err(garmatnet_core::Error::OutOfRange {
            what: "sheet spacing (metres)".into(),
            value: spacing,
            min: Real::MIN_POSITIVE,
            max: Real::MAX,
            hint: String::new(),
        }
        .into());
    }
    let index = |c: usize, r: usize| r * columns + c;
    let half_w = 0.5 * spacing * (columns - 1) as Real;
    let half_d = 0.5 * spacing * (rows - 1) as Real;
    let mut positions = Vec::with_capacity(columns * rows);
    let mut masses = Vec::with_capacity(columns * rows);
    for r in 0..rows {
        for c in 0..columns {
            positions.push(Vec3::new(
                c as Real * spacing - half_w,
                0.0,
                r as Real * spacing - half_d,
            ));
            let edge_c = if c == 0 || c == columns - 1 { 0.5 } else { 1.0 };
            let edge_r = if r == 0 || r == rows - 1 { 0.5 } else { 1.0 };
            masses.push(areal_density * spacing * spacing * edge_c * edge_r);
        }
    }
    let mut springs = Vec::new();
    let mut add = |a: usize, b: usize, k: Real| {
        let rest_length = (positions[a] - positions[b]).norm();
        springs.push(SpringSpec {
            a,
            b,
            rest_length,
            stiffness: k,
        });
    };
    for r in 0..rows {
        for c in 0..columns {
            let v = index(c, r);
            if c + 1 < columns {
                add(v, index(c + 1, r), stiffness.structural_warp);
            }
            if r + 1 < rows {
                add(v, index(c, r + 1), stiffness.structural_weft);
            }
            if c + 1 < columns && r + 1 < rows {
                add(v, index(c + 1, r + 1), stiffness.shear);
                add(index(c + 1, r), index(c, r + 1), stiffness.shear);
            }
            if c + 2 < columns {
                add(v, index(c + 2, r), stiffness.flexion_warp);
            }
            if r + 2 < rows {
                add(v, index(c, r + 2), stiffness.flexion_weft);
            }
        }
    }
    ClothModel::new(&positions, &springs, &masses)
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn sheet_has_provots_spring_counts_and_mass() {
        let k = SheetStiffness {
            structural_warp: 1.0,
            structural_weft: 2.0,
            shear: 3.0,
            flexion_warp: 4.0,
            flexion_weft: 5.0,
        };
        let (c, r) = (5, 4);
        let m = grid_sheet(c, r, 0.1, 0.2, k).unwrap();
        let expected =
            r * (c - 1) + c * (r - 1) + 2 * (c - 1) * (r - 1) + r * (c - 2) + c * (r - 2);
        assert_eq!(m.springs().len(), expected);
        assert_relative_eq!(m.total_mass(), 0.2 * 0.4 * 0.3, epsilon = 1e-12);
    }
}
