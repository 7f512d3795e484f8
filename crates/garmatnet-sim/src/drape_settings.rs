//! Tuning knobs of the static-drape solver.

use garmatnet_core::Real;
use serde::{Deserialize, Serialize};

/// Settings of [`crate::DrapeSolver`]. The defaults drape garment-sized cloth (a few
/// thousand vertices, 0.1 to 1000 N/m springs) to static equilibrium.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct DrapeSettings {
    /// Pseudo time step `h` of the implicit-Euler steps (seconds). The global matrix is
    /// `M / h^2 + L`: larger steps converge faster on soft cloth but must keep the matrix
    /// well conditioned when nothing (pins, contact) holds the cloth.
    pub time_step: Real,
    /// Iteration cap; the drape reports `converged = false` when it is reached.
    pub max_iterations: usize,
    /// Convergence threshold on the normalised residual: the root mean square over free
    /// vertices of `|f_i| / (m_i g)` (net force over the vertex's weight, dimensionless).
    pub residual_tolerance: Real,
    /// Gravitational acceleration (m/s^2), acting along -y.
    pub gravity: Real,
    /// Contact margin (metres): cloth is kept this far outside the collider.
    pub contact_margin: Real,
    /// Contact penalty weight relative to the vertex's own diagonal stiffness
    /// (`m/h^2 + sum of incident spring stiffnesses`): dimensionless, >> 1 keeps contacts
    /// within a small fraction of the margin.
    pub contact_weight_ratio: Real,
    /// Coulomb friction coefficient between cloth and collider (0 = frictionless).
    pub friction: Real,
    /// Chebyshev semi-iterative acceleration (Wang 2015): estimated spectral radius of the
    /// plain local/global iteration, in [0, 1); 0 disables it.
    pub chebyshev_rho: Real,
    /// Iterations before the Chebyshev acceleration starts (and after each refactorisation).
    pub chebyshev_delay: usize,
}

impl Default for DrapeSettings {
    fn default() -> Self {
        Self {
            time_step: 0.1,
            max_iterations: 3000,
            residual_tolerance: 1e-2,
            gravity: 9.81,
            contact_margin: 0.003,
            contact_weight_ratio: 10.0,
            friction: 0.3,
            chebyshev_rho: 0.99,
            chebyshev_delay: 10,
        }
    }
}
