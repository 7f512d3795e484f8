//! The conservative part of the drape energy: springs, gravity and penalty contact,
//!
//! `E(x) = Σ_s k_s/2 (|x_a - x_b| - L_s)^2 + Σ_i m_i g y_i + Σ_i k_c,i/2 max(0, margin - φ(x_i))^2`,
//!
//! with its gradient, its positive semi-definite Hessian approximation and energy
//! differences computed term by term (so the line search can compare energies near
//! convergence, where the total is dominated by gravity and rounding would hide the change).
//!
//! This is the one definition of the drape's potential: [`drape_energy_and_gradient`] and
//! [`contact_stiffness`] expose it (per term) for code that evaluates the same energy
//! elsewhere, such as the training crate's differentiable version. Friction is not part
//! of it: it is path-dependent (it charges slip from where each vertex settled), so no
//! potential of the positions alone describes it; the solver adds it as a lagged potential
//! per drape (`contact.rs`).

use garmatnet_core::error::ensure_finite;
use garmatnet_core::{Error as CoreError, Mat3, Real, SignedDistance, Vec3, unit_normal};

use crate::error::Result;
use crate::solver::cloth_model::ClothModel;
use crate::solver::drape_settings::DrapeSettings;

/// The drape energy split by term (joules).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct EnergyTerms {
    /// `Σ_s k_s/2 (|x_a - x_b| - L_s)²` over every spring (structural, shear, flexion).
    pub springs: Real,
    /// `Σ_i m_i g y_i`: gravity's potential, zero at `y = 0`.
    pub gravity: Real,
    /// `Σ_i k_c,i/2 max(0, margin - φ(x_i))²` plus the hardening inside the body
    /// ([`DrapeSettings::contact_hardening`]).
    pub contact: Real,
}

impl EnergyTerms {
    /// The total (joules).
    #[must_use]
    pub fn total(&self) -> Real {
        self.springs + self.gravity + self.contact
    }
}

/// The contact penalty stiffness of each vertex (N/m): [`DrapeSettings::contact_stiffness_ratio`]
/// times the sum of the vertex's incident spring stiffnesses, at least
/// [`DrapeSettings::min_contact_stiffness`]. The solver's own penalty.
#[must_use]
pub fn contact_stiffness(model: &ClothModel, settings: &DrapeSettings) -> Vec<Real> {
    let mut incident = vec![0.0; model.vertex_count()];
    for s in model.springs() {
        incident[s.a] += s.stiffness;
        incident[s.b] += s.stiffness;
    }
    let (ratio, floor) = (
        settings.contact_stiffness_ratio,
        settings.min_contact_stiffness,
    );
    incident.iter().map(|k| (ratio * k).max(floor)).collect()
}

/// The solver's conservative drape energy of `model` at positions `x` (metres) against
/// `collider`, by term, and its gradient (newtons, one per vertex), with no vertex pinned.
/// Friction is left out: it charges slip from where each vertex settled, so no potential of
/// the positions alone describes it. The reference for any other
/// implementation of the energy.
///
/// # Errors
/// - As [`DrapeSettings::validate`] for invalid settings;
/// - [`CoreError::WrongLength`] if `x` does not have one position per vertex;
/// - [`CoreError::NonFinite`] for NaN or infinite positions.
pub fn drape_energy_and_gradient(
    model: &ClothModel,
    settings: &DrapeSettings,
    collider: &impl SignedDistance,
    x: &[Vec3],
) -> Result<(EnergyTerms, Vec<Vec3>)> {
    settings.validate()?;
    let n = model.vertex_count();
    if x.len() != n {
        return Err(CoreError::WrongLength {
            what: "cloth positions".into(),
            expected: n.to_string(),
            got: x.len(),
        }
        .into());
    }
    ensure_finite(
        "cloth positions (metres)",
        x.iter().flat_map(|v| [v.x, v.y, v.z]),
    )?;
    let stiffness = contact_stiffness(model, settings);
    let pinned = vec![false; n];
    let energy = DrapeEnergy {
        model,
        gravity: settings.gravity,
        margin: settings.contact_margin,
        contact_stiffness: &stiffness,
        hardening: settings.contact_hardening,
        is_pinned: &pinned,
    };
    let mut contacts = vec![None; n];
    let mut gradient = vec![Vec3::zeros(); n];
    energy.gradient(x, collider, &mut contacts, &mut gradient);
    Ok((energy.terms(x, &contacts), gradient))
}

/// A vertex within the contact margin of the collider.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Contact {
    /// Signed distance to the collider (metres, < margin).
    pub(crate) distance: Real,
    /// The distance field's gradient: the penalty's force is along it, with its length,
    /// so the force is the exact derivative of the penalty energy (a smooth union's
    /// gradient is shorter than unit in its blend regions).
    pub(crate) gradient: Vec3,
}

impl Contact {
    /// Outward unit normal (the gradient normalised), for friction.
    pub(crate) fn normal(&self) -> Vec3 {
        unit_normal(&self.gradient)
    }
}

/// Depth inside the collider (metres) where the penalty's hardening
/// ([`DrapeSettings::contact_hardening`]) begins. Newton steps
/// put cloth a fraction of a millimetre into the body on their way and the plain penalty
/// pushes it back; hardening those transients changed the path: Cotton Poplin's 12-frame
/// gentle walk at paper resolution, whose drapes never end inside the body, took 1,333
/// settle iterations with the hardening from the surface against 1,064 without, and the
/// same 1,064 with it from 1 mm (or 3 mm) down.
pub const HARDENING_DEPTH: Real = 1e-3;

/// The energy's constant data for one drape.
#[derive(Debug, Clone, Copy)]
pub(crate) struct DrapeEnergy<'a> {
    pub(crate) model: &'a ClothModel,
    /// Gravitational acceleration (m/s^2) along -y.
    pub(crate) gravity: Real,
    /// Contact margin (metres).
    pub(crate) margin: Real,
    /// Penalty stiffness per vertex (N/m).
    pub(crate) contact_stiffness: &'a [Real],
    /// Length scale `ℓ` (metres) of the penalty's hardening inside the collider (0: none;
    /// [`crate::DrapeSettings::contact_hardening`]).
    pub(crate) hardening: Real,
    pub(crate) is_pinned: &'a [bool],
}

impl DrapeEnergy<'_> {
    /// The contact of vertex `i` at `x`, if it lies within the margin.
    pub(crate) fn contact(
        &self,
        i: usize,
        x: &Vec3,
        collider: &impl SignedDistance,
    ) -> Option<Contact> {
        if self.is_pinned[i] {
            return None;
        }
        let (distance, gradient) = collider.distance_and_gradient(x);
        (distance < self.margin).then_some(Contact { distance, gradient })
    }

    /// How far past [`HARDENING_DEPTH`] inside the collider (metres) distance `φ` lies: the
    /// depth the hardening acts on (0 when it is off).
    fn depth(&self, distance: Real) -> Real {
        if self.hardening > 0.0 {
            (-distance - HARDENING_DEPTH).max(0.0)
        } else {
            0.0
        }
    }

    /// The hardening's energy at distance `φ`, added to the penalty's `k_c/2 (margin - φ)²`:
    /// `k_c h³ / (3 ℓ)` with `h = -φ - HARDENING_DEPTH > 0`, else 0 (so the energy stays
    /// twice differentiable where it begins: the extra force and stiffness start at zero).
    fn hardening_energy(&self, i: usize, distance: Real) -> Real {
        let h = self.depth(distance);
        if h > 0.0 {
            self.contact_stiffness[i] * h * h * h / (3.0 * self.hardening)
        } else {
            0.0
        }
    }

    /// The penalty's force on a contact: `k_c (margin - φ + h²/ℓ) ∇φ` (newtons, outward), `h`
    /// the hardening's depth.
    pub(crate) fn penalty_force(&self, i: usize, c: &Contact) -> Vec3 {
        let h = self.depth(c.distance);
        let hard = if h > 0.0 { h * h / self.hardening } else { 0.0 };
        c.gradient * (self.contact_stiffness[i] * (self.margin - c.distance + hard))
    }

    /// The penalty's stiffness along `∇φ` (N/m): `k_c (1 + 2h/ℓ)`.
    fn penalty_stiffness(&self, i: usize, c: &Contact) -> Real {
        let h = self.depth(c.distance);
        let hard = if h > 0.0 {
            2.0 * h / self.hardening
        } else {
            0.0
        };
        self.contact_stiffness[i] * (1.0 + hard)
    }

    /// The energy at `x` by term (joules), with `contacts` those at `x` ([`Self::gradient`]
    /// fills them). Pinned vertices count for nothing but their springs.
    pub(crate) fn terms(&self, x: &[Vec3], contacts: &[Option<Contact>]) -> EnergyTerms {
        let masses = self.model.masses();
        let mut terms = EnergyTerms::default();
        for i in 0..x.len() {
            if self.is_pinned[i] {
                continue;
            }
            terms.gravity += masses[i] * self.gravity * x[i].y;
            if let Some(c) = &contacts[i] {
                let gap = self.margin - c.distance;
                terms.contact += 0.5 * self.contact_stiffness[i] * gap * gap
                    + self.hardening_energy(i, c.distance);
            }
        }
        terms.springs = self
            .model
            .springs()
            .iter()
            .map(|s| {
                let stretch = (x[s.a] - x[s.b]).norm() - s.rest_length;
                0.5 * s.stiffness * stretch * stretch
            })
            .sum();
        terms
    }

    /// Fills `contacts` and `gradient` (newtons; zero on pinned vertices) at `x`.
    pub(crate) fn gradient(
        &self,
        x: &[Vec3],
        collider: &impl SignedDistance,
        contacts: &mut [Option<Contact>],
        gradient: &mut [Vec3],
    ) {
        let masses = self.model.masses();
        for i in 0..x.len() {
            gradient[i] = Vec3::new(0.0, masses[i] * self.gravity, 0.0);
            contacts[i] = self.contact(i, &x[i], collider);
            if let Some(c) = &contacts[i] {
                gradient[i] -= self.penalty_force(i, c);
            }
        }
        for s in self.model.springs() {
            let d = x[s.a] - x[s.b];
            let len = d.norm();
            if len > 0.0 {
                let g = d * (s.stiffness * (len - s.rest_length) / len);
                gradient[s.a] += g;
                gradient[s.b] -= g;
            }
        }
        for (g, &p) in gradient.iter_mut().zip(self.is_pinned) {
            if p {
                *g = Vec3::zeros();
            }
        }
    }

    /// Adds the Hessian's spring blocks (projected to PSD: the transverse term is dropped in
    /// compression) and contact blocks (Gauss-Newton `k_c ∇φ ∇φᵀ`) to `diagonal`, and writes
    /// the coupling blocks (`-K_s`, zero where a spring end is pinned) into `coupling`.
    pub(crate) fn add_hessian(
        &self,
        x: &[Vec3],
        contacts: &[Option<Contact>],
        diagonal: &mut [Mat3],
        coupling: &mut [Mat3],
    ) {
        for (s, block) in self.model.springs().iter().zip(coupling.iter_mut()) {
            let d = x[s.a] - x[s.b];
            let len = d.norm();
            let k = if len > 1e-12 * s.rest_length.max(1e-12) {
                let n = d / len;
                let nn = n * n.transpose();
                let transverse = (1.0 - s.rest_length / len).max(0.0);
                (nn + (Mat3::identity() - nn) * transverse) * s.stiffness
            } else {
                // Coincident ends: no direction, so stiffen isotropically (still PSD).
                Mat3::identity() * s.stiffness
            };
            let (pa, pb) = (self.is_pinned[s.a], self.is_pinned[s.b]);
            if !pa {
                diagonal[s.a] += k;
            }
            if !pb {
                diagonal[s.b] += k;
            }
            *block = if pa || pb { Mat3::zeros() } else { -k };
        }
        for (i, c) in contacts.iter().enumerate() {
            if let Some(c) = c {
                diagonal[i] += c.gradient * c.gradient.transpose() * self.penalty_stiffness(i, c);
            }
        }
    }

    /// `E(x1) - E(x0)` (joules), with `φ` evaluated at `x1` by `collider` and the contacts
    /// at `x0` given.
    pub(crate) fn change(
        &self,
        x0: &[Vec3],
        x1: &[Vec3],
        contacts0: &[Option<Contact>],
        collider: &impl SignedDistance,
    ) -> Real {
        let masses = self.model.masses();
        let mut delta = 0.0;
        for i in 0..x0.len() {
            if self.is_pinned[i] {
                continue;
            }
            delta += masses[i] * self.gravity * (x1[i].y - x0[i].y);
            let before = contacts0[i].map_or(0.0, |c| self.margin - c.distance);
            let contact1 = self.contact(i, &x1[i], collider);
            let after = contact1.map_or(0.0, |c| self.margin - c.distance);
            delta += 0.5 * self.contact_stiffness[i] * (after - before) * (after + before);
            if self.hardening > 0.0 {
                let hard =
                    |c: Option<Contact>| c.map_or(0.0, |c| self.hardening_energy(i, c.distance));
                delta += hard(contact1) - hard(contacts0[i]);
            }
        }
        for s in self.model.springs() {
            let (d0, d1) = (x0[s.a] - x0[s.b], x1[s.a] - x1[s.b]);
            let (l0, l1) = (d0.norm(), d1.norm());
            let sum = l0 + l1;
            // l1 - l0 from the squared lengths: exact where the lengths nearly agree.
            let dl = if sum > 0.0 {
                (d1.norm_squared() - d0.norm_squared()) / sum
            } else {
                0.0
            };
            delta += 0.5 * s.stiffness * dl * (l0 + l1 - 2.0 * s.rest_length);
        }
        delta
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::cloth_model::SpringSpec;
    use approx::assert_relative_eq;
    use garmatnet_core::Sphere;

    fn total(e: &DrapeEnergy<'_>, x: &[Vec3], sphere: &impl SignedDistance) -> Real {
        let zero: Vec<Vec3> = vec![Vec3::zeros(); x.len()];
        let none = vec![None; x.len()];
        // Energy relative to all vertices at the origin with springs at length 0 and no
        // contact: E(x) - E(0) + E(0), with E(0) = Σ k L^2 / 2.
        let base: Real = e
            .model
            .springs()
            .iter()
            .map(|s| 0.5 * s.stiffness * s.rest_length * s.rest_length)
            .sum();
        base + e.change(&zero, x, &none, sphere)
    }

    /// A sphere's distance halved: a distance bound whose gradient is shorter than unit,
    /// as a smooth union's is in its blend regions.
    struct HalvedSphere(Sphere);

    impl SignedDistance for HalvedSphere {
        fn distance_and_gradient(&self, p: &Vec3) -> (Real, Vec3) {
            let (d, g) = self.0.distance_and_gradient(p);
            (0.5 * d, 0.5 * g)
        }
    }

    #[test]
    fn gradient_matches_finite_differences() {
        for hardening in [0.0, 1e-3] {
            check_gradient(
                &Sphere {
                    centre: Vec3::zeros(),
                    radius: 1.0,
                },
                hardening,
            );
        }
    }

    #[test]
    fn gradient_matches_finite_differences_where_the_field_is_only_a_distance_bound() {
        for hardening in [0.0, 1e-3] {
            check_gradient(
                &HalvedSphere(Sphere {
                    centre: Vec3::zeros(),
                    radius: 1.0,
                }),
                hardening,
            );
        }
    }

    #[test]
    fn hardening_stiffens_the_penalty_only_inside_the_collider() {
        let model = ClothModel::new(&[Vec3::zeros()], &[], &[0.1]).unwrap();
        let (stiffness, pinned) = ([300.0], [false]);
        let energy = |hardening| DrapeEnergy {
            model: &model,
            gravity: 9.81,
            margin: 0.003,
            contact_stiffness: &stiffness,
            is_pinned: &pinned,
            hardening,
        };
        let (soft, hard) = (energy(0.0), energy(1e-4));
        let at = |distance| Contact {
            distance,
            gradient: Vec3::y(),
        };
        // Outside the collider, and down to HARDENING_DEPTH inside it: the same penalty.
        for distance in [0.001, -0.0009] {
            let c = at(distance);
            assert_eq!(soft.penalty_force(0, &c), hard.penalty_force(0, &c));
            assert_eq!(soft.penalty_stiffness(0, &c), hard.penalty_stiffness(0, &c));
            assert_eq!(hard.hardening_energy(0, distance), 0.0);
        }
        // 5 mm inside, 4 mm past where it begins: 300 (8 mm + 16e-6 / 1e-4 m) = 50.4 N
        // instead of 2.4 N.
        let inside = at(-0.005);
        assert_relative_eq!(soft.penalty_force(0, &inside).y, 2.4, max_relative = 1e-12);
        assert_relative_eq!(hard.penalty_force(0, &inside).y, 50.4, max_relative = 1e-12);
        assert_relative_eq!(
            hard.penalty_stiffness(0, &inside),
            300.0 * (1.0 + 80.0),
            max_relative = 1e-12
        );
    }

    fn check_gradient(sphere: &impl SignedDistance, hardening: Real) {
        let x0 = [
            Vec3::new(0.0, 1.02, 0.0),
            // 8 mm inside the sphere (4 mm as the halved field measures it).
            Vec3::new(0.3, 0.94, 0.1),
            Vec3::new(0.1, 1.3, 0.2),
        ];
        let springs = [
            SpringSpec {
                a: 0,
                b: 1,
                rest_length: 0.25,
                stiffness: 40.0,
            },
            SpringSpec {
                a: 1,
                b: 2,
                rest_length: 0.5,
                stiffness: 7.0,
            },
        ];
        let model = ClothModel::new(&x0, &springs, &[0.1, 0.2, 0.3]).unwrap();
        let stiffness = [500.0, 800.0, 900.0];
        let pinned = [false; 3];
        let e = DrapeEnergy {
            model: &model,
            gravity: 9.81,
            margin: 0.03,
            contact_stiffness: &stiffness,
            is_pinned: &pinned,
            hardening,
        };
        let mut contacts = vec![None; 3];
        let mut g = vec![Vec3::zeros(); 3];
        e.gradient(&x0, sphere, &mut contacts, &mut g);
        assert!(contacts[0].is_some() && contacts[1].is_some() && contacts[2].is_none());
        let h = 1e-6;
        for i in 0..3 {
            for c in 0..3 {
                let mut xp = x0.to_vec();
                let mut xm = x0.to_vec();
                xp[i][c] += h;
                xm[i][c] -= h;
                let fd = (total(&e, &xp, sphere) - total(&e, &xm, sphere)) / (2.0 * h);
                assert_relative_eq!(g[i][c], fd, epsilon = 1e-5, max_relative = 1e-6);
            }
        }
    }

    #[test]
    fn public_energy_is_the_solvers_change_and_its_gradient_the_derivative() {
        let sphere = Sphere {
            centre: Vec3::zeros(),
            radius: 1.0,
        };
        let x0 = vec![
            Vec3::new(0.0, 1.002, 0.0),
            // 5 mm inside: the hardening acts.
            Vec3::new(0.6, 0.795, 0.0),
            Vec3::new(0.1, 1.3, 0.2),
        ];
        let springs = [
            SpringSpec {
                a: 0,
                b: 1,
                rest_length: 0.25,
                stiffness: 40.0,
            },
            SpringSpec {
                a: 1,
                b: 2,
                rest_length: 0.5,
                stiffness: 7.0,
            },
        ];
        let model = ClothModel::new(&x0, &springs, &[0.1, 0.2, 0.3]).unwrap();
        let settings = DrapeSettings::default();
        let (terms, g) = drape_energy_and_gradient(&model, &settings, &sphere, &x0).unwrap();
        assert!(terms.contact > 0.0 && terms.springs > 0.0);
        let stiffness = contact_stiffness(&model, &settings);
        assert_eq!(stiffness, vec![300.0; 3], "the default floor");
        let pinned = [false; 3];
        let e = DrapeEnergy {
            model: &model,
            gravity: settings.gravity,
            margin: settings.contact_margin,
            contact_stiffness: &stiffness,
            is_pinned: &pinned,
            hardening: settings.contact_hardening,
        };
        let none = vec![None; 3];
        let x1: Vec<Vec3> = x0.iter().map(|p| p * 1.001).collect();
        let (terms1, _) = drape_energy_and_gradient(&model, &settings, &sphere, &x1).unwrap();
        let contacts0: Vec<_> = (0..3).map(|i| e.contact(i, &x0[i], &sphere)).collect();
        assert_relative_eq!(
            terms1.total() - terms.total(),
            e.change(&x0, &x1, &contacts0, &sphere),
            max_relative = 1e-9
        );
        assert!(
            e.change(&x0, &x0, &none, &sphere).abs() > 0.0,
            "contacts count"
        );
        let h = 1e-7;
        for i in 0..3 {
            for c in 0..3 {
                let (mut xp, mut xm) = (x0.clone(), x0.clone());
                xp[i][c] += h;
                xm[i][c] -= h;
                let total = |x: &[Vec3]| {
                    drape_energy_and_gradient(&model, &settings, &sphere, x)
                        .unwrap()
                        .0
                        .total()
                };
                let fd = (total(&xp) - total(&xm)) / (2.0 * h);
                assert_relative_eq!(g[i][c], fd, epsilon = 1e-4, max_relative = 1e-5);
            }
        }
        let short = drape_energy_and_gradient(&model, &settings, &sphere, &x0[..2]);
        assert!(matches!(
            short,
            Err(crate::Error::Core(CoreError::WrongLength { got: 2, .. }))
        ));
        let mut nan = x0.clone();
        nan[1].y = Real::NAN;
        let bad = drape_energy_and_gradient(&model, &settings, &sphere, &nan);
        assert!(matches!(
            bad,
            Err(crate::Error::Core(CoreError::NonFinite { .. }))
        ));
    }
}
