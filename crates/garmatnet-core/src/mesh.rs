//! Indexed triangle meshes and their derived geometry and topology.
//!
//! Topology (edges, adjacency, boundary loops) depends only on the faces, so callers that
//! process thousands of shapes of one garment compute it once and keep it. The per-shape
//! quantities (normals, areas) come in two flavours: a convenience method on the mesh's own
//! vertices, and an `_into` form that takes any positions with the mesh's topology and
//! writes into a caller-owned buffer, so a hot loop allocates nothing.

use std::collections::HashMap;

use crate::error::{Error, Result};
use crate::math::{Real, Vec3};

/// An indexed triangle mesh: vertex positions (metres) and counter-clockwise faces.
#[derive(Debug, Clone, PartialEq)]
pub struct TriMesh {
    /// Vertex positions.
    pub vertices: Vec<Vec3>,
    /// Triangles as vertex indices, counter-clockwise seen from outside.
    pub faces: Vec<[u32; 3]>,
}

impl TriMesh {
    /// A mesh from vertices and faces, checked.
    ///
    /// # Errors
    /// [`Error::InvalidMesh`] if a face indexes past the vertices or repeats a vertex;
    /// [`Error::NonFinite`] if a vertex is NaN or infinite.
    pub fn new(vertices: Vec<Vec3>, faces: Vec<[u32; 3]>) -> Result<Self> {
        crate::error::ensure_finite(
            "mesh vertex coordinates",
            vertices.iter().flat_map(|v| [v.x, v.y, v.z]),
        )?;
        let n = vertices.len();
        for (f, face) in faces.iter().enumerate() {
            if let Some(bad) = face.iter().find(|&&i| i as usize >= n) {
                return Err(Error::InvalidMesh(format!(
                    "face {f} uses vertex {bad}, but the mesh has only {n} vertices"
                )));
            }
            if face[0] == face[1] || face[1] == face[2] || face[0] == face[2] {
                return Err(Error::InvalidMesh(format!(
                    "face {f} repeats a vertex: {face:?}"
                )));
            }
        }
        Ok(Self { vertices, faces })
    }

    /// The number of vertices.
    #[must_use]
    pub fn vertex_count(&self) -> usize {
        self.vertices.len()
    }

    /// The number of triangles.
    #[must_use]
    pub fn face_count(&self) -> usize {
        self.faces.len()
    }

    /// Checks that `positions` has one entry per vertex of this mesh.
    fn check_positions(&self, positions: &[Vec3]) -> Result<()> {
        if positions.len() == self.vertices.len() {
            Ok(())
        } else {
            Err(Error::Mismatch {
                what: "positions for the mesh's topology (one per vertex)".to_owned(),
                expected: format!("{} positions", self.vertices.len()),
                got: format!("{} positions", positions.len()),
            })
        }
    }

    /// Twice-area-weighted face normals `(b - a) x (c - a)` of `positions`, unnormalised:
    /// the building block of normals and areas.
    fn face_cross(positions: &[Vec3], face: &[u32; 3]) -> Vec3 {
        let [a, b, c] = face.map(|i| positions[i as usize]);
        (b - a).cross(&(c - a))
    }

    /// Unit face normals (counter-clockwise faces point outward); a degenerate (zero-area)
    /// face gets the zero vector.
    ///
    /// # Shapes
    /// Returns `[face_count]`.
    #[must_use]
    pub fn face_normals(&self) -> Vec<Vec3> {
        let mut out = Vec::new();
        self.face_normals_into(&self.vertices, &mut out)
            .expect("own vertices match");
        out
    }

    /// [`Self::face_normals`] of `positions` (a shape with this mesh's topology), written
    /// into `out` (resized; no allocation once it has the capacity).
    ///
    /// # Shapes
    /// `positions`: `[vertex_count]`; `out`: `[face_count]`.
    ///
    /// # Errors
    /// [`Error::Mismatch`] if `positions` does not have one entry per vertex.
    pub fn face_normals_into(&self, positions: &[Vec3], out: &mut Vec<Vec3>) -> Result<()> {
        self.check_positions(positions)?;
        out.clear();
        out.extend(self.faces.iter().map(|f| {
            let n = Self::face_cross(positions, f);
            n.try_normalize(0.0).unwrap_or_else(Vec3::zeros)
        }));
        Ok(())
    }

    /// Face areas (square metres).
    ///
    /// # Shapes
    /// Returns `[face_count]`.
    #[must_use]
    pub fn face_areas(&self) -> Vec<Real> {
        let mut out = Vec::new();
        self.face_areas_into(&self.vertices, &mut out)
            .expect("own vertices match");
        out
    }

    /// [`Self::face_areas`] of `positions`, written into `out`.
    ///
    /// # Shapes
    /// `positions`: `[vertex_count]`; `out`: `[face_count]`.
    ///
    /// # Errors
    /// [`Error::Mismatch`] if `positions` does not have one entry per vertex.
    pub fn face_areas_into(&self, positions: &[Vec3], out: &mut Vec<Real>) -> Result<()> {
        self.check_positions(positions)?;
        out.clear();
        out.extend(
            self.faces
                .iter()
                .map(|f| 0.5 * Self::face_cross(positions, f).norm()),
        );
        Ok(())
    }

    /// Area-weighted unit vertex normals: the normalised sum of the incident faces' normals
    /// weighted by their areas. A vertex with no (non-degenerate) face gets the zero vector.
    ///
    /// # Shapes
    /// Returns `[vertex_count]`.
    #[must_use]
    pub fn vertex_normals(&self) -> Vec<Vec3> {
        let mut out = Vec::new();
        self.vertex_normals_into(&self.vertices, &mut out)
            .expect("own vertices match");
        out
    }

    /// [`Self::vertex_normals`] of `positions`, written into `out`.
    ///
    /// # Shapes
    /// `positions`: `[vertex_count]`; `out`: `[vertex_count]`.
    ///
    /// # Errors
    /// [`Error::Mismatch`] if `positions` does not have one entry per vertex.
    pub fn vertex_normals_into(&self, positions: &[Vec3], out: &mut Vec<Vec3>) -> Result<()> {
        self.check_positions(positions)?;
        out.clear();
        out.resize(positions.len(), Vec3::zeros());
        for f in &self.faces {
            // The unnormalised cross product is already area-weighted (its length is twice
            // the area), which is exactly the weighting wanted.
            let n = Self::face_cross(positions, f);
            for &v in f {
                out[v as usize] += n;
            }
        }
        for n in out.iter_mut() {
            *n = n.try_normalize(0.0).unwrap_or_else(Vec3::zeros);
        }
        Ok(())
    }

    /// Lumped vertex areas (square metres): a third of the area of every incident face.
    /// They sum to the total surface area; the solver multiplies them by the fabric's areal
    /// density (kg/m^2) to get vertex masses.
    ///
    /// # Shapes
    /// Returns `[vertex_count]`.
    #[must_use]
    pub fn vertex_areas(&self) -> Vec<Real> {
        let mut out = Vec::new();
        self.vertex_areas_into(&self.vertices, &mut out)
            .expect("own vertices match");
        out
    }

    /// [`Self::vertex_areas`] of `positions`, written into `out`.
    ///
    /// # Shapes
    /// `positions`: `[vertex_count]`; `out`: `[vertex_count]`.
    ///
    /// # Errors
    /// [`Error::Mismatch`] if `positions` does not have one entry per vertex.
    pub fn vertex_areas_into(&self, positions: &[Vec3], out: &mut Vec<Real>) -> Result<()> {
        self.check_positions(positions)?;
        out.clear();
        out.resize(positions.len(), 0.0);
        for f in &self.faces {
            let third = Self::face_cross(positions, f).norm() / 6.0;
            for &v in f {
                out[v as usize] += third;
            }
        }
        Ok(())
    }

    /// The total surface area (square metres).
    #[must_use]
    pub fn area(&self) -> Real {
        self.faces
            .iter()
            .map(|f| 0.5 * Self::face_cross(&self.vertices, f).norm())
            .sum()
    }

    /// Every undirected edge once, as `[low, high]` vertex indices, sorted.
    #[must_use]
    pub fn edges(&self) -> Vec<[u32; 2]> {
        let mut edges: Vec<[u32; 2]> = self
            .faces
            .iter()
            .flat_map(|&[a, b, c]| [[a, b], [b, c], [c, a]])
            .map(|[i, j]| [i.min(j), i.max(j)])
            .collect();
        edges.sort_unstable();
        edges.dedup();
        edges
    }

    /// The vertex adjacency (vertices sharing an edge), as a compact CSR table.
    #[must_use]
    pub fn adjacency(&self) -> Adjacency {
        Adjacency::from_edges(self.vertices.len(), &self.edges())
    }

    /// The boundary edges: edges used by exactly one face, oriented as in that face (so on a
    /// consistently oriented mesh they run counter-clockwise around the surface's holes seen
    /// from outside). Sorted by their first, then second vertex.
    #[must_use]
    pub fn boundary_edges(&self) -> Vec<[u32; 2]> {
        // Count each undirected edge and remember one orientation; an edge used once is on
        // the boundary. Sorting keeps this allocation-light and deterministic.
        let mut directed: Vec<([u32; 2], [u32; 2])> = self
            .faces
            .iter()
            .flat_map(|&[a, b, c]| [[a, b], [b, c], [c, a]])
            .map(|e| ([e[0].min(e[1]), e[0].max(e[1])], e))
            .collect();
        directed.sort_unstable();
        let mut out = Vec::new();
        let mut k = 0;
        while k < directed.len() {
            let mut end = k + 1;
            while end < directed.len() && directed[end].0 == directed[k].0 {
                end += 1;
            }
            if end - k == 1 {
                out.push(directed[k].1);
            }
            k = end;
        }
        out.sort_unstable();
        out
    }

    /// The boundary as ordered loops of vertex indices (the garment's openings: neck, hem,
    /// cuffs). Each loop is closed (its last vertex connects back to its first) and follows
    /// the orientation of [`Self::boundary_edges`]. Loops are ordered by their smallest
    /// starting vertex, each starting at its smallest vertex, so the result is deterministic.
    ///
    /// On a broken mesh (non-manifold or inconsistently oriented boundary) a chain that cannot
    /// be closed is returned as it was walked; a vertex where several loops touch appears in
    /// each of them.
    #[must_use]
    pub fn boundary_loops(&self) -> Vec<Vec<u32>> {
        let edges = self.boundary_edges();
        // Undirected incidence of boundary edges per vertex, so that an inconsistently
        // oriented boundary still forms loops; the face orientation is preferred when walking.
        let mut incident: HashMap<u32, Vec<usize>> = HashMap::new();
        for (k, &[a, b]) in edges.iter().enumerate() {
            incident.entry(a).or_default().push(k);
            incident.entry(b).or_default().push(k);
        }
        let mut used = vec![false; edges.len()];
        let mut loops = Vec::new();
        for start_edge in 0..edges.len() {
            if used[start_edge] {
                continue;
            }
            let start = edges[start_edge][0];
            let mut chain = vec![start];
            let mut current = start;
            loop {
                let candidates = &incident[&current];
                let pick = candidates
                    .iter()
                    .copied()
                    .find(|&k| !used[k] && edges[k][0] == current)
                    .or_else(|| candidates.iter().copied().find(|&k| !used[k]));
                let Some(k) = pick else { break };
                used[k] = true;
                let [a, b] = edges[k];
                current = if a == current { b } else { a };
                if current == start {
                    break;
                }
                chain.push(current);
            }
            loops.push(chain);
        }
        loops
    }

    /// The axis-aligned bounding box of the vertices, or `None` for a mesh without vertices.
    #[must_use]
    pub fn bounds(&self) -> Option<Aabb> {
        Aabb::of_points(&self.vertices)
    }
}

/// An axis-aligned bounding box (metres).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// The smallest coordinate on each axis.
    pub min: Vec3,
    /// The largest coordinate on each axis.
    pub max: Vec3,
}

impl Aabb {
    /// The tightest box around `points`, or `None` if there are none.
    #[must_use]
    pub fn of_points(points: &[Vec3]) -> Option<Self> {
        let first = *points.first()?;
        let mut b = Aabb {
            min: first,
            max: first,
        };
        for p in &points[1..] {
            b.min = b.min.inf(p);
            b.max = b.max.sup(p);
        }
        Some(b)
    }

    /// The box's size along each axis (metres).
    #[must_use]
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }

    /// The box's centre.
    #[must_use]
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// The length of the box's diagonal (metres): a scale for relative tolerances.
    #[must_use]
    pub fn diagonal(&self) -> Real {
        self.extent().norm()
    }
}

/// Vertex adjacency in compressed sparse row form: the neighbours of vertex `i` are
/// `neighbors[offsets[i]..offsets[i + 1]]`, sorted ascending. One allocation for the whole
/// mesh, cache-friendly to iterate in smoothing and solver loops.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Adjacency {
    /// Row starts into `neighbors`; `vertex_count + 1` entries, the last is `neighbors.len()`.
    pub offsets: Vec<u32>,
    /// All neighbour lists, concatenated.
    pub neighbors: Vec<u32>,
}

impl Adjacency {
    /// The adjacency of `vertex_count` vertices connected by undirected `edges`
    /// (each edge once, as returned by [`TriMesh::edges`]).
    ///
    /// # Panics
    /// If an edge names a vertex `>= vertex_count` (a broken caller invariant: meshes are
    /// checked on construction).
    #[must_use]
    pub fn from_edges(vertex_count: usize, edges: &[[u32; 2]]) -> Self {
        let mut degree = vec![0u32; vertex_count + 1];
        for &[a, b] in edges {
            degree[a as usize + 1] += 1;
            degree[b as usize + 1] += 1;
        }
        for i in 0..vertex_count {
            degree[i + 1] += degree[i];
        }
        let offsets = degree;
        let mut fill: Vec<u32> = offsets[..vertex_count].to_vec();
        let mut neighbors = vec![0u32; offsets[vertex_count] as usize];
        for &[a, b] in edges {
            neighbors[fill[a as usize] as usize] = b;
            fill[a as usize] += 1;
            neighbors[fill[b as usize] as usize] = a;
            fill[b as usize] += 1;
        }
        for i in 0..vertex_count {
            neighbors[offsets[i] as usize..offsets[i + 1] as usize].sort_unstable();
        }
        Self { offsets, neighbors }
    }

    /// The number of vertices.
    #[must_use]
    pub fn vertex_count(&self) -> usize {
        self.offsets.len() - 1
    }

    /// The neighbours of vertex `i`, sorted ascending.
    ///
    /// # Panics
    /// If `i >= vertex_count()`.
    #[must_use]
    pub fn neighbors(&self, i: usize) -> &[u32] {
        &self.neighbors[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// The number of neighbours of vertex `i`.
    ///
    /// # Panics
    /// If `i >= vertex_count()`.
    #[must_use]
    pub fn degree(&self, i: usize) -> usize {
        (self.offsets[i + 1] - self.offsets[i]) as usize
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    /// A flat `nx` x `ny`-cell grid in the z = 0 plane with `spacing` metres between
    /// vertices; vertex `(i, j)` is `j * (nx + 1) + i`, faces counter-clockwise seen from +z.
    pub(crate) fn grid(nx: u32, ny: u32, spacing: Real) -> TriMesh {
        let mut vertices = Vec::new();
        for j in 0..=ny {
            for i in 0..=nx {
                vertices.push(Vec3::new(
                    Real::from(i) * spacing,
                    Real::from(j) * spacing,
                    0.0,
                ));
            }
        }
        let id = |i: u32, j: u32| j * (nx + 1) + i;
        let mut faces = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                faces.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
        TriMesh::new(vertices, faces).unwrap()
    }

    /// An open cylinder (radius 1 m, `around` segments, `rings` rings along z).
    fn tube(around: u32, rings: u32) -> TriMesh {
        let mut vertices = Vec::new();
        for r in 0..rings {
            for k in 0..around {
                let a = std::f64::consts::TAU * Real::from(k) / Real::from(around);
                vertices.push(Vec3::new(a.cos(), a.sin(), Real::from(r)));
            }
        }
        let id = |k: u32, r: u32| r * around + k % around;
        let mut faces = Vec::new();
        for r in 0..rings - 1 {
            for k in 0..around {
                faces.push([id(k, r), id(k + 1, r), id(k + 1, r + 1)]);
                faces.push([id(k, r), id(k + 1, r + 1), id(k, r + 1)]);
            }
        }
        TriMesh::new(vertices, faces).unwrap()
    }

    fn tetrahedron() -> TriMesh {
        let v = vec![
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(1.0, -1.0, -1.0),
            Vec3::new(-1.0, 1.0, -1.0),
            Vec3::new(-1.0, -1.0, 1.0),
        ];
        TriMesh::new(v, vec![[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]]).unwrap()
    }

    #[test]
    fn unit_square_geometry() {
        let m = grid(1, 1, 1.0);
        assert_eq!(m.face_areas(), vec![0.5, 0.5]);
        for n in m.face_normals().iter().chain(&m.vertex_normals()) {
            assert_relative_eq!(*n, Vec3::z(), epsilon = 1e-15);
        }
        // The diagonal's ends touch both triangles, the other two corners one each.
        let a = m.vertex_areas();
        assert_relative_eq!(a[0], 1.0 / 3.0);
        assert_relative_eq!(a[1], 1.0 / 6.0);
        assert_relative_eq!(a.iter().sum::<Real>(), m.area());
        assert_eq!(m.edges(), vec![[0, 1], [0, 2], [0, 3], [1, 3], [2, 3]]);
        assert_eq!(m.boundary_edges(), vec![[0, 1], [1, 3], [2, 0], [3, 2]]);
        assert_eq!(m.boundary_loops(), vec![vec![0, 1, 3, 2]]);
    }

    #[test]
    fn grid_topology_counts() {
        let (nx, ny) = (5u32, 3u32);
        let m = grid(nx, ny, 0.1);
        let v = m.vertex_count();
        // Euler characteristic of a disc: V - E + F = 1.
        assert_eq!(v as i64 - m.edges().len() as i64 + m.face_count() as i64, 1);
        let adj = m.adjacency();
        assert_eq!(adj.vertex_count(), v);
        assert_eq!(
            adj.degree((nx + 2) as usize),
            6,
            "interior vertices of this grid have 6"
        );
        for i in 0..v {
            for &j in adj.neighbors(i) {
                assert!(adj.neighbors(j as usize).contains(&(i as u32)), "symmetric");
            }
            assert!(
                adj.neighbors(i).windows(2).all(|w| w[0] < w[1]),
                "sorted, unique"
            );
        }
        let loops = m.boundary_loops();
        assert_eq!(loops.len(), 1);
        assert_eq!(loops[0].len(), 2 * (nx + ny) as usize);
        let edges = m.boundary_edges();
        let lp = &loops[0];
        for k in 0..lp.len() {
            let e = [lp[k], lp[(k + 1) % lp.len()]];
            assert!(
                edges.contains(&e),
                "loop step {e:?} follows a boundary edge"
            );
        }
        let b = m.bounds().unwrap();
        assert_relative_eq!(b.extent(), Vec3::new(0.5, 0.3, 0.0), epsilon = 1e-12);
        assert_relative_eq!(b.center(), Vec3::new(0.25, 0.15, 0.0), epsilon = 1e-12);
    }

    #[test]
    fn tube_has_two_loops_and_closed_mesh_none() {
        let loops = tube(12, 4).boundary_loops();
        assert_eq!(loops.len(), 2);
        assert!(loops.iter().all(|l| l.len() == 12));
        assert!(tetrahedron().boundary_loops().is_empty());
        assert!(tetrahedron().boundary_edges().is_empty());
    }

    #[test]
    fn closed_mesh_normals_point_outward() {
        let m = tetrahedron();
        for (p, n) in m.vertices.iter().zip(m.vertex_normals()) {
            assert_relative_eq!(n, p.normalize(), epsilon = 1e-12);
        }
        let total: Real = m.vertex_areas().iter().sum();
        assert_relative_eq!(total, m.area(), epsilon = 1e-12);
    }

    #[test]
    fn into_forms_reject_wrong_lengths_and_reuse_buffers() {
        let m = grid(2, 2, 1.0);
        let mut out = Vec::with_capacity(m.vertex_count());
        let err = m
            .vertex_normals_into(&m.vertices[1..], &mut out)
            .unwrap_err();
        assert!(matches!(err, Error::Mismatch { .. }), "{err}");
        let cap = out.capacity();
        m.vertex_normals_into(&m.vertices, &mut out).unwrap();
        assert_eq!(out.len(), m.vertex_count());
        assert_eq!(
            out.capacity(),
            cap,
            "no reallocation when the buffer is big enough"
        );
    }

    #[test]
    fn degenerate_face_gets_zero_normal_and_empty_mesh_no_bounds() {
        let v = vec![Vec3::zeros(), Vec3::x(), Vec3::x() * 2.0];
        let m = TriMesh::new(v, vec![[0, 1, 2]]).unwrap();
        assert_eq!(m.face_normals(), vec![Vec3::zeros()]);
        assert_eq!(m.face_areas(), vec![0.0]);
        assert!(TriMesh::new(vec![], vec![]).unwrap().bounds().is_none());
    }

    proptest! {
        #[test]
        fn lumped_areas_sum_to_surface_area(
            z in proptest::collection::vec(-0.2f64..0.2, 16)
        ) {
            let mut m = grid(3, 3, 0.1);
            for (v, dz) in m.vertices.iter_mut().zip(&z) {
                v.z = *dz;
            }
            let total: Real = m.vertex_areas().iter().sum();
            prop_assert!((total - m.area()).abs() <= 1e-12 * m.area());
            let normals = m.vertex_normals();
            prop_assert!(normals.iter().all(|n| (n.norm() - 1.0).abs() < 1e-12));
        }
    }
}
