//! Tuning knobs of the static-drape solver.

use garmatnet_core::{Error as CoreError, Real};
use serde::{Deserialize, Serialize};

use crate::error::Result;

/// Largest multiple of the Newton step the line search's expansion tries
/// ([`DrapeSettings::step_expansion`]'s upper bound).
pub(crate) const MAX_EXPANSION: Real = 64.0;

/// Settings of [`crate::DrapeSolver`]. The defaults drape garment-sized cloth (a few
/// thousand vertices, 0.01 to 20,000 N/m springs, 0.002 to 10 kg/m^2) to static equilibrium.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DrapeSettings {
    /// Initial pseudo time step `h` (seconds) of the pseudo-transient continuation: each
    /// Newton step minimises `E(x) + |x - x_k|^2_M / (2 h^2)`, so a small `h` keeps the first
    /// steps of a cold drape gentle (a free vertex moves about `g h^2`). `h` then adapts
    /// (switched evolution relaxation: it grows as the residual falls).
    pub time_step: Real,
    /// Largest pseudo time step (seconds); beyond a few seconds the steps are plain Newton.
    pub max_time_step: Real,
    /// Newton iteration cap; the drape reports `converged = false` when it is reached.
    pub max_iterations: usize,
    /// Convergence threshold on the RMS over free vertices of `|f_i| / (m_i g)` (net force,
    /// friction included, over the vertex's weight; dimensionless).
    pub residual_tolerance: Real,
    /// Convergence threshold on the largest `|f_i| / (m_i g)` over free vertices.
    pub max_residual_tolerance: Real,
    /// Gravitational acceleration (m/s^2), acting along -y.
    pub gravity: Real,
    /// Contact margin (metres): the penalty pushes cloth closer than this to the collider
    /// back out, so at rest cloth sits a little inside the margin, outside the collider.
    pub contact_margin: Real,
    /// Contact penalty stiffness of a vertex relative to the sum of its incident spring
    /// stiffnesses (dimensionless). Default 0: the force a body exerts on draped cloth is set
    /// by the load (weight, and tension times curvature), not by the cloth's stiffness, and
    /// penalties 10^5 times stiffer than the load stalled Newton on every landing vertex.
    pub contact_stiffness_ratio: Real,
    /// Contact penalty stiffness (N/m) when the ratio gives less. The default 300 N/m holds
    /// the largest contact loads of a draped shirt (~0.02 N per vertex) within 0.1 mm.
    pub min_contact_stiffness: Real,
    /// Hardening of the contact penalty inside the collider: length scale `ℓ` (metres) of
    /// an extra energy `k h³ / (3ℓ)`, `h` the depth past 1 mm below the surface (force
    /// `k h²/ℓ`, stiffness `2k h/ℓ`, both zero where it begins, so the energy stays twice
    /// differentiable; shallower dips of Newton's steps are left to the plain penalty, which
    /// pushes them back). 0 turns it off. The plain penalty holds a draped shirt's weight
    /// within 0.1 mm, but a stiff fabric wrapped around a moving arm pulls harder than that:
    /// Trim Fusible Rigid's sleeve settled 29 mm inside the arm before the final projection
    /// moved it out, and the walk snagged and tore the sleeve over the following frames.
    /// Default 1e-4 (0.1 mm: 5 mm deep the penalty pushes 50 N instead of 2.4). Manifests
    /// written before it existed read as 0, as they were made
    /// ([`crate::SequenceSettings::from_manifest`]).
    pub contact_hardening: Real,
    /// Coulomb friction coefficient between cloth and collider (dimensionless; 0 is
    /// frictionless). Friction is smooth and lagged (normals and normal forces held from the
    /// start of each drape, as incremental potential contact does) and acts on each contact
    /// vertex's slip from its anchor, so a shirt on a moving body stays
    /// where it landed unless pulled harder than the Coulomb bound. Default 0.3 (cotton on
    /// skin): with it (and [`crate::SequenceSettings::follow_body`]) drapes of two fabrics
    /// 0.5 % apart in ω lay 2.6 mm apart on average instead of 14 mm frictionless (3.1
    /// instead of 46 mm in the worst frame; book/src/solver.md, "The ground truth's noise
    /// floor"). 0 gives the frictionless contact of datasets made before this default.
    pub friction: Real,
    /// Slip length of the friction (metres): below it static friction is a spring of
    /// stiffness `2 μ λ / ε`; beyond it the vertex slides against `μ λ`.
    pub friction_slip: Real,
    /// Largest move of any vertex in one Newton step (metres): the whole step is scaled
    /// down to it, so no vertex tunnels through a thin body part.
    pub max_step: Real,
    /// Line-search expansion factor (1 to 64; 1 turns it off). Once the pseudo time step
    /// has reached [`DrapeSettings::max_time_step`] (plain Newton), a full step that lowers
    /// the energy is lengthened by this factor again and again while the energy keeps
    /// falling, up to [`DrapeSettings::max_step`] per vertex. The PSD-projected spring
    /// Hessian leaves out the negative transverse stiffness of compressed springs, so where
    /// cloth buckles and folds settle the Newton model is stiffer than the cloth and its
    /// steps fall short. Default 2: 27 % fewer Newton iterations settling the T-shirt at each
    /// pose (book/src/solver.md). A walk's intermediate steps (4 iterations
    /// at the default [`crate::SequenceSettings::intermediate_iterations`]) never reach plain
    /// Newton, so the walk itself is unchanged. Manifests written
    /// before it existed read as 1 ([`crate::SequenceSettings::from_manifest`]).
    pub step_expansion: Real,
    /// Precision of the Newton matrix's Cholesky factorisation, the bulk of a drape's time.
    /// Default [`FactorPrecision::Double`]. [`FactorPrecision::Mixed`] factors in single
    /// precision (about 1.5x faster) and refines each solve against the double-precision
    /// matrix to a relative residual of 1e-9: T-shirt walks 12–23 % faster, to drapes
    /// within the ground truth's noise floor of the double-precision ones, but the steps'
    /// 1e-9 errors grow where an equilibrium is unstable (a sheet balanced on a sphere
    /// slides off it), so it is opt-in (book/src/solver.md). Manifests
    /// written before it existed lack it and read as `Double`, as they were made.
    pub factor_precision: FactorPrecision,
}

/// Floating-point precision of the drape solver's Cholesky factorisation
/// ([`DrapeSettings::factor_precision`]; `"double"` or `"mixed"` in JSON).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FactorPrecision {
    /// Factor and solve in double precision.
    #[default]
    Double,
    /// Factor in single precision and refine each solve against the double-precision
    /// matrix until its relative residual is below 1e-9; where single precision fails
    /// (a pivot lost to rounding) or refinement stalls (an ill-conditioned matrix), that
    /// matrix is factored in double precision instead.
    Mixed,
}

impl Default for DrapeSettings {
    fn default() -> Self {
        Self {
            time_step: 0.02,
            max_time_step: 10.0,
            max_iterations: 300,
            residual_tolerance: 1e-3,
            max_residual_tolerance: 5e-2,
            gravity: 9.81,
            contact_margin: 0.003,
            contact_stiffness_ratio: 0.0,
            min_contact_stiffness: 300.0,
            contact_hardening: 1e-4,
            friction: 0.3,
            friction_slip: 1e-3,
            max_step: 0.02,
            step_expansion: 2.0,
            factor_precision: FactorPrecision::Double,
        }
    }
}

impl DrapeSettings {
    /// Checks every setting against the range the solver works in (finite, positive time
    /// steps and tolerances, a margin and step limit of sensible size, an expansion factor
    /// from 1 to 64, at least one iteration). [`crate::DrapeSolver`] does so on creation and
    /// on [`crate::DrapeSolver::set_settings`]; call it to check settings read from a file
    /// before a long run.
    ///
    /// # Errors
    /// [`garmatnet_core::Error::OutOfRange`] (as [`crate::Error::Core`]) naming the first
    /// setting outside its range, with the range.
    pub fn validate(&self) -> Result<()> {
        let checks: [(&str, Real, Real, Real); 13] = [
            ("time step (seconds)", self.time_step, 1e-6, 1e3),
            (
                "max time step (seconds)",
                self.max_time_step,
                self.time_step,
                1e3,
            ),
            (
                "residual tolerance",
                self.residual_tolerance,
                0.0,
                Real::MAX,
            ),
            (
                "max residual tolerance",
                self.max_residual_tolerance,
                0.0,
                Real::MAX,
            ),
            ("gravity (m/s^2)", self.gravity, 1e-6, Real::MAX),
            ("contact margin (metres)", self.contact_margin, 0.0, 1.0),
            (
                "contact stiffness ratio",
                self.contact_stiffness_ratio,
                0.0,
                1e9,
            ),
            (
                "min contact stiffness (N/m)",
                self.min_contact_stiffness,
                1e-6,
                1e12,
            ),
            (
                "contact hardening length (metres; 0 is off)",
                self.contact_hardening,
                0.0,
                1.0,
            ),
            ("friction coefficient", self.friction, 0.0, 10.0),
            (
                "friction slip length (metres)",
                self.friction_slip,
                1e-7,
                0.1,
            ),
            ("max step (metres)", self.max_step, 1e-9, 10.0),
            (
                "step expansion factor",
                self.step_expansion,
                1.0,
                MAX_EXPANSION,
            ),
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
        if self.max_iterations == 0 {
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
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_outside_the_solvers_range_are_refused_by_name() {
        assert!(DrapeSettings::default().validate().is_ok());
        let refused = |settings: DrapeSettings, name: &str| {
            let err = settings.validate().unwrap_err().to_string();
            assert!(err.contains(name), "{err}");
        };
        refused(
            DrapeSettings {
                time_step: Real::NAN,
                ..DrapeSettings::default()
            },
            "time step",
        );
        refused(
            DrapeSettings {
                step_expansion: MAX_EXPANSION * 2.0,
                ..DrapeSettings::default()
            },
            "step expansion",
        );
        refused(
            DrapeSettings {
                max_iterations: 0,
                ..DrapeSettings::default()
            },
            "max_iterations",
        );
    }
}
