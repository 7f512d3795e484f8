//! Laplacian smoothing of garment shapes (paper §3.3, eqs. 2–3): the smoothed garment
//! `T_fitting` that separates the overall fit from the wrinkles.
//!
//! Each iteration moves every vertex a fraction `lambda` towards the weighted average of its
//! neighbours, `t_i <- t_i + lambda * sum_j w_ij (t_j - t_i)` with `sum_j w_ij = 1` (an explicit
//! step of the diffusion equation `df/dt = lambda * Laplacian(f)`). The paper uses
//! `lambda = 0.15` and 80 iterations ([`SmoothingSettings::default`]). All vertices are
//! updated simultaneously (Jacobi), so the result does not depend on vertex order.
//!
//! # Boundaries
//! The paper does not say how the garment's openings are treated. With the plain umbrella
//! operator a boundary vertex only has neighbours on one side, so 80 iterations pull the
//! neck, hem and cuffs inward across the surface and the "smooth fit" would no longer cover
//! the body where the simulated garment does. Here:
//! - a *boundary* vertex is smoothed only along its boundary loop (a 1-D Laplacian with its
//!   two loop neighbours, weights 1/2 each): the opening's curve loses its wiggles but the
//!   opening does not move across the surface, and a straight boundary stays straight;
//! - a *fixed* vertex does not move: where the template's boundary turns by more than
//!   [`CORNER_ANGLE_DEGREES`] (a corner, e.g. where a cuff meets a side seam), a vertex on more
//!   than one loop (or twice on one), and the ends of a loop that does not close (broken
//!   meshes). Corners are detected once, on the rest template, so every shape of a data set
//!   is smoothed with the same operator.
//!
//! # Weights
//! [`LaplacianWeights::Uniform`] (the default): `w_ij = 1 / degree(i)`, depending on topology
//! only, so the operator is built once. [`LaplacianWeights::Cotangent`]: `w_ij` proportional to
//! `(cot alpha_ij + cot beta_ij) / 2`, the angles opposite edge `ij`, computed from the *input*
//! shape once per [`LaplacianSmoother::smooth`] call and kept fixed over its iterations (cheap,
//! and it keeps every step a convex combination). Negative summed cotangents (obtuse
//! configurations) are clamped to 0 so that weights stay non-negative and the step stays
//! stable for any `lambda <= 1`; each vertex's weights are then normalised to sum to 1, and a
//! vertex whose weights all vanish falls back to uniform weights. Boundary vertices use the
//! 1-D loop rule above with either setting.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, ensure_finite};
use crate::math::{Real, Vec3};
use crate::mesh::TriMesh;

/// The boundary turning angle (degrees, measured on the rest template) above which a
/// boundary vertex is a corner and stays fixed.
pub const CORNER_ANGLE_DEGREES: Real = 60.0;

/// Marks a face-corner slot that does not belong to an interior vertex's row.
const NO_SLOT: u32 = u32::MAX;

/// How neighbours are weighted in the discrete Laplacian.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LaplacianWeights {
    /// Every neighbour counts equally (the umbrella operator).
    #[default]
    Uniform,
    /// Cotangent weights of the shape being smoothed (see the module docs).
    Cotangent,
}

/// The smoothing of eq. 3. The default is the paper's: `lambda = 0.15`, 80 iterations,
/// uniform weights.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SmoothingSettings {
    /// The step `lambda` of eq. 3 (dimensionless, in `(0, 1]`).
    pub lambda: Real,
    /// The number of smoothing steps.
    pub iterations: usize,
    /// The neighbour weighting.
    pub weights: LaplacianWeights,
}

impl Default for SmoothingSettings {
    fn default() -> Self {
        Self {
            lambda: 0.15,
            iterations: 80,
            weights: LaplacianWeights::Uniform,
        }
    }
}

impl SmoothingSettings {
    /// Checks the settings.
    ///
    /// # Errors
    /// [`Error::OutOfRange`] if `lambda` is not in `(0, 1]` (larger steps overshoot and can
    /// oscillate; 0 or less does not smooth).
    pub fn validate(&self) -> Result<()> {
        if self.lambda > 0.0 && self.lambda <= 1.0 {
            Ok(())
        } else {
            Err(Error::OutOfRange {
                what: "smoothing step lambda".to_owned(),
                value: self.lambda,
                min: 0.0,
                max: 1.0,
                hint: "; the paper uses 0.15 (0 itself is excluded)".to_owned(),
            })
        }
    }
}

/// What the smoother does with a vertex (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum VertexRole {
    /// Smoothed with all its neighbours.
    Interior,
    /// Smoothed along its boundary loop only.
    Boundary,
    /// Never moves (boundary corner, non-manifold boundary vertex, or isolated vertex).
    Fixed,
}

/// A Laplacian smoother for one mesh topology, built once and applied to many shapes.
///
/// The operator is a CSR table: interior vertices list all their neighbours, boundary
/// vertices their two loop neighbours, fixed vertices nothing. Smoothing allocates the
/// output, one scratch buffer and (cotangent weights only) one weight per table entry per
/// call, nothing per iteration.
///
/// ```
/// use garmatnet_core::{LaplacianSmoother, SmoothingSettings, TriMesh, Vec3};
/// // A fan of four triangles around a centre vertex lifted 1 cm out of the plane.
/// let rim = [(0.1, 0.0), (0.0, 0.1), (-0.1, 0.0), (0.0, -0.1)];
/// let mut vertices = vec![Vec3::new(0.0, 0.0, 0.01)];
/// vertices.extend(rim.iter().map(|&(x, y)| Vec3::new(x, y, 0.0)));
/// let mesh = TriMesh::new(vertices, vec![[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 1]])?;
/// let smoother = LaplacianSmoother::new(&mesh, SmoothingSettings::default())?;
/// let smoothed = smoother.smooth(&mesh.vertices)?;
/// assert!(smoothed[0].z < 1e-6); // the bump is gone (0.85^80 of it is left)
/// assert_eq!(&smoothed[1..], &mesh.vertices[1..]); // the square's rim: four fixed corners
/// # Ok::<(), garmatnet_core::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct LaplacianSmoother {
    settings: SmoothingSettings,
    roles: Vec<VertexRole>,
    offsets: Vec<u32>,
    neighbors: Vec<u32>,
    uniform_weights: Vec<Real>,
    faces: Vec<[u32; 3]>,
    /// Per face and corner `k`: the table slots of the opposite edge's two directions
    /// (`NO_SLOT` where the row is not an interior vertex's).
    cotangent_slots: Vec<[[u32; 2]; 3]>,
}

impl LaplacianSmoother {
    /// Builds the smoother for `template`'s topology; boundary corners are found on
    /// `template`'s vertex positions (the rest shape).
    ///
    /// # Errors
    /// [`Error::OutOfRange`] for invalid `settings` ([`SmoothingSettings::validate`]).
    pub fn new(template: &TriMesh, settings: SmoothingSettings) -> Result<Self> {
        settings.validate()?;
        let n = template.vertex_count();
        let adjacency = template.adjacency();
        let (roles, loop_neighbors) = classify_vertices(template);

        let mut offsets = Vec::with_capacity(n + 1);
        let mut neighbors = Vec::with_capacity(adjacency.neighbors.len());
        offsets.push(0u32);
        for (i, role) in roles.iter().enumerate() {
            match role {
                VertexRole::Interior => neighbors.extend_from_slice(adjacency.neighbors(i)),
                VertexRole::Boundary => neighbors.extend_from_slice(&loop_neighbors[i]),
                VertexRole::Fixed => {}
            }
            offsets.push(u32::try_from(neighbors.len()).expect("fewer than 2^32 mesh edges"));
        }
        let mut uniform_weights = vec![0.0; neighbors.len()];
        for i in 0..n {
            let row = offsets[i] as usize..offsets[i + 1] as usize;
            let share = 1.0 / row.len().max(1) as Real;
            uniform_weights[row].fill(share);
        }

        // Interior rows are the adjacency's sorted neighbour lists, so a slot is found by
        // binary search.
        let slot = |i: u32, j: u32| -> u32 {
            if roles[i as usize] != VertexRole::Interior {
                return NO_SLOT;
            }
            let start = offsets[i as usize] as usize;
            let row = &neighbors[start..offsets[i as usize + 1] as usize];
            let k = row
                .binary_search(&j)
                .expect("an edge's ends are neighbours");
            u32::try_from(start + k).expect("fewer than 2^32 mesh edges")
        };
        let cotangent_slots = template
            .faces
            .iter()
            .map(|f| {
                [0, 1, 2].map(|k| {
                    let (a, b) = (f[(k + 1) % 3], f[(k + 2) % 3]);
                    [slot(a, b), slot(b, a)]
                })
            })
            .collect();

        Ok(Self {
            settings,
            roles,
            offsets,
            neighbors,
            uniform_weights,
            faces: template.faces.clone(),
            cotangent_slots,
        })
    }

    /// The settings the smoother applies.
    #[must_use]
    pub fn settings(&self) -> &SmoothingSettings {
        &self.settings
    }

    /// The number of vertices of the topology.
    #[must_use]
    pub fn vertex_count(&self) -> usize {
        self.roles.len()
    }

    /// What the smoother does with each vertex.
    ///
    /// # Shapes
    /// `[vertex_count]`.
    #[must_use]
    pub fn roles(&self) -> &[VertexRole] {
        &self.roles
    }

    /// Smooths one shape of the topology (metres in, metres out).
    ///
    /// # Shapes
    /// `positions`: `[vertex_count]`; returns `[vertex_count]`.
    ///
    /// # Errors
    /// [`Error::Mismatch`] if `positions` does not have one entry per vertex;
    /// [`Error::NonFinite`] if a coordinate is NaN or infinite.
    pub fn smooth(&self, positions: &[Vec3]) -> Result<Vec<Vec3>> {
        let n = self.vertex_count();
        if positions.len() != n {
            return Err(Error::Mismatch {
                what: "positions to smooth (one per vertex of the smoother's mesh)".to_owned(),
                expected: format!("{n} positions"),
                got: format!("{} positions", positions.len()),
            });
        }
        ensure_finite(
            "positions to smooth",
            positions.iter().flat_map(|v| [v.x, v.y, v.z]),
        )?;
        let cotangent;
        let weights: &[Real] = match self.settings.weights {
            LaplacianWeights::Uniform => &self.uniform_weights,
            LaplacianWeights::Cotangent => {
                cotangent = self.cotangent_weights(positions);
                &cotangent
            }
        };
        let lambda = self.settings.lambda;
        let mut current = positions.to_vec();
        let mut next = current.clone();
        for _ in 0..self.settings.iterations {
            for (i, out) in next.iter_mut().enumerate() {
                let (start, end) = (self.offsets[i] as usize, self.offsets[i + 1] as usize);
                let x = current[i];
                // Summing differences (not positions) keeps the step translation-invariant
                // to rounding and exact for fixed rows.
                let mut laplacian = Vec3::zeros();
                for k in start..end {
                    laplacian += (current[self.neighbors[k] as usize] - x) * weights[k];
                }
                *out = x + laplacian * lambda;
            }
            std::mem::swap(&mut current, &mut next);
        }
        Ok(current)
    }

    /// Cotangent weights of `positions`, normalised per interior row (see the module docs).
    fn cotangent_weights(&self, positions: &[Vec3]) -> Vec<Real> {
        let mut w = vec![0.0; self.neighbors.len()];
        for (face, slots) in self.faces.iter().zip(&self.cotangent_slots) {
            let p = face.map(|i| positions[i as usize]);
            for k in 0..3 {
                let (u, v) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
                let sine = u.cross(&v).norm();
                // A degenerate corner (zero or straight angle) has no meaningful cotangent.
                if sine <= 1e-12 * u.norm() * v.norm() {
                    continue;
                }
                let half_cot = 0.5 * u.dot(&v) / sine;
                for &s in &slots[k] {
                    if s != NO_SLOT {
                        w[s as usize] += half_cot;
                    }
                }
            }
        }
        for (i, role) in self.roles.iter().enumerate() {
            let row = self.offsets[i] as usize..self.offsets[i + 1] as usize;
            if *role != VertexRole::Interior {
                w[row.clone()].copy_from_slice(&self.uniform_weights[row]);
                continue;
            }
            let mut sum = 0.0;
            for x in &mut w[row.clone()] {
                *x = x.max(0.0);
                sum += *x;
            }
            if sum > 0.0 {
                w[row].iter_mut().for_each(|x| *x /= sum);
            } else {
                w[row.clone()].copy_from_slice(&self.uniform_weights[row]);
            }
        }
        w
    }
}

/// Each vertex's role and, for boundary vertices, its two loop neighbours.
fn classify_vertices(mesh: &TriMesh) -> (Vec<VertexRole>, Vec<[u32; 2]>) {
    let n = mesh.vertex_count();
    let mut roles = vec![VertexRole::Fixed; n];
    for f in &mesh.faces {
        for &v in f {
            roles[v as usize] = VertexRole::Interior;
        }
    }
    let mut loop_neighbors = vec![[0u32; 2]; n];
    let loops = mesh.boundary_loops();
    let mut appearances = vec![0u32; n];
    for l in &loops {
        for &v in l {
            appearances[v as usize] += 1;
        }
    }
    let edges = mesh.boundary_edges();
    let is_edge = |a: u32, b: u32| {
        edges.binary_search(&[a, b]).is_ok() || edges.binary_search(&[b, a]).is_ok()
    };
    let cos_corner = CORNER_ANGLE_DEGREES.to_radians().cos();
    for l in &loops {
        let len = l.len();
        let closed = len >= 3 && is_edge(l[len - 1], l[0]);
        for (k, &v) in l.iter().enumerate() {
            let vi = v as usize;
            roles[vi] = VertexRole::Fixed;
            if appearances[vi] > 1 || (!closed && (k == 0 || k + 1 == len)) || len < 3 {
                continue;
            }
            let (prev, next) = (l[(k + len - 1) % len], l[(k + 1) % len]);
            let p = mesh.vertices[prev as usize];
            let x = mesh.vertices[vi];
            let q = mesh.vertices[next as usize];
            let (incoming, outgoing) = (x - p, q - x);
            let norms = incoming.norm() * outgoing.norm();
            // Turning by more than the corner angle means cos(turn) < cos(corner angle).
            if norms > 0.0 && incoming.dot(&outgoing) >= cos_corner * norms {
                roles[vi] = VertexRole::Boundary;
                loop_neighbors[vi] = [prev, next];
            }
        }
    }
    (roles, loop_neighbors)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rot3;
    use crate::mesh::tests::grid;
    use crate::rng::SplitMix64;

    fn settings(weights: LaplacianWeights, iterations: usize) -> SmoothingSettings {
        SmoothingSettings {
            iterations,
            weights,
            ..SmoothingSettings::default()
        }
    }

    /// A spherical cap of radius 1 m: a pole and `rings` rings of `around` vertices, down to
    /// a polar angle of 70 degrees.
    fn cap(around: u32, rings: u32) -> TriMesh {
        let mut vertices = vec![Vec3::z()];
        for r in 1..=rings {
            let theta = 70f64.to_radians() * Real::from(r) / Real::from(rings);
            for k in 0..around {
                let phi = std::f64::consts::TAU * Real::from(k) / Real::from(around);
                vertices.push(Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                ));
            }
        }
        let id = |r: u32, k: u32| 1 + (r - 1) * around + k % around;
        let mut faces = Vec::new();
        for k in 0..around {
            faces.push([0, id(1, k), id(1, k + 1)]);
        }
        for r in 1..rings {
            for k in 0..around {
                faces.push([id(r, k), id(r + 1, k), id(r + 1, k + 1)]);
                faces.push([id(r, k), id(r + 1, k + 1), id(r, k + 1)]);
            }
        }
        TriMesh::new(vertices, faces).unwrap()
    }

    fn noisy(points: &[Vec3], sigma: Real, seed: u64) -> Vec<Vec3> {
        let mut rng = SplitMix64::new(seed);
        points
            .iter()
            .map(|p| p + Vec3::new(rng.normal(), rng.normal(), rng.normal()) * sigma)
            .collect()
    }

    /// The squared norm of the uniform Laplacian: zero only where every vertex is the
    /// average of its neighbours (a plane).
    fn roughness(mesh: &TriMesh, x: &[Vec3]) -> Real {
        let adj = mesh.adjacency();
        (0..x.len())
            .map(|i| {
                let nb = adj.neighbors(i);
                let avg = nb.iter().map(|&j| x[j as usize]).sum::<Vec3>() / nb.len() as Real;
                (avg - x[i]).norm_squared()
            })
            .sum()
    }

    #[test]
    fn roles_of_grid_and_cap() {
        let g = grid(4, 3, 0.1);
        let s = LaplacianSmoother::new(&g, SmoothingSettings::default()).unwrap();
        let count = |r: VertexRole| s.roles().iter().filter(|&&x| x == r).count();
        assert_eq!(count(VertexRole::Fixed), 4, "the four right-angle corners");
        assert_eq!(count(VertexRole::Boundary), 2 * (4 + 3) - 4);
        assert_eq!(count(VertexRole::Interior), 3 * 2);
        let c = cap(16, 4);
        let s = LaplacianSmoother::new(&c, SmoothingSettings::default()).unwrap();
        assert_eq!(
            s.roles()
                .iter()
                .filter(|&&x| x == VertexRole::Boundary)
                .count(),
            16
        );
        assert!(
            !s.roles().contains(&VertexRole::Fixed),
            "a round opening has no corners"
        );
    }

    #[test]
    fn flat_grid_stays_flat() {
        let mut g = grid(8, 6, 0.05);
        let rotation = Rot3::from_euler_angles(0.3, -0.5, 1.1);
        let normal = rotation * Vec3::z();
        let mut rng = SplitMix64::new(3);
        for v in &mut g.vertices {
            // In-plane jitter only.
            *v = rotation * (*v + Vec3::new(rng.normal(), rng.normal(), 0.0) * 0.01);
        }
        for weights in [LaplacianWeights::Uniform, LaplacianWeights::Cotangent] {
            let s = LaplacianSmoother::new(&g, settings(weights, 80)).unwrap();
            let out = s.smooth(&g.vertices).unwrap();
            for p in &out {
                assert!(p.dot(&normal).abs() < 1e-12, "{weights:?}: left the plane");
            }
            assert!(roughness(&g, &out) < roughness(&g, &g.vertices));
        }
    }

    #[test]
    fn noise_energy_decreases_monotonically() {
        let g = grid(12, 12, 0.05);
        let one_step = LaplacianSmoother::new(&g, settings(LaplacianWeights::Uniform, 1)).unwrap();
        let edges = g.edges();
        let dirichlet = |x: &[Vec3]| -> Real {
            edges
                .iter()
                .map(|&[a, b]| (x[a as usize].z - x[b as usize].z).powi(2))
                .sum()
        };
        let mut rng = SplitMix64::new(5);
        let mut x = g.vertices.clone();
        for (i, role) in one_step.roles().iter().enumerate() {
            if *role == VertexRole::Interior {
                x[i].z = 0.01 * rng.normal();
            }
        }
        let start = dirichlet(&x);
        let mut last = start;
        for step in 0..80 {
            x = one_step.smooth(&x).unwrap();
            let e = dirichlet(&x);
            assert!(
                e < last,
                "step {step}: energy {e} did not drop below {last}"
            );
            last = e;
        }
        assert!(
            last < 0.05 * start,
            "80 steps remove most of the noise: {last} vs {start}"
        );
    }

    #[test]
    fn translation_commutes_with_smoothing() {
        let c = cap(20, 6);
        let x = noisy(&c.vertices, 0.02, 8);
        let t = Vec3::new(0.4, -1.3, 2.2);
        let moved: Vec<Vec3> = x.iter().map(|p| p + t).collect();
        for weights in [LaplacianWeights::Uniform, LaplacianWeights::Cotangent] {
            let s = LaplacianSmoother::new(&c, settings(weights, 80)).unwrap();
            let a = s.smooth(&x).unwrap();
            let b = s.smooth(&moved).unwrap();
            for (p, q) in a.iter().zip(&b) {
                assert!((p + t - q).amax() < 1e-12, "{weights:?}");
            }
        }
    }

    #[test]
    fn straight_boundary_stays_straight() {
        let g = grid(10, 6, 0.1);
        let mut x = noisy(&g.vertices, 0.01, 13);
        let bottom: Vec<usize> = (0..=10).collect();
        // The bottom edge: on the x axis, unevenly spaced, corners at their grid places.
        for &i in &bottom {
            x[i].y = 0.0;
            x[i].z = 0.0;
        }
        x[0].x = 0.0;
        x[10].x = 1.0;
        let spacing_spread = |x: &[Vec3]| -> Real {
            bottom
                .windows(2)
                .map(|w| (x[w[1]].x - x[w[0]].x - 0.1).abs())
                .fold(0.0, Real::max)
        };
        for weights in [LaplacianWeights::Uniform, LaplacianWeights::Cotangent] {
            let s = LaplacianSmoother::new(&g, settings(weights, 80)).unwrap();
            let out = s.smooth(&x).unwrap();
            for &i in &bottom {
                assert_eq!(
                    (out[i].y, out[i].z),
                    (0.0, 0.0),
                    "{weights:?}: vertex {i} left the line"
                );
            }
            assert_eq!(out[0], x[0], "corners are fixed");
            assert_eq!(out[10], x[10], "corners are fixed");
            assert!(
                spacing_spread(&out) < 0.75 * spacing_spread(&x),
                "smoothed along the line"
            );
        }
    }

    #[test]
    fn both_weightings_converge_on_a_noisy_cap() {
        let c = cap(24, 8);
        // Noise along the normal (radial): the cotangent Laplacian has linear precision, so
        // by design it leaves tangential jitter alone and only normal noise is its job.
        let mut rng = SplitMix64::new(21);
        let x: Vec<Vec3> = c
            .vertices
            .iter()
            .map(|p| p * (1.0 + 0.01 * rng.normal()))
            .collect();
        // The RMS of the radial part of `a - b`.
        let rms = |a: &[Vec3], b: &[Vec3]| -> Real {
            let sum: Real = a
                .iter()
                .zip(b)
                .map(|(p, q)| (p - q).dot(&q.normalize()).powi(2))
                .sum();
            (sum / a.len() as Real).sqrt()
        };
        let noise = rms(&x, &c.vertices);
        for weights in [LaplacianWeights::Uniform, LaplacianWeights::Cotangent] {
            let paper = LaplacianSmoother::new(&c, settings(weights, 80)).unwrap();
            let longer = LaplacianSmoother::new(&c, settings(weights, 160)).unwrap();
            let clean80 = paper.smooth(&c.vertices).unwrap();
            let clean160 = longer.smooth(&c.vertices).unwrap();
            let left80 = rms(&paper.smooth(&x).unwrap(), &clean80);
            let left160 = rms(&longer.smooth(&x).unwrap(), &clean160);
            assert!(
                left80 < 0.3 * noise,
                "{weights:?}: noise left {left80} of {noise}"
            );
            // Twice the iterations stays as good (no blow-up of the difference); the cotangent
            // weights of the noisy and the clean input differ slightly, so their results need
            // not get ever closer.
            assert!(
                left160 < 0.3 * noise,
                "{weights:?}: stable at 160 steps ({left160})"
            );
        }
    }

    #[test]
    fn bad_input_is_a_typed_error() {
        let g = grid(2, 2, 0.1);
        let s = LaplacianSmoother::new(&g, SmoothingSettings::default()).unwrap();
        let err = s.smooth(&g.vertices[1..]).unwrap_err();
        assert!(matches!(err, Error::Mismatch { .. }), "{err}");
        let mut x = g.vertices.clone();
        x[4].x = f64::INFINITY;
        let err = s.smooth(&x).unwrap_err();
        assert!(matches!(err, Error::NonFinite { index: 12, .. }), "{err}");
        for lambda in [0.0, 1.5, f64::NAN] {
            let bad = SmoothingSettings {
                lambda,
                ..SmoothingSettings::default()
            };
            let err = LaplacianSmoother::new(&g, bad).unwrap_err();
            assert!(matches!(err, Error::OutOfRange { .. }), "{err}");
        }
    }

    #[test]
    fn settings_default_to_the_paper_and_deserialise_partially() {
        let d = SmoothingSettings::default();
        assert_eq!(
            (d.lambda, d.iterations, d.weights),
            (0.15, 80, LaplacianWeights::Uniform)
        );
        let s: SmoothingSettings = serde_json::from_str(r#"{"weights":"cotangent"}"#).unwrap();
        assert_eq!(
            s,
            SmoothingSettings {
                weights: LaplacianWeights::Cotangent,
                ..d
            }
        );
    }
}
