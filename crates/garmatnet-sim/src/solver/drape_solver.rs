//! The static-drape solver: Newton's method with pseudo-transient continuation on the
//! drape energy (springs, gravity, penalty contact; see `drape_energy.rs`) plus smooth,
//! lagged Coulomb friction.
//!
//! Iteration `k` takes one damped Newton step on
//! `Φ_k(x) = E(x) + D(x) + |x - x_k|^2_M / (2h^2)`: it solves `(M/h^2 + H) Δ = -∇Φ_k(x_k)`
//! with `H` the PSD-projected spring Hessian, `k_c n nᵀ` per contact and the friction
//! potential's Hessian, then backtracks on `Φ_k` (Armijo). Once `h` has reached its
//! largest value (plain Newton), a full step that lowers `Φ_k` is lengthened by
//! [`DrapeSettings::step_expansion`] again and again while `Φ_k` keeps falling: the
//! projection drops the negative transverse stiffness of compressed springs, so the model is
//! stiffer than the cloth where it buckles and its steps fall short as folds settle.
//! `D` is the friction potential
//! of Li et al. 2020's incremental potential contact, quasi-static: it charges each contact
//! vertex for its tangential slip from its anchor, as a stiff spring within the slip length
//! and as `μ λ` per metre beyond. It acts on the vertices in contact at the start of the
//! drape, with their normals and normal forces `λ` lagged there and held, so Newton
//! minimises one smooth potential (incremental potential contact lags once per time step
//! the same way). Cloth that lands during a drape slides freely until the next one, which
//! is one reason a moving body is draped in small steps ([`crate::drape_sequence`]). The
//! anchors are where the caller says: where each vertex would be had it moved with the body
//! since it settled. `λ` is the load the body carries (springs and gravity pressing in),
//! which the stiff penalty's force equals only at equilibrium.
//! Measured and rejected on the T-shirt: giving friction to cloth as it lands (anchored
//! there) put the drapes of two nearly equal fabrics 1.6 times as far apart, and
//! re-lagging at the equilibrium reached and going on (IPC's outer iterations) pushed two
//! of four poses past the 300-iteration cap.
//! The residual is a force balance: springs + gravity + contact + friction, over the
//! vertex's weight.

use std::time::Instant;

use garmatnet_core::error::ensure_finite;
use garmatnet_core::{Error as CoreError, Mat3, Real, SignedDistance, Vec3};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::solver::cloth_model::ClothModel;
use crate::solver::contact::{Friction, push_out};
use crate::solver::drape_energy::{Contact, DrapeEnergy, contact_stiffness};
use crate::solver::drape_settings::{DrapeSettings, MAX_EXPANSION};
use crate::solver::newton_system::NewtonSystem;

/// Armijo sufficient-decrease constant.
const ARMIJO: Real = 1e-4;
/// Halvings of the step before it is rejected.
const MAX_BACKTRACKS: usize = 10;
/// Growth of the pseudo time step after a full, unclamped Newton step.
const GROWTH: Real = 3.0;
/// Below this multiple of the RMS residual tolerance, a Newton step the line search refuses
/// is still taken if it lowers the force residual.
const NEAR_EQUILIBRIUM: Real = 100.0;
/// Smallest pseudo time step (seconds).
const MIN_TIME_STEP: Real = 1e-6;

/// What one drape did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DrapeStats {
    /// Newton iterations run (one numeric factorisation each).
    pub iterations: usize,
    /// Final normalised residual: RMS over free vertices of `|f_i| / (m_i g)`, with `f_i`
    /// the net force (springs + gravity + contact + friction) on vertex `i`.
    pub final_residual: Real,
    /// Final largest `|f_i| / (m_i g)` over free vertices.
    pub max_residual: Real,
    /// Deepest remaining penetration into the collider after the final projection
    /// (metres, >= 0), at the free vertices. A recorded drape (a dataset sample,
    /// [`crate::simulate_drape`], a frame of [`crate::drape_sequence`]) reports it at points
    /// across its triangles too, after their push out of the body
    /// ([`garmatnet_core::push_mesh_outside`]), and its strain there; its residuals,
    /// contacts and convergence stay the solver's, from before that push.
    pub max_penetration: Real,
    /// Deepest vertex inside the collider at the solver's last iterate, before the final
    /// projection moved it out (metres, >= 0): how far the contact penalty let the cloth
    /// sink. 0 in stats recorded before it existed.
    #[serde(default)]
    pub max_depth_before_projection: Real,
    /// Largest spring strain `(l - rest) / rest` (dimensionless; negative when all springs
    /// are compressed).
    pub max_strain: Real,
    /// Vertices in contact at the end (within the margin of the collider).
    pub contacts: usize,
    /// Sum of the contact forces (normal penalty + friction) on the cloth at the last
    /// iterate (newtons); at equilibrium without pins it balances the cloth's weight.
    pub contact_force: Vec3,
    /// Numeric Cholesky factorisations done (one per Newton iteration).
    pub refactorizations: usize,
    /// Newton steps rejected by the line search (the pseudo time step shrank).
    pub rejected_steps: usize,
    /// Newton steps lengthened beyond the full step by the line search's expansion
    /// ([`DrapeSettings::step_expansion`]); 0 in stats recorded before it existed.
    #[serde(default)]
    pub expanded_steps: usize,
    /// Wall-clock time of the drape (milliseconds).
    pub wall_time_ms: Real,
    /// Whether both residual tolerances were met before the iteration cap.
    pub converged: bool,
}

impl DrapeStats {
    /// Adds the cost of `earlier`, a drape of the same garment this one continued
    /// (iterations, factorisations, rejected and expanded steps, wall time); the state
    /// figures (residuals, strain, contacts, convergence) stay this drape's.
    pub fn add_cost_of(&mut self, earlier: &DrapeStats) {
        self.iterations += earlier.iterations;
        self.refactorizations += earlier.refactorizations;
        self.rejected_steps += earlier.rejected_steps;
        self.expanded_steps += earlier.expanded_steps;
        self.wall_time_ms += earlier.wall_time_ms;
    }
}

/// The solver for one cloth topology: owns the Newton system's symbolic Cholesky
/// factorisation (computed once in [`DrapeSolver::new`]); each iteration only refactors
/// numerically.
#[derive(Debug, Clone)]
pub struct DrapeSolver {
    model: ClothModel,
    settings: DrapeSettings,
    system: NewtonSystem,
    /// Contact penalty stiffness per vertex (N/m).
    contact_stiffness: Vec<Real>,
}

impl DrapeSolver {
    /// A solver for `model`, with its symbolic factorisation (fill-reducing ordering and
    /// elimination tree) computed once.
    ///
    /// # Errors
    /// [`CoreError::OutOfRange`] for invalid settings (non-positive time steps, iteration
    /// cap, tolerances, gravity or step limit; negative margin or friction);
    /// [`Error::Factorization`] if the symbolic analysis fails (out of memory).
    pub fn new(model: &ClothModel, settings: &DrapeSettings) -> Result<Self> {
        settings.validate()?;
        let mut solver = Self {
            system: NewtonSystem::new(model)?,
            model: model.clone(),
            settings: settings.clone(),
            contact_stiffness: Vec::new(),
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
        settings.validate()?;
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

    /// Non-zeros of the Cholesky factor of the 3n x 3n Newton matrix (its cost driver).
    #[must_use]
    pub fn factor_nonzeros(&self) -> usize {
        self.system.factor_len()
    }

    /// The contact penalty stiffness of each vertex (N/m), as [`contact_stiffness`] gives
    /// it for the model and settings.
    #[must_use]
    pub fn contact_stiffness(&self) -> &[Real] {
        &self.contact_stiffness
    }

    fn update_weights(&mut self) {
        self.contact_stiffness = contact_stiffness(&self.model, &self.settings);
    }

    /// Drapes the cloth from `positions` (metres; the warm start, e.g. the previous pose's
    /// result) to static equilibrium under gravity against `collider`, holding the
    /// `pinned` vertices at their given positions. Writes the result into `positions`.
    /// Friction (when [`DrapeSettings::friction`] is positive) resists slip from where each
    /// vertex starts: the collider is taken to be at rest. For a collider that moved since
    /// `positions` settled, use [`DrapeSolver::drape_with_anchors`].
    ///
    /// # Errors
    /// As [`DrapeSolver::drape_with_anchors`].
    pub fn drape(
        &mut self,
        positions: &mut [Vec3],
        collider: &impl SignedDistance,
        pinned: &[usize],
    ) -> Result<DrapeStats> {
        let anchors = positions.to_vec();
        self.drape_with_anchors(positions, &anchors, collider, pinned)
    }

    /// As [`DrapeSolver::drape`], with friction measured from `anchors` (metres, one per
    /// vertex): where each vertex would be had it moved with the collider since it last
    /// settled (for a posed body, the previous result carried by
    /// [`garmatnet_core::PosedBody::carry_to`]). A vertex in contact then sticks to the
    /// body within [`DrapeSettings::friction_slip`] and slides only when the tangential
    /// load passes the Coulomb bound. Anchors of vertices out of contact are not used.
    ///
    /// # Errors
    /// - [`CoreError::WrongLength`] if `positions` or `anchors` does not have one entry per
    ///   vertex;
    /// - [`CoreError::NonFinite`] for NaN or infinite positions or anchors;
    /// - [`CoreError::OutOfRange`] for a pinned index past the vertices;
    /// - [`Error::Factorization`] if the Newton matrix is not positive definite;
    /// - [`Error::Diverged`] if an iterate became non-finite (`positions` is then left at
    ///   the last finite iterate).
    pub fn drape_with_anchors(
        &mut self,
        positions: &mut [Vec3],
        anchors: &[Vec3],
        collider: &impl SignedDistance,
        pinned: &[usize],
    ) -> Result<DrapeStats> {
        let start = Instant::now();
        let n = self.model.vertex_count();
        for (what, len) in [
            ("cloth positions", positions.len()),
            ("friction anchors", anchors.len()),
        ] {
            if len != n {
                return Err(CoreError::WrongLength {
                    what: what.into(),
                    expected: n.to_string(),
                    got: len,
                }
                .into());
            }
        }
        ensure_finite(
            "cloth positions (metres)",
            positions.iter().flat_map(|v| [v.x, v.y, v.z]),
        )?;
        ensure_finite(
            "friction anchors (metres)",
            anchors.iter().flat_map(|v| [v.x, v.y, v.z]),
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
        let model = self.model.clone();
        let masses = model.masses();
        let energy = DrapeEnergy {
            model: &model,
            gravity: s.gravity,
            margin: s.contact_margin,
            contact_stiffness: &self.contact_stiffness,
            is_pinned: &is_pinned,
            hardening: s.contact_hardening,
        };
        let mut friction = Friction::new(s.friction, s.friction_slip, anchors);

        let mut contacts: Vec<Option<Contact>> = vec![None; n];
        let mut gradient = vec![Vec3::zeros(); n];
        let mut diagonal = vec![Mat3::zeros(); n];
        let mut coupling = vec![Mat3::zeros(); model.springs().len()];
        let mut rhs = vec![0.0; 3 * n];
        let mut trial = positions.to_vec();
        let mut trial_contacts = contacts.clone();
        let mut trial_gradient = gradient.clone();
        let mut h = s.time_step;
        let mut iterations = 0;
        let mut rejected_steps = 0;
        let mut expanded_steps = 0;
        let (residual, max_residual, contact_force, converged) = loop {
            // The gradient of Φ_k at x_k (conservative forces plus friction) and the
            // force-balance residual.
            energy.gradient(positions, collider, &mut contacts, &mut gradient);
            if iterations == 0 {
                friction.lag(&energy, &contacts, &gradient);
            }
            let balance = friction.add_to_gradient(positions, &mut gradient);
            let (rms, max) = force_residual(&gradient, masses, &is_pinned, s.gravity);
            let done = rms <= s.residual_tolerance && max <= s.max_residual_tolerance;
            if done || iterations >= s.max_iterations {
                let contact_force = (0..n)
                    .filter_map(|i| contacts[i].map(|c| energy.penalty_force(i, &c)))
                    .fold(balance, |sum, f| sum + f);
                break (rms, max, contact_force, done);
            }
            for i in 0..n {
                diagonal[i] = if is_pinned[i] {
                    Mat3::identity()
                } else {
                    Mat3::identity() * (masses[i] / (h * h))
                };
            }
            energy.add_hessian(positions, &contacts, &mut diagonal, &mut coupling);
            friction.add_hessian(positions, &mut diagonal);
            self.system
                .factorize(&diagonal, &coupling, s.factor_precision)?;
            iterations += 1;
            for i in 0..n {
                let g = -gradient[i];
                rhs[3 * i] = g.x;
                rhs[3 * i + 1] = g.y;
                rhs[3 * i + 2] = g.z;
            }
            self.system.solve(&mut rhs)?;
            let longest = (0..n)
                .map(|i| Vec3::new(rhs[3 * i], rhs[3 * i + 1], rhs[3 * i + 2]).norm())
                .fold(0.0, Real::max);
            if !longest.is_finite() {
                return Err(Error::Diverged {
                    iteration: iterations,
                });
            }
            let scale = if longest > s.max_step {
                s.max_step / longest
            } else {
                1.0
            };
            let step: Vec<Vec3> = (0..n)
                .map(|i| Vec3::new(rhs[3 * i], rhs[3 * i + 1], rhs[3 * i + 2]) * scale)
                .collect();
            let slope: Real = (0..n).map(|i| gradient[i].dot(&step[i])).sum();
            // Φ_k(x_k + α step) - Φ_k(x_k): E change + lagged friction + proximal (inertia)
            // term.
            let phi_change = |alpha: Real, trial: &mut [Vec3]| {
                for i in 0..n {
                    trial[i] = positions[i] + step[i] * alpha;
                }
                let mut change = energy.change(positions, trial, &contacts, collider)
                    + friction.change(positions, trial);
                for i in 0..n {
                    let d = step[i] * alpha;
                    change += 0.5 * masses[i] / (h * h) * d.norm_squared();
                }
                change
            };
            // Backtracking (Armijo) from the full step.
            let mut alpha = 1.0;
            let mut accepted = false;
            for _ in 0..=MAX_BACKTRACKS {
                let change = phi_change(alpha, &mut trial);
                if change <= ARMIJO * alpha * slope {
                    accepted = true;
                    if alpha == 1.0 && s.step_expansion > 1.0 && h >= s.max_time_step {
                        // A full step that lowered Φ: lengthen it while Φ keeps falling.
                        let step_length = longest * scale;
                        let (mut best, mut next) = (change, s.step_expansion);
                        while next * step_length <= s.max_step && next <= MAX_EXPANSION {
                            let longer = phi_change(next, &mut trial);
                            if longer.is_nan() || longer >= best {
                                break;
                            }
                            (best, alpha, next) = (longer, next, next * s.step_expansion);
                        }
                        if alpha > 1.0 {
                            expanded_steps += 1;
                        }
                        for i in 0..n {
                            trial[i] = positions[i] + step[i] * alpha;
                        }
                    }
                    break;
                }
                alpha *= 0.5;
            }
            if !accepted && rms <= NEAR_EQUILIBRIUM * s.residual_tolerance {
                // Near equilibrium a Newton step changes the energy by ~1e-10 J, where the
                // energy test loses its resolution (and a contact crossing the margin bends
                // it), and Armijo can fail at every length: without this the pseudo time step
                // shrinks to nothing and the drape stalls at the cap a hair above the
                // tolerance. Take the full step if it lowers the force residual.
                for i in 0..n {
                    trial[i] = positions[i] + step[i];
                }
                energy.gradient(&trial, collider, &mut trial_contacts, &mut trial_gradient);
                friction.add_to_gradient(&trial, &mut trial_gradient);
                let (trial_rms, _) = force_residual(&trial_gradient, masses, &is_pinned, s.gravity);
                if trial_rms < rms {
                    accepted = true;
                    alpha = 1.0;
                }
            }
            if accepted {
                if trial.iter().any(|p| !p.iter().all(|v| v.is_finite())) {
                    return Err(Error::Diverged {
                        iteration: iterations,
                    });
                }
                positions.copy_from_slice(&trial);
                // Full steps grow h towards plain Newton; damped ones mean it was too bold.
                h = if alpha >= 1.0 && scale == 1.0 {
                    h * GROWTH
                } else if alpha >= 1.0 {
                    h
                } else {
                    h * 0.5
                };
                h = h.clamp(MIN_TIME_STEP, s.max_time_step);
            } else {
                rejected_steps += 1;
                h = (h * 0.25).max(MIN_TIME_STEP);
            }
        };
        let max_depth_before_projection = positions
            .iter()
            .zip(&is_pinned)
            .filter(|(_, pinned)| !**pinned)
            .map(|(x, _)| -collider.distance(x))
            .fold(0.0, Real::max);
        let max_penetration = push_out(positions, collider, &is_pinned);
        let contacts = (0..n)
            .filter(|&i| !is_pinned[i] && collider.distance(&positions[i]) < s.contact_margin)
            .count();
        Ok(DrapeStats {
            iterations,
            final_residual: residual,
            max_residual,
            max_penetration,
            max_depth_before_projection,
            max_strain: self.model.max_strain(positions)?,
            contacts,
            contact_force,
            refactorizations: iterations,
            rejected_steps,
            expanded_steps,
            wall_time_ms: start.elapsed().as_secs_f64() * 1e3,
            converged,
        })
    }
}

/// The solver's stopping measure: the RMS and the largest `|f_i| / (m_i g)` over the free
/// vertices (`is_pinned[i]` false), for net forces `f = -gradient`. [`DrapeSettings`]'s
/// residual tolerances are in these units. `gradient`, `masses` and `is_pinned` hold one
/// entry per vertex, in the same order.
///
/// [`DrapeSettings`]: crate::DrapeSettings
#[must_use]
pub fn force_residual(
    gradient: &[Vec3],
    masses: &[Real],
    is_pinned: &[bool],
    gravity: Real,
) -> (Real, Real) {
    let (sum, max, count) = gradient
        .iter()
        .zip(masses)
        .zip(is_pinned)
        .filter(|(_, pinned)| !**pinned)
        .fold(
            (0.0, 0.0 as Real, 0usize),
            |(sum, max, count), ((g, m), _)| {
                let e = g.norm() / (m * gravity);
                (sum + e * e, max.max(e), count + 1)
            },
        );
    ((sum / count.max(1) as Real).sqrt(), max)
}
