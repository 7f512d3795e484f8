//! The static-drape solver: projective dynamics (Liu et al. 2013, "Fast Simulation of
//! Mass-Spring Systems") in implicit-Euler pseudo time, with body contact and friction
//! inside the global solve.
//!
//! Each iteration minimises `(1/2h^2)|x - x_k|_M^2 + E(x)` by one local step (project every
//! spring to its rest length and every near-body vertex to the collider's offset surface)
//! and one global step (solve `(M/h^2 + L + W_c) x = rhs` for x, y and z with one sparse
//! Cholesky factor). Because the local/global surrogate majorises the energy, the energy
//! never rises; its fixed points are exactly the static equilibria.

use std::sync::Arc;
use std::time::Instant;

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymmetricOrdering,
    factorize_symbolic_cholesky,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use garmatnet_core::error::ensure_finite;
use garmatnet_core::{Error as CoreError, Real, SignedDistance, Vec3};
use serde::{Deserialize, Serialize};

use crate::cloth_model::ClothModel;
use crate::contact::{contact_target, push_out};
use crate::drape_settings::DrapeSettings;
use crate::error::{Error, Result};

/// Vertices that left the collider stay in the factorised contact set (as a proximal pull
/// to where they are) for this many iterations before a refactorisation drops them: cloth
/// hovering at the margin would otherwise refactor on every flicker.
const SEPARATION_PATIENCE: u32 = 30;

/// What one drape did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DrapeStats {
    /// Local/global iterations run.
    pub iterations: usize,
    /// Final normalised residual: RMS over free vertices of `|f_i| / (m_i g)`, with `f_i`
    /// the net force (springs + gravity + contact reaction) on vertex `i`.
    pub final_residual: Real,
    /// Final largest `|f_i| / (m_i g)` over free vertices.
    pub max_residual: Real,
    /// Deepest remaining penetration into the collider (metres, >= 0).
    pub max_penetration: Real,
    /// Largest spring strain `(l - rest) / rest` (dimensionless; negative when all springs
    /// are compressed).
    pub max_strain: Real,
    /// Vertices in contact at the end (within the margin of the collider).
    pub contacts: usize,
    /// Sum of the contact reaction forces on the cloth at the last iterate (newtons); at
    /// equilibrium without pins it balances the cloth's weight.
    pub contact_force: Vec3,
    /// Numeric Cholesky refactorisations done (contact set, pins or material changed).
    pub refactorizations: usize,
    /// Wall-clock time of the drape (milliseconds).
    pub wall_time_ms: Real,
    /// Whether `final_residual` reached the tolerance before the iteration cap.
    pub converged: bool,
}

/// The solver for one cloth topology: owns the symbolic Cholesky factorisation (computed
/// once in [`DrapeSolver::new`]) and refactors numerically only when the contact set, the
/// pins or the material change.
#[derive(Debug, Clone)]
pub struct DrapeSolver {
    model: ClothModel,
    settings: DrapeSettings,
    /// Upper-triangle CSC pattern of the n x n system matrix.
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    diag_slot: Vec<usize>,
    spring_slot: Vec<usize>,
    symbolic: Arc<SymbolicCholesky<usize>>,
    /// `m/h^2 + sum of incident stiffnesses` per vertex (N/m).
    base_diag: Vec<Real>,
    /// Contact penalty weight per vertex (N/m).
    contact_weight: Vec<Real>,
    matrix_values: Vec<Real>,
    factor_values: Vec<Real>,
    /// The contact set and pins the current factor was computed for; `None` before the first.
    factored_for: Option<(Vec<bool>, Vec<bool>)>,
}

impl DrapeSolver {
    /// A solver for `model`, with its symbolic factorisation (fill-reducing ordering and
    /// elimination tree) computed once.
    ///
    /// # Errors
    /// [`CoreError::OutOfRange`] for invalid settings (non-positive time step or iteration
    /// cap, negative margin, friction or tolerance, Chebyshev rho outside [0, 1));
    /// [`Error::Factorization`] if the symbolic analysis fails (out of memory).
    pub fn new(model: &ClothModel, settings: &DrapeSettings) -> Result<Self> {
        validate_settings(settings)?;
        let n = model.vertex_count();
        // Column j holds rows i <= j: the diagonal and every spring partner with a smaller index.
        let mut columns: Vec<Vec<usize>> = (0..n).map(|j| vec![j]).collect();
        for s in model.springs() {
            let (i, j) = (s.a.min(s.b), s.a.max(s.b));
            columns[j].push(i);
        }
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for col in &mut columns {
            col.sort_unstable();
            col.dedup();
            row_idx.extend_from_slice(col);
            col_ptr.push(row_idx.len());
        }
        let slot = |i: usize, j: usize| -> usize {
            let rows = &row_idx[col_ptr[j]..col_ptr[j + 1]];
            col_ptr[j] + rows.binary_search(&i).expect("pattern holds every spring")
        };
        let diag_slot: Vec<usize> = (0..n).map(|j| slot(j, j)).collect();
        let spring_slot: Vec<usize> = model
            .springs()
            .iter()
            .map(|s| slot(s.a.min(s.b), s.a.max(s.b)))
            .collect();
        let pattern = SymbolicSparseColMatRef::new_checked(n, n, &col_ptr, None, &row_idx);
        let symbolic = factorize_symbolic_cholesky(
            pattern,
            Side::Upper,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams::default(),
        )
        .map_err(|e| Error::Factorization(format!("{e:?}")))?;
        let factor_len = symbolic.len_val();
        let mut solver = Self {
            model: model.clone(),
            settings: settings.clone(),
            matrix_values: vec![0.0; row_idx.len()],
            col_ptr,
            row_idx,
            diag_slot,
            spring_slot,
            symbolic: Arc::new(symbolic),
            base_diag: Vec::new(),
            contact_weight: Vec::new(),
            factor_values: vec![0.0; factor_len],
            factored_for: None,
        };
        solver.update_weights();
        Ok(solver)
    }

    /// Switches to another material (stiffnesses, masses, rest lengths) on the same
    /// topology, keeping the symbolic factorisation.
    ///
    /// # Errors
    /// [`CoreError::Mismatch`] if `model`'s vertex count or spring endpoints differ.
    pub fn set_model(&mut self, model: &ClothModel) -> Result<()> {
        if !self.model.same_topology(model) {
            return Err(CoreError::Mismatch {
                what: "cloth topology of the drape solver".into(),
                expected: format!(
                    "{} vertices and the same {} spring endpoints",
                    self.model.vertex_count(),
                    self.model.springs().len()
                ),
                got: format!(
                    "{} vertices, {} springs",
                    model.vertex_count(),
                    model.springs().len()
                ),
            }
            .into());
        }
        self.model = model.clone();
        self.update_weights();
        Ok(())
    }

    /// Changes the settings, keeping the symbolic factorisation.
    ///
    /// # Errors
    /// As [`DrapeSolver::new`] for invalid settings.
    pub fn set_settings(&mut self, settings: &DrapeSettings) -> Result<()> {
        validate_settings(settings)?;
        self.settings = settings.clone();
        self.update_weights();
        Ok(())
    }

    /// The cloth being simulated.
    #[must_use]
    pub fn model(&self) -> &ClothModel {
        &self.model
    }

    /// The settings in use.
    #[must_use]
    pub fn settings(&self) -> &DrapeSettings {
        &self.settings
    }

    fn update_weights(&mut self) {
        let h2 = self.settings.time_step * self.settings.time_step;
        self.base_diag = self.model.masses().iter().map(|m| m / h2).collect();
        for s in self.model.springs() {
            self.base_diag[s.a] += s.stiffness;
            self.base_diag[s.b] += s.stiffness;
        }
        let ratio = self.settings.contact_weight_ratio;
        self.contact_weight = self.base_diag.iter().map(|d| ratio * d).collect();
        self.factored_for = None;
    }

    /// Drapes the cloth from `positions` (metres; the warm start, e.g. the previous pose's
    /// result) to static equilibrium under gravity against `collider`, holding the
    /// `pinned` vertices at their given positions. Writes the result into `positions`.
    ///
    /// # Errors
    /// - [`CoreError::WrongLength`] if `positions` does not have one entry per vertex;
    /// - [`CoreError::NonFinite`] for NaN or infinite positions;
    /// - [`CoreError::OutOfRange`] for a pinned index past the vertices;
    /// - [`Error::Factorization`] if the system matrix is not positive definite;
    /// - [`Error::Diverged`] if the iteration produced non-finite positions
    ///   (`positions` is then left at the last finite iterate).
    pub fn drape(
        &mut self,
        positions: &mut [Vec3],
        collider: &impl SignedDistance,
        pinned: &[usize],
    ) -> Result<DrapeStats> {
        let start = Instant::now();
        let n = self.model.vertex_count();
        if positions.len() != n {
            return Err(CoreError::WrongLength {
                what: "cloth positions".into(),
                expected: n.to_string(),
                got: positions.len(),
            }
            .into());
        }
        ensure_finite(
            "cloth positions (metres)",
            positions.iter().flat_map(|v| [v.x, v.y, v.z]),
        )?;
        let mut is_pinned = vec![false; n];
        for &p in pinned {
            if p >= n {
                return Err(CoreError::OutOfRange {
                    what: "pinned vertex index".into(),
                    value: p as Real,
                    min: 0.0,
                    max: (n - 1) as Real,
                    hint: "; pin only vertices of the cloth".into(),
                }
                .into());
            }
            is_pinned[p] = true;
        }
        let s = self.settings.clone();
        let h2 = s.time_step * s.time_step;
        let gravity = Vec3::new(0.0, -s.gravity, 0.0);
        let masses = self.model.masses().to_vec();
        let free_count = is_pinned.iter().filter(|p| !**p).count().max(1);

        // The contact set starts from the input alone (not from earlier drapes), so the
        // result is a pure function of the inputs; an unchanged set reuses the old factor.
        let mut in_matrix = vec![false; n];
        let mut separated_for = vec![0u32; n];
        let mut anchors: Vec<Option<Vec3>> = vec![None; n];
        let mut targets: Vec<Option<Vec3>> = vec![None; n];
        let mut force = vec![Vec3::zeros(); n];
        let mut rhs = vec![0.0; 3 * n];
        let mut previous = positions.to_vec();
        let mut omega = 1.0;
        let mut chebyshev_age = 0usize;
        let mut refactorizations = 0usize;
        let contact_force;
        let mut solve_buffer =
            MemBuffer::new(self.symbolic.solve_in_place_scratch::<Real>(3, Par::Seq));

        let mut iterations = 0;
        let (residual, max_residual, converged) = loop {
            // Local step at x_k: contact targets (with friction) and whether the set changed.
            let mut contacts_changed = false;
            for i in 0..n {
                targets[i] = if is_pinned[i] {
                    None
                } else {
                    contact_target(
                        &positions[i],
                        collider,
                        s.contact_margin,
                        s.friction,
                        &mut anchors[i],
                    )
                };
                if targets[i].is_some() {
                    separated_for[i] = 0;
                    contacts_changed |= !in_matrix[i];
                    in_matrix[i] = true;
                } else if in_matrix[i] {
                    separated_for[i] += 1;
                }
            }
            let drop_separated = separated_for.iter().any(|&c| c >= SEPARATION_PATIENCE);
            if drop_separated {
                for i in 0..n {
                    if in_matrix[i] && separated_for[i] >= SEPARATION_PATIENCE {
                        in_matrix[i] = false;
                        separated_for[i] = 0;
                    }
                }
            }
            // Local step for springs, global right-hand side and the residual force, in one pass.
            self.assemble_rhs(
                positions, &is_pinned, &in_matrix, &targets, gravity, h2, &mut rhs, &mut force,
            );
            let (rms, max) =
                normalised_residual(&force, &masses, &is_pinned, s.gravity, free_count);
            if rms <= s.residual_tolerance || iterations >= s.max_iterations {
                contact_force = (0..n)
                    .filter_map(|i| targets[i].map(|p| (p - positions[i]) * self.contact_weight[i]))
                    .fold(Vec3::zeros(), |acc, f| acc + f);
                break (rms, max, rms <= s.residual_tolerance);
            }
            let refactor = match &self.factored_for {
                Some((c, p)) => {
                    contacts_changed || drop_separated || *c != in_matrix || *p != is_pinned
                }
                None => true,
            };
            if refactor {
                self.factorize(&in_matrix, &is_pinned)?;
                refactorizations += 1;
                chebyshev_age = 0;
            }
            self.solve(&mut rhs, &mut solve_buffer);
            iterations += 1;
            // Chebyshev semi-iterative acceleration (Wang 2015), restarted after refactors.
            chebyshev_age += 1;
            let accelerate = s.chebyshev_rho > 0.0 && chebyshev_age > s.chebyshev_delay;
            omega = if !accelerate {
                1.0
            } else if chebyshev_age == s.chebyshev_delay + 1 {
                2.0 / (2.0 - s.chebyshev_rho * s.chebyshev_rho)
            } else {
                4.0 / (4.0 - s.chebyshev_rho * s.chebyshev_rho * omega)
            };
            for i in 0..n {
                if is_pinned[i] {
                    continue;
                }
                let solved = Vec3::new(rhs[i], rhs[n + i], rhs[2 * n + i]);
                let mut next = if accelerate {
                    previous[i] + (solved - previous[i]) * omega
                } else {
                    solved
                };
                // A vertex the solve did not constrain can step through the body in one
                // iteration (free fall moves h^2 g); put it back on the margin surface so the
                // next local step sees it as a contact instead of pushing it out the far side.
                if !in_matrix[i] {
                    let (d, normal) = collider.distance_and_gradient(&next);
                    if d < 0.0 {
                        next += normal * (s.contact_margin - d);
                    }
                }
                if !(next.x.is_finite() && next.y.is_finite() && next.z.is_finite()) {
                    return Err(Error::Diverged {
                        iteration: iterations,
                    });
                }
                previous[i] = positions[i];
                positions[i] = next;
            }
        };
        let max_penetration = push_out(positions, collider, &is_pinned);
        let contacts = (0..n)
            .filter(|&i| !is_pinned[i] && collider.distance(&positions[i]) < s.contact_margin)
            .count();
        Ok(DrapeStats {
            iterations,
            final_residual: residual,
            max_residual,
            max_penetration,
            max_strain: self.max_strain(positions),
            contacts,
            contact_force,
            refactorizations,
            wall_time_ms: start.elapsed().as_secs_f64() * 1e3,
            converged,
        })
    }

    /// Fills `rhs` (column-major n x 3) with `M/h^2 x_k + f_ext + sum_s k_s S_s^T d_s +
    /// W_c p` and `force` with the net force on each vertex at `x_k`.
    #[allow(clippy::too_many_arguments)]
    fn assemble_rhs(
        &self,
        x: &[Vec3],
        is_pinned: &[bool],
        in_matrix: &[bool],
        targets: &[Option<Vec3>],
        gravity: Vec3,
        h2: Real,
        rhs: &mut [Real],
        force: &mut [Vec3],
    ) {
        let n = x.len();
        let masses = self.model.masses();
        let mut b: Vec<Vec3> = (0..n)
            .map(|i| x[i] * (masses[i] / h2) + gravity * masses[i])
            .collect();
        for i in 0..n {
            force[i] = gravity * masses[i];
        }
        for spring in self.model.springs() {
            let (a, c) = (spring.a, spring.b);
            let k = spring.stiffness;
            let l = x[a] - x[c];
            let len = l.norm();
            let direction = if len > 1e-14 {
                l / len
            } else {
                let rest = self.model.rest_positions()[a] - self.model.rest_positions()[c];
                rest.try_normalize(1e-14).unwrap_or_else(Vec3::x)
            };
            let projected = direction * spring.rest_length;
            b[a] += projected * k;
            b[c] -= projected * k;
            let f = (projected - l) * k;
            force[a] += f;
            force[c] -= f;
            // Dirichlet pins: the pinned end's coupling moves to the free end's right-hand side.
            if is_pinned[a] && !is_pinned[c] {
                b[c] += x[a] * k;
            } else if is_pinned[c] && !is_pinned[a] {
                b[a] += x[c] * k;
            }
        }
        for i in 0..n {
            if is_pinned[i] {
                b[i] = x[i] * self.base_diag[i];
                continue;
            }
            if let Some(p) = targets[i] {
                let w = self.contact_weight[i];
                b[i] += p * w;
                force[i] += (p - x[i]) * w;
            } else if in_matrix[i] {
                // Factorised as a contact but currently free: a proximal pull to itself.
                b[i] += x[i] * self.contact_weight[i];
            }
        }
        for i in 0..n {
            rhs[i] = b[i].x;
            rhs[n + i] = b[i].y;
            rhs[2 * n + i] = b[i].z;
        }
    }

    fn factorize(&mut self, in_matrix: &[bool], is_pinned: &[bool]) -> Result<()> {
        let n = self.model.vertex_count();
        self.matrix_values.iter_mut().for_each(|v| *v = 0.0);
        for i in 0..n {
            let contact = if in_matrix[i] && !is_pinned[i] {
                self.contact_weight[i]
            } else {
                0.0
            };
            self.matrix_values[self.diag_slot[i]] = self.base_diag[i] + contact;
        }
        for (spring, &slot) in self.model.springs().iter().zip(&self.spring_slot) {
            if !is_pinned[spring.a] && !is_pinned[spring.b] {
                self.matrix_values[slot] -= spring.stiffness;
            }
        }
        let pattern =
            SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
        let matrix = SparseColMatRef::new(pattern, &self.matrix_values);
        let mut buffer = MemBuffer::new(
            self.symbolic
                .factorize_numeric_llt_scratch::<Real>(Par::Seq, Default::default()),
        );
        self.symbolic
            .factorize_numeric_llt(
                &mut self.factor_values,
                matrix,
                Side::Upper,
                LltRegularization::default(),
                Par::Seq,
                MemStack::new(&mut buffer),
                Default::default(),
            )
            .map_err(|e| Error::Factorization(format!("{e:?}")))?;
        self.factored_for = Some((in_matrix.to_vec(), is_pinned.to_vec()));
        Ok(())
    }

    fn solve(&self, rhs: &mut [Real], buffer: &mut MemBuffer) {
        let n = self.model.vertex_count();
        let llt = LltRef::new(&self.symbolic, &self.factor_values);
        let rhs = MatMut::from_column_major_slice_mut(rhs, n, 3);
        llt.solve_in_place_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(buffer));
    }

    fn max_strain(&self, x: &[Vec3]) -> Real {
        self.model
            .springs()
            .iter()
            .filter(|s| s.rest_length > 0.0)
            .map(|s| ((x[s.a] - x[s.b]).norm() - s.rest_length) / s.rest_length)
            .fold(Real::NEG_INFINITY, Real::max)
    }
}

/// RMS and maximum over free vertices of `|f_i| / (m_i g)`.
fn normalised_residual(
    force: &[Vec3],
    masses: &[Real],
    is_pinned: &[bool],
    gravity: Real,
    free_count: usize,
) -> (Real, Real) {
    let mut sum = 0.0;
    let mut max: Real = 0.0;
    for i in 0..force.len() {
        if is_pinned[i] {
            continue;
        }
        let e = force[i].norm() / (masses[i] * gravity);
        sum += e * e;
        max = max.max(e);
    }
    ((sum / free_count as Real).sqrt(), max)
}

fn validate_settings(s: &DrapeSettings) -> Result<()> {
    let checks: [(&str, Real, Real, Real); 7] = [
        ("time step (seconds)", s.time_step, 1e-6, 10.0),
        ("residual tolerance", s.residual_tolerance, 0.0, Real::MAX),
        ("gravity (m/s^2)", s.gravity, 1e-6, Real::MAX),
        ("contact margin (metres)", s.contact_margin, 0.0, 1.0),
        ("contact weight ratio", s.contact_weight_ratio, 1e-3, 1e9),
        ("friction coefficient", s.friction, 0.0, 10.0),
        ("Chebyshev rho", s.chebyshev_rho, 0.0, 0.9999),
    ];
    for (what, value, min, max) in checks {
        if !(value >= min && value <= max) {
            return Err(CoreError::OutOfRange {
                what: format!("drape setting {what}"),
                value,
                min,
                max,
                hint: String::new(),
            }
            .into());
        }
    }
    if s.max_iterations == 0 {
        return Err(CoreError::OutOfRange {
            what: "drape setting max_iterations".into(),
            value: 0.0,
            min: 1.0,
            max: Real::MAX,
            hint: String::new(),
        }
        .into());
    }
    Ok(())
}
