//! Provot's mass-spring network on the garment's pattern grid (paper §3.1, Figure 2).

use std::collections::HashSet;

use serde::{Deserialize, Serialize};

use crate::garment::pattern::{GridPoint, PanelGrid};
use crate::math::{Real, Vec3};

/// The kind of a cloth spring, after Provot (1995). Each kind has its own stiffness in the
/// material space (structural and flexion per direction, shear shared).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SpringKind {
    /// Neighbours along `v` (warp, vertical).
    StructuralVertical,
    /// Neighbours along `u` (weft, horizontal).
    StructuralHorizontal,
    /// Both diagonals of each grid quad.
    Shear,
    /// Every other vertex along `v` (resists bending about horizontal lines).
    FlexionVertical,
    /// Every other vertex along `u` (resists bending about vertical lines).
    FlexionHorizontal,
}

impl SpringKind {
    /// All kinds, in declaration order.
    pub const ALL: [SpringKind; 5] = [
        SpringKind::StructuralVertical,
        SpringKind::StructuralHorizontal,
        SpringKind::Shear,
        SpringKind::FlexionVertical,
        SpringKind::FlexionHorizontal,
    ];

    /// A stable small code (used by template hashes).
    #[must_use]
    pub fn code(self) -> u8 {
        match self {
            SpringKind::StructuralVertical => 0,
            SpringKind::StructuralHorizontal => 1,
            SpringKind::Shear => 2,
            SpringKind::FlexionVertical => 3,
            SpringKind::FlexionHorizontal => 4,
        }
    }
}

/// A spring between two garment vertices.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Spring {
    /// First vertex index.
    pub a: u32,
    /// Second vertex index (`a != b`).
    pub b: u32,
    /// Natural length (metres): the distance in the garment's rest shape.
    pub rest_length: Real,
    /// Which stiffness the spring takes.
    pub kind: SpringKind,
}

/// Builds the springs of both panels.
///
/// Structural and shear springs follow the panels' grid edges and quad diagonals; welded
/// seam edges are shared, so each is one spring. Flexion springs skip one vertex along a
/// grid line and continue across a seam into the other panel (the seam vertex is the middle
/// one: the grid line folds over the seam), so the cloth resists bending at the seams as
/// elsewhere. Nothing connects across an opening: every spring's grid path is cloth.
pub(crate) fn provot_springs(grid: &PanelGrid, vertices: &[Vec3]) -> Vec<Spring> {
    let mut builder = SpringBuilder {
        vertices,
        seen: HashSet::new(),
        springs: Vec::new(),
    };
    for side in 0..2 {
        for j in 0..=grid.jt {
            for i in -grid.ic..=grid.ic {
                let p = (i, j);
                let Some(pv) = grid.vertex(side, p) else {
                    continue;
                };
                for (q, kind) in [
                    ((i + 1, j), SpringKind::StructuralHorizontal),
                    ((i, j + 1), SpringKind::StructuralVertical),
                ] {
                    if grid.has_edge(side, p, q) {
                        builder.add(pv, grid.vertex(side, q), kind);
                    }
                }
                if grid.has_cell(side, p) {
                    let corner = |q| grid.vertex(side, q);
                    builder.add(pv, corner((i + 1, j + 1)), SpringKind::Shear);
                    if let Some(a) = corner((i + 1, j)) {
                        builder.add(a, corner((i, j + 1)), SpringKind::Shear);
                    }
                }
                for (step, kind) in [
                    ((1, 0), SpringKind::FlexionHorizontal),
                    ((0, 1), SpringKind::FlexionVertical),
                ] {
                    let mid = (i + step.0, j + step.1);
                    let far = (i + 2 * step.0, j + 2 * step.1);
                    if grid.has_edge(side, p, mid) && grid.has_edge(side, mid, far) {
                        builder.add(pv, grid.vertex(side, far), kind);
                    }
                }
                // Fold over a seam: p - mid is cloth in this panel, mid sits on a seam that
                // crosses the line, and the line continues back from mid in the other panel.
                for (step, kind) in [
                    ((1, 0), SpringKind::FlexionHorizontal),
                    ((-1, 0), SpringKind::FlexionHorizontal),
                    ((0, 1), SpringKind::FlexionVertical),
                    ((0, -1), SpringKind::FlexionVertical),
                ] {
                    let mid = (i + step.0, j + step.1);
                    let beyond = (mid.0 + step.0, mid.1 + step.1);
                    let other = 1 - side;
                    if grid.has_edge(side, p, mid)
                        && !grid.has_edge(side, mid, beyond)
                        && seam_crosses(grid, mid, step)
                        && grid.has_edge(other, mid, p)
                        && !grid.is_seam_edge(p, mid)
                    {
                        builder.add(pv, grid.vertex(other, p), kind);
                    }
                }
            }
        }
    }
    builder.springs
}

/// Whether a seam edge at `point` runs across the grid direction `step`.
fn seam_crosses(grid: &PanelGrid, (i, j): GridPoint, step: GridPoint) -> bool {
    let (di, dj) = (step.1.abs(), step.0.abs());
    grid.is_seam_edge((i, j), (i + di, j + dj)) || grid.is_seam_edge((i - di, j - dj), (i, j))
}

struct SpringBuilder<'a> {
    vertices: &'a [Vec3],
    seen: HashSet<(u32, u32)>,
    springs: Vec<Spring>,
}

impl SpringBuilder<'_> {
    fn add(&mut self, a: u32, b: Option<u32>, kind: SpringKind) {
        let Some(b) = b else { return };
        if a == b || !self.seen.insert((a.min(b), a.max(b))) {
            return;
        }
        let rest_length = (self.vertices[a as usize] - self.vertices[b as usize]).norm();
        if rest_length > 0.0 {
            self.springs.push(Spring {
                a,
                b,
                rest_length,
                kind,
            });
        }
    }
}
