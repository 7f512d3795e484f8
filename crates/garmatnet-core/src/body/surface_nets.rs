//! Naive surface nets: a closed triangle mesh of a signed distance field's zero level set.
//!
//! One vertex per grid cell that the surface crosses (the mean of its edges' crossings,
//! then pulled onto the surface along the gradient), one quad per grid edge that the surface
//! crosses. Unlike marching cubes this needs no case table, and the quads are well shaped.

use crate::body::sdf::SignedDistance;
use crate::error::{Error, Result};
use crate::math::{Real, Vec3};
use crate::mesh::TriMesh;

/// The most grid points one extraction may use (about 1 GiB of samples).
pub(crate) const MAX_GRID_POINTS: usize = 1 << 27;

/// Extracts the zero level set of `sdf` inside the box `[min, max]` (metres) on a cubic grid
/// of `spacing` (metres). Faces are counter-clockwise seen from outside (where the distance
/// is positive).
///
/// The grid extends two cells past the box on every side, so a surface inside the box gives
/// a closed mesh. `sdf` must be a distance bound (|gradient| ≤ 1), which lets the sampler
/// skip grid points far from the surface.
///
/// # Errors
/// [`Error::OutOfRange`] for a spacing that is not positive or a grid past 2^27 points;
/// [`Error::InvalidBox`] for an empty or non-finite box; [`Error::InvalidMesh`] if
/// the surface reaches the grid's boundary (the box does not enclose it).
pub fn surface_nets<S: SignedDistance + ?Sized>(
    sdf: &S,
    min: &Vec3,
    max: &Vec3,
    spacing: Real,
) -> Result<TriMesh> {
    let grid = Grid::new(min, max, spacing)?;
    let values = grid.sample(sdf);
    let (vertices, cell_vertex) = grid.cell_vertices(sdf, &values);
    let faces = grid.faces(&values, &cell_vertex)?;
    TriMesh::new(vertices, faces)
}

struct Grid {
    origin: Vec3,
    spacing: Real,
    dims: [usize; 3],
}

impl Grid {
    fn new(min: &Vec3, max: &Vec3, spacing: Real) -> Result<Self> {
        if !(spacing.is_finite() && spacing > 0.0) {
            return Err(Error::OutOfRange {
                what: "surface-nets grid spacing (metres)".into(),
                value: spacing,
                min: f64::MIN_POSITIVE,
                max: f64::INFINITY,
                hint: "; use a positive spacing such as 0.01".into(),
            });
        }
        if (0..3).any(|a| !(min[a].is_finite() && max[a].is_finite() && min[a] < max[a])) {
            return Err(Error::InvalidBox {
                min: [min.x, min.y, min.z],
                max: [max.x, max.y, max.z],
            });
        }
        let margin = 2.0 * spacing;
        let origin = min - Vec3::repeat(margin);
        let dims: [usize; 3] =
            std::array::from_fn(|a| ((max[a] - min[a]) / spacing).ceil() as usize + 5);
        let points = dims
            .iter()
            .try_fold(1usize, |acc, &n| acc.checked_mul(n))
            .unwrap_or(usize::MAX);
        if points > MAX_GRID_POINTS {
            return Err(Error::OutOfRange {
                what: "surface-nets grid points".into(),
                value: points as f64,
                min: 1.0,
                max: MAX_GRID_POINTS as f64,
                hint: "; use a coarser spacing or a smaller box".into(),
            });
        }
        Ok(Self {
            origin,
            spacing,
            dims,
        })
    }

    fn index(&self, i: usize, j: usize, k: usize) -> usize {
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    fn point(&self, i: usize, j: usize, k: usize) -> Vec3 {
        self.origin + Vec3::new(i as Real, j as Real, k as Real) * self.spacing
    }

    /// Samples the field at every grid point. Far from the surface only the sign matters
    /// (no crossing can touch the point's cells), so a distance bound lets a row skip ahead:
    /// points within `|d| - cell diagonal` of a sample get that sign and a magnitude that
    /// still exceeds the cell diagonal.
    fn sample<S: SignedDistance + ?Sized>(&self, sdf: &S) -> Vec<Real> {
        let [nx, ny, nz] = self.dims;
        let diagonal = self.spacing * 3f64.sqrt();
        let mut values = vec![0.0; nx * ny * nz];
        for k in 0..nz {
            for j in 0..ny {
                let row = self.index(0, j, k);
                let mut i = 0;
                while i < nx {
                    let d = sdf.distance(&self.point(i, j, k));
                    values[row + i] = d;
                    let skip = ((d.abs() - diagonal) / self.spacing).floor().max(0.0) as usize;
                    for m in 1..=skip.min(nx - 1 - i) {
                        values[row + i + m] = d.signum() * (d.abs() - m as Real * self.spacing);
                    }
                    i += skip + 1;
                }
            }
        }
        values
    }

    /// One vertex per cell with corners on both sides of the surface (`u32::MAX` for the
    /// other cells, indexed like grid points).
    fn cell_vertices<S: SignedDistance + ?Sized>(
        &self,
        sdf: &S,
        values: &[Real],
    ) -> (Vec<Vec3>, Vec<u32>) {
        let [nx, ny, nz] = self.dims;
        let mut cell_vertex = vec![u32::MAX; nx * ny * nz];
        let mut vertices = Vec::new();
        let corner_offset = |c: usize| (c & 1, (c >> 1) & 1, (c >> 2) & 1);
        for k in 0..nz - 1 {
            for j in 0..ny - 1 {
                for i in 0..nx - 1 {
                    let corner_values: [Real; 8] = std::array::from_fn(|c| {
                        let (di, dj, dk) = corner_offset(c);
                        values[self.index(i + di, j + dj, k + dk)]
                    });
                    let inside = corner_values.iter().filter(|v| **v < 0.0).count();
                    if inside == 0 || inside == 8 {
                        continue;
                    }
                    let mut sum = Vec3::zeros();
                    let mut crossings = 0.0;
                    for c in 0..8 {
                        for bit in 0..3 {
                            let e = c | (1 << bit);
                            if e == c || (corner_values[c] < 0.0) == (corner_values[e] < 0.0) {
                                continue;
                            }
                            let t = corner_values[c] / (corner_values[c] - corner_values[e]);
                            let (ci, cj, ck) = corner_offset(c);
                            let mut local = Vec3::new(ci as Real, cj as Real, ck as Real);
                            local[bit] += t;
                            sum += local;
                            crossings += 1.0;
                        }
                    }
                    let cell_origin = self.point(i, j, k);
                    let guess = cell_origin + sum / crossings * self.spacing;
                    cell_vertex[self.index(i, j, k)] = vertices.len() as u32;
                    vertices.push(pull_onto_surface(sdf, guess, self.spacing));
                }
            }
        }
        (vertices, cell_vertex)
    }

    /// Two triangles per crossed grid edge, joining the four cells around it, wound so the
    /// normal points from the inside end of the edge to the outside end.
    fn faces(&self, values: &[Real], cell_vertex: &[u32]) -> Result<Vec<[u32; 3]>> {
        let [nx, ny, nz] = self.dims;
        let mut faces = Vec::new();
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let here = [i, j, k];
                    let inside = values[self.index(i, j, k)] < 0.0;
                    for axis in 0..3 {
                        if here[axis] + 1 >= self.dims[axis] {
                            continue;
                        }
                        let mut next = here;
                        next[axis] += 1;
                        if inside == (values[self.index(next[0], next[1], next[2])] < 0.0) {
                            continue;
                        }
                        // (u, v, axis) is right-handed, so cells listed counter-clockwise
                        // in (u, v) face +axis.
                        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
                        if here[u] == 0
                            || here[v] == 0
                            || here[u] + 1 >= self.dims[u]
                            || here[v] + 1 >= self.dims[v]
                        {
                            return Err(Error::InvalidMesh(
                                "the surface reaches the surface-nets grid boundary; enlarge the box".into(),
                            ));
                        }
                        let quad = [(1, 1), (0, 1), (0, 0), (1, 0)].map(|(du, dv)| {
                            let mut c = here;
                            c[u] -= du;
                            c[v] -= dv;
                            cell_vertex[self.index(c[0], c[1], c[2])]
                        });
                        let [q0, q1, q2, q3] = if inside {
                            quad
                        } else {
                            [quad[3], quad[2], quad[1], quad[0]]
                        };
                        faces.push([q0, q1, q2]);
                        faces.push([q0, q2, q3]);
                    }
                }
            }
        }
        Ok(faces)
    }
}

/// Two Newton steps along the normal, kept only if they stay near the cell (a guard
/// against creases where the gradient jumps).
fn pull_onto_surface<S: SignedDistance + ?Sized>(sdf: &S, guess: Vec3, spacing: Real) -> Vec3 {
    let mut p = guess;
    for _ in 0..2 {
        let (d, n) = sdf.distance_and_normal(&p);
        p -= n * d;
    }
    if (p - guess).norm() <= spacing {
        p
    } else {
        guess
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::sdf::Sphere;
    use std::collections::HashMap;

    /// How many faces use each undirected edge, and whether every directed edge appears once.
    pub(crate) fn edge_face_counts(mesh: &TriMesh) -> (HashMap<(u32, u32), usize>, bool) {
        let mut counts = HashMap::new();
        let mut directed = HashMap::new();
        for f in &mesh.faces {
            for e in 0..3 {
                let (a, b) = (f[e], f[(e + 1) % 3]);
                *counts.entry((a.min(b), a.max(b))).or_insert(0) += 1;
                *directed.entry((a, b)).or_insert(0) += 1;
            }
        }
        let consistent = directed.values().all(|&c| c == 1);
        (counts, consistent)
    }

    #[test]
    fn sphere_mesh_is_closed_outward_and_on_the_surface() {
        let sphere = Sphere {
            centre: Vec3::new(0.1, -0.2, 0.05),
            radius: 0.3,
        };
        let lo = sphere.centre - Vec3::repeat(0.3);
        let hi = sphere.centre + Vec3::repeat(0.3);
        let mesh = surface_nets(&sphere, &lo, &hi, 0.03).unwrap();
        assert!(mesh.face_count() > 500);
        let (counts, consistent) = edge_face_counts(&mesh);
        assert!(counts.values().all(|&c| c == 2));
        assert!(consistent, "neighbouring faces must be wound consistently");
        // Euler characteristic of a sphere.
        let chi = mesh.vertex_count() as i64 - counts.len() as i64 + mesh.face_count() as i64;
        assert_eq!(chi, 2);
        for v in &mesh.vertices {
            assert!(sphere.distance(v).abs() < 1e-6);
        }
        for f in &mesh.faces {
            let [a, b, c] = f.map(|i| mesh.vertices[i as usize]);
            let normal = (b - a).cross(&(c - a));
            assert!(
                normal.dot(&((a + b + c) / 3.0 - sphere.centre)) > 0.0,
                "inward face {f:?}"
            );
        }
    }

    #[test]
    fn surface_outside_the_box_is_an_error() {
        let sphere = Sphere {
            centre: Vec3::zeros(),
            radius: 0.75,
        };
        let err = surface_nets(&sphere, &Vec3::repeat(-0.5), &Vec3::repeat(0.5), 0.1);
        assert!(matches!(err, Err(Error::InvalidMesh(_))));
    }

    #[test]
    fn bad_arguments_are_rejected() {
        let sphere = Sphere {
            centre: Vec3::zeros(),
            radius: 0.1,
        };
        let (lo, hi) = (Vec3::repeat(-0.2), Vec3::repeat(0.2));
        assert!(surface_nets(&sphere, &lo, &hi, 0.0).is_err());
        assert!(surface_nets(&sphere, &hi, &lo, 0.01).is_err());
        assert!(surface_nets(&sphere, &lo, &hi, 1e-5).is_err());
    }
}
