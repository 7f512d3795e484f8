//! The T-shirt walked along poses: the step sizes between poses ([`surface_steps`]), a pose
//! sequence walked in small warm-started steps by a [`FrameStepper`] ([`drape_sequence`]),
//! and the rest drape every sequence starts from ([`settle_rest_drape`]).

use garmatnet_core::{CapsuleBody, Error as CoreError, Garment, Material, Pose, Real, Vec3};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result, StepParameter};
use crate::motion::generator::{MIN_STEP_RAD, equal_steps, interpolation_steps};
use crate::solver::cloth_model::cloth_from_garment;
use crate::solver::drape_settings::DrapeSettings;
use crate::solver::drape_solver::{DrapeSolver, DrapeStats};
use crate::solver::frame_stepper::FrameStepper;
use crate::solver::mirror_symmetry::MirrorMap;

/// How [`drape_sequence`] walks from pose to pose.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct SequenceSettings {
    /// The solver settings of the full drape at every requested pose.
    pub drape: DrapeSettings,
    /// Largest joint rotation between intermediate poses (radians). The default 0.014 moves
    /// a point 0.7 m from its joint (a wrist from the shoulder) by about 1 cm per step.
    pub max_step_rad: Real,
    /// Newton iterations on each intermediate pose (the cloth need only follow the body).
    pub intermediate_iterations: usize,
    /// Largest distance (metres) the skin under the cloth may carry any cloth vertex per
    /// intermediate step; 0 (the default) turns it off. When positive, a walk takes as many
    /// equal steps as the cloth's longest path along the skin needs ([`surface_steps`]) —
    /// never more than `max_step_rad` asks for — so joints the shirt does not cover (wrists,
    /// knees) no longer set the pace. Left out of the JSON when 0, so manifests of datasets
    /// made without it are unchanged.
    #[serde(skip_serializing_if = "is_zero")]
    pub max_surface_step: Real,
    /// Whether each step starts from the previous result carried with the body
    /// ([`garmatnet_core::PosedBody::carry_to`]) and measures friction from there, as cloth
    /// resting on moving skin does. Default true. With false each step starts where the
    /// cloth was and friction treats the body as still (holding cloth in place while the
    /// skin slides under it); datasets made before friction were walked that way, with
    /// zero friction.
    pub follow_body: bool,
}

impl Default for SequenceSettings {
    fn default() -> Self {
        Self {
            drape: DrapeSettings::default(),
            max_step_rad: 0.014,
            intermediate_iterations: 4,
            follow_body: true,
            max_surface_step: 0.0,
        }
    }
}

impl SequenceSettings {
    /// The settings a dataset's manifest records (its `solver` field). Missing fields take
    /// the defaults, except those whose default changed what a walk computes: a manifest
    /// written before friction existed has no `drape.friction` or `follow_body`, and its
    /// samples were walked frictionless, so those read as 0 and false; one written before
    /// the line search's expansion has no `drape.step_expansion`, which reads as 1 (off),
    /// and one written before the penalty hardened inside the body has no
    /// `drape.contact_hardening`, which reads as 0 (off).
    ///
    /// # Errors
    /// The JSON's error if `solver` is not a settings object.
    pub fn from_manifest(solver: &serde_json::Value) -> serde_json::Result<Self> {
        let mut settings: Self = serde_json::from_value(solver.clone())?;
        if solver.pointer("/drape/friction").is_none() {
            settings.drape.friction = 0.0;
        }
        if solver.get("follow_body").is_none() {
            settings.follow_body = false;
        }
        if solver.pointer("/drape/step_expansion").is_none() {
            settings.drape.step_expansion = 1.0;
        }
        if solver.pointer("/drape/contact_hardening").is_none() {
            settings.drape.contact_hardening = 0.0;
        }
        Ok(settings)
    }
}

impl SequenceSettings {
    /// Checks every setting against the range a walk works in: the drape settings
    /// ([`DrapeSettings::validate`]), a finite interpolation step of at least
    /// [`MIN_STEP_RAD`] (a smaller one would cut a pose change into millions of steps), at
    /// least one intermediate iteration and a finite surface step of at least 0 (off). Only
    /// lower bounds: larger values mean fewer or longer steps, which datasets made with them
    /// must still resume with.
    /// [`drape_sequence`] and dataset generation check it before any work; call it to
    /// check settings read from a file before a long run.
    ///
    /// # Errors
    /// [`CoreError::OutOfRange`] naming the first setting outside its range, with the range.
    pub fn validate(&self) -> Result<()> {
        self.drape.validate()?;
        let checks: [(&str, Real, Real, Real); 3] = [
            (
                "sequence setting max_step_rad (radians)",
                self.max_step_rad,
                MIN_STEP_RAD,
                Real::MAX,
            ),
            (
                "sequence setting intermediate_iterations",
                self.intermediate_iterations as Real,
                1.0,
                Real::MAX,
            ),
            (
                "sequence setting max_surface_step (metres; 0 is off)",
                self.max_surface_step,
                0.0,
                Real::MAX,
            ),
        ];
        for (what, value, min, max) in checks {
            if !(value >= min && value <= max) {
                return Err(CoreError::OutOfRange {
                    what: what.into(),
                    value,
                    min,
                    max,
                    hint: String::new(),
                }
                .into());
            }
        }
        Ok(())
    }
}

fn is_zero(x: &Real) -> bool {
    *x == 0.0
}

/// The intermediate poses of a walk from `from` to `to` (`to` last, `from` left out) for cloth
/// at `positions` on `body` posed at `from`: the [`interpolation_steps`] at `max_step_rad`,
/// or, when `max_surface_step` is positive, as few equal slerp steps as keep every cloth
/// vertex, carried with the skin ([`garmatnet_core::PosedBody::carry_to`]) along those
/// steps, within `max_surface_step` metres of path per step. The path is measured over the
/// `max_step_rad` steps, and the result never has more steps than they.
///
/// # Errors
/// [`Error::StepOutOfRange`] for a `max_step_rad` that is not finite or below
/// [`MIN_STEP_RAD`] ([`StepParameter::JointTurn`]), or a `max_surface_step` that is negative
/// or not finite ([`StepParameter::SurfaceTravel`]).
pub fn surface_steps(
    body: &CapsuleBody,
    from: &Pose,
    to: &Pose,
    positions: &[Vec3],
    max_step_rad: Real,
    max_surface_step: Real,
) -> Result<Vec<Pose>> {
    let fine = interpolation_steps(from, to, max_step_rad)?;
    if !(max_surface_step.is_finite() && max_surface_step >= 0.0) {
        return Err(Error::StepOutOfRange {
            parameter: StepParameter::SurfaceTravel,
            value: max_surface_step,
            min: 0.0,
        });
    }
    if max_surface_step == 0.0 || fine.len() == 1 {
        return Ok(fine);
    }
    let mut points = positions.to_vec();
    let mut path = vec![0.0; points.len()];
    let mut before = points.clone();
    let mut posed = body.pose(from);
    for pose in &fine {
        let next = body.pose(pose);
        before.copy_from_slice(&points);
        posed.carry_to(&next, &mut points);
        for ((length, a), b) in path.iter_mut().zip(&before).zip(&points) {
            *length += (b - a).norm();
        }
        posed = next;
    }
    let longest = path.iter().copied().fold(0.0, Real::max);
    let n = ((longest / max_surface_step).ceil() as usize).clamp(1, fine.len());
    Ok(equal_steps(from, to, n))
}

/// Where a resumed [`drape_sequence`] picks up: pose `next - 1` is done and `positions` is
/// its saved result (as stored in a dataset: f32 precision).
#[derive(Debug, Clone, PartialEq)]
pub struct SequenceResume {
    /// The first pose still to drape (>= 1).
    pub next: usize,
    /// The settled garment at pose `next - 1` (metres).
    pub positions: Vec<Vec3>,
}

/// Drapes `garment` of `material` on `body` in every pose of `poses`, in order.
///
/// After each pose the state is recorded as a dataset sample is (ground-truth revision 4:
/// its triangles pushed out of the body between the vertices, then rounded to f32 precision,
/// the precision datasets store), and the walk goes on from there, so a run resumed from a
/// saved sample ([`SequenceResume`]) continues bit-identically to one that never stopped.
///
/// Starts from the rest garment on the body in the garment's rest pose
/// ([`Garment::rest_pose`]: the A-pose for the fitted shirt, the T-pose for the boxy one)
/// and drapes it there (landing it frictionless for [`LANDING_ITERATIONS`], then settling
/// it with friction, restarted from its mirror average where that does not settle:
/// [`settle_rest_drape`]), then walks
/// to each pose through intermediate poses ([`surface_steps`]: [`interpolation_steps`] at
/// `settings.max_step_rad`, or fewer with `settings.max_surface_step`), warm-starting every
/// step from the previous result (carried with the body when `settings.follow_body`) with
/// `settings.intermediate_iterations` Newton iterations, and converges fully at each pose.
/// Calls `on_sample(pose_index, positions, stats)` with the settled garment (metres) at
/// every pose. Returns the stats of the rest drape followed by one per pose.
///
/// # Errors
/// As [`cloth_from_garment`] and [`DrapeSolver::drape`]; settings that fail
/// [`SequenceSettings::validate`] are [`CoreError::OutOfRange`]; [`Error::InvalidResume`] for
/// a `resume` whose `next` is not a pose from 1 to `poses.len()` or whose positions are not
/// one per garment vertex; any error of `on_sample` stops the walk and is returned.
pub fn drape_sequence(
    garment: &Garment,
    body: &CapsuleBody,
    material: &Material,
    poses: &[Pose],
    settings: &SequenceSettings,
    resume: Option<SequenceResume>,
    mut on_sample: impl FnMut(usize, &[Vec3], &DrapeStats) -> Result<()>,
) -> Result<Vec<DrapeStats>> {
    settings.validate()?;
    for pose in poses {
        pose.validate()?;
    }
    let model = cloth_from_garment(garment, material)?;
    let full = settings.drape.clone();
    let quick = DrapeSettings {
        max_iterations: settings.intermediate_iterations,
        ..full.clone()
    };
    let mut solver = DrapeSolver::new(&model, &full)?;
    let mut all = Vec::new();
    let (positions, mut current, first) = match resume {
        None => {
            // The rest mesh fits the body in the garment's rest pose: the walk starts there.
            let (positions, stats) = settle_rest_drape(&mut solver, &full, garment, body)?;
            all.push(stats);
            (positions, garment.rest_pose.clone(), 0)
        }
        Some(r) => {
            if r.next == 0 || r.next > poses.len() || r.positions.len() != garment.vertex_count() {
                return Err(Error::InvalidResume {
                    next: r.next,
                    poses: poses.len(),
                    positions: r.positions.len(),
                    vertices: garment.vertex_count(),
                });
            }
            (r.positions, poses[r.next - 1].clone(), r.next)
        }
    };
    let mut garment_on_body = FrameStepper::with_solver(solver, body, &current, positions)?
        .follow_body(settings.follow_body);
    for (index, target) in poses.iter().enumerate().skip(first) {
        let steps = surface_steps(
            body,
            &current,
            target,
            garment_on_body.positions(),
            settings.max_step_rad,
            settings.max_surface_step,
        )?;
        let (last, between) = steps
            .split_last()
            .unwrap_or_else(|| unreachable!("interpolation ends at the target"));
        if !between.is_empty() {
            garment_on_body.set_settings(&quick)?;
            for pose in between {
                garment_on_body.step(pose)?;
            }
            garment_on_body.set_settings(&full)?;
        }
        let mut stats = garment_on_body.step(last)?;
        // The walk goes on from the drape as recorded (pushed out, rounded to f32), so a
        // walk resumed from its last sample takes the same path.
        garment_on_body.record(&garment.rest.faces, &mut stats)?;
        on_sample(index, garment_on_body.positions(), &stats)?;
        all.push(stats);
        current = target.clone();
    }
    Ok(all)
}

/// Newton iterations of the rest drape's frictionless landing ([`settle_at_rest`]).
pub const LANDING_ITERATIONS: usize = 10;

/// Drapes the garment at `positions` (the rest template, clear of the body) on `body` in the
/// rest pose, with `settings`: first [`LANDING_ITERATIONS`] Newton iterations, which land
/// the cloth on the body (the template starts out of contact, so friction, lagged at the
/// start of a drape, has no contact to act on), then a drape to equilibrium from there with
/// friction holding what has landed. The returned stats are the second drape's, its
/// iterations and time the sum of both.
///
/// Draped in one frictionless go, the shirt slid along the raised arms for its whole
/// convergence: its lateral mode on the T-pose body is so soft that SMPL's 3 mm of
/// left-right asymmetry carried five of six fabrics 29–40 mm toward the body's left, and on
/// an exactly symmetric body rounding alone carried Silk Duchess Satin 30 mm. Landed first
/// and then held by friction, the drape on a symmetric body is symmetric to the micrometre.
///
/// # Errors
/// As [`DrapeSolver::drape`].
pub fn settle_at_rest(
    solver: &mut DrapeSolver,
    settings: &DrapeSettings,
    positions: &mut [Vec3],
    body: &CapsuleBody,
    rest_pose: &Pose,
) -> Result<DrapeStats> {
    let rest = body.pose(rest_pose);
    solver.set_settings(&DrapeSettings {
        max_iterations: LANDING_ITERATIONS.min(settings.max_iterations),
        ..settings.clone()
    })?;
    let landing = solver.drape(positions, &rest, &[])?;
    solver.set_settings(settings)?;
    let mut stats = solver.drape(positions, &rest, &[])?;
    stats.add_cost_of(&landing);
    Ok(stats)
}

/// Drapes `garment` on `body` at its rest pose from its rest mesh ([`settle_at_rest`]) and
/// returns the rest drape (metres) with the solver's report: the start of every canonical
/// sample ([`CanonicalDraper`](crate::CanonicalDraper)) and of every walk
/// ([`drape_sequence`]).
///
/// The garment's rest pose is left-right symmetric, so its rest drape must be too. Where the
/// drape from the rest mesh does not settle within the iteration cap at a symmetric rest pose
/// (Spandex, the softest preset, drifts 22 mm toward the body's left meanwhile), it is
/// restarted from its mirror average (each vertex halfway to its [mirror twin](MirrorMap)'s
/// mirror image) and settled again; the returned stats then count both solves
/// ([`DrapeStats::add_cost_of`]). A rest drape that settles the first time, or a garment with
/// no mirror map, is kept as it is.
///
/// # Errors
/// As [`settle_at_rest`] and [`MirrorMap::mirrored`].
pub fn settle_rest_drape(
    solver: &mut DrapeSolver,
    settings: &DrapeSettings,
    garment: &Garment,
    body: &CapsuleBody,
) -> Result<(Vec<Vec3>, DrapeStats)> {
    let rest_pose = &garment.rest_pose;
    let mut positions = garment.rest.vertices.clone();
    let mut stats = settle_at_rest(solver, settings, &mut positions, body, rest_pose)?;
    if !stats.converged && rest_pose.mirrored() == *rest_pose {
        // A drape that does not settle at a left-right symmetric rest pose can drift to one
        // side for as long as the iteration cap lets it (Spandex: 22 mm, 59 mm of mirror
        // asymmetry). Restart it from its mirror average and settle it again.
        if let Ok(map) = MirrorMap::of_garment(garment) {
            let mirrored = map.mirrored(&positions)?;
            for (p, m) in positions.iter_mut().zip(&mirrored) {
                *p = (*p + m) * 0.5;
            }
            let first = stats;
            stats = settle_at_rest(solver, settings, &mut positions, body, rest_pose)?;
            stats.add_cost_of(&first);
        }
    }
    Ok((positions, stats))
}

/// Every pose's settled garment along [`drape_sequence`]'s walk from the rest pose (metres;
/// one per pose, in order), for callers that want the drapes rather than a callback.
///
/// # Errors
/// As [`drape_sequence`].
pub fn drape_poses(
    garment: &Garment,
    body: &CapsuleBody,
    material: &Material,
    poses: &[Pose],
    settings: &SequenceSettings,
) -> Result<Vec<Vec<Vec3>>> {
    let mut drapes = Vec::with_capacity(poses.len());
    drape_sequence(garment, body, material, poses, settings, None, |_, x, _| {
        drapes.push(x.to_vec());
        Ok(())
    })?;
    Ok(drapes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sequence_settings_outside_the_walks_range_are_refused_by_name() {
        assert!(SequenceSettings::default().validate().is_ok());
        let refused = |settings: SequenceSettings, name: &str| {
            let err = settings.validate().unwrap_err().to_string();
            assert!(err.contains(name), "{err}");
        };
        refused(
            SequenceSettings {
                max_step_rad: 1e-300,
                ..SequenceSettings::default()
            },
            "max_step_rad",
        );
        refused(
            SequenceSettings {
                intermediate_iterations: 0,
                ..SequenceSettings::default()
            },
            "intermediate_iterations",
        );
        refused(
            SequenceSettings {
                max_surface_step: Real::NAN,
                ..SequenceSettings::default()
            },
            "max_surface_step",
        );
        let mut bad_drape = SequenceSettings::default();
        bad_drape.drape.max_iterations = 0;
        refused(bad_drape, "max_iterations");
    }

    #[test]
    fn step_sizes_out_of_range_are_typed_errors() {
        let body = CapsuleBody::smpl_neutral();
        let from = Pose::zero();
        let mut to = Pose::zero();
        to.set_joint(
            garmatnet_core::joint_index("left_shoulder").unwrap(),
            Vec3::new(0.0, 0.0, 0.35),
        );
        let points = [Vec3::new(0.3, 0.3, 0.0)];
        for surface in [-0.01, Real::NAN, Real::INFINITY] {
            let err = surface_steps(&body, &from, &to, &points, 0.05, surface).unwrap_err();
            assert!(
                matches!(
                    err,
                    Error::StepOutOfRange {
                        parameter: StepParameter::SurfaceTravel,
                        value,
                        ..
                    } if value.to_bits() == surface.to_bits()
                ),
                "{err}"
            );
            assert!(err.to_string().contains("max_surface_step"), "{err}");
        }
        let err = surface_steps(&body, &from, &to, &points, 0.0, 0.01).unwrap_err();
        assert!(
            matches!(
                err,
                Error::StepOutOfRange {
                    parameter: StepParameter::JointTurn,
                    ..
                }
            ),
            "{err}"
        );
        assert!(surface_steps(&body, &from, &to, &points, 0.05, 0.0).is_ok());
    }

    #[test]
    fn a_resume_outside_the_walk_is_a_typed_error() {
        let body = CapsuleBody::smpl_neutral();
        let garment = Garment::tshirt(garmatnet_core::Resolution::Coarse, &body).unwrap();
        let material = Material::preset("Cotton Poplin").unwrap();
        let poses = [Pose::zero()];
        let n = garment.vertex_count();
        for (next, positions) in [(0, n), (2, n), (1, n - 1)] {
            let resume = SequenceResume {
                next,
                positions: vec![Vec3::zeros(); positions],
            };
            let err = drape_sequence(
                &garment,
                &body,
                &material,
                &poses,
                &SequenceSettings::default(),
                Some(resume),
                |_, _, _| Ok(()),
            )
            .unwrap_err();
            assert!(
                matches!(
                    err,
                    Error::InvalidResume { next: got_next, poses: 1, positions: got, vertices }
                        if got_next == next && got == positions && vertices == n
                ),
                "{err}"
            );
        }
    }
}
