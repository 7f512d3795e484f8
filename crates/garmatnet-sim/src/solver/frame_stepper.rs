//! A draped garment that follows its body from pose to pose, one frame at a time on one
//! solver: what an application steps, and what [`drape_sequence`] walks a sequence with;
//! drapes are recorded at the f32 precision datasets store.
//!
//! [`drape_sequence`]: crate::drape_sequence

use garmatnet_core::error::ensure_finite;
use garmatnet_core::{
    CapsuleBody, Error as CoreError, Garment, Material, Pose, PosedBody, Vec3, push_mesh_outside,
};

use crate::error::Result;
use crate::solver::cloth_model::cloth_from_garment;
use crate::solver::drape_settings::DrapeSettings;
use crate::solver::drape_solver::{DrapeSolver, DrapeStats};

/// A draped garment that follows its body from pose to pose: the simulator as an
/// application steps it, one frame at a time, on one solver (its symbolic factorisation made
/// once).
///
/// Each [`FrameStepper::step`] carries the cloth with the skin to the new pose
/// ([`PosedBody::carry_to`]; unless [`FrameStepper::follow_body`] is off), then runs the
/// solver from there with friction measured from the carried positions, so the shirt moves
/// with the body and slides only where it is pulled harder than the Coulomb bound. The
/// solver's [`DrapeSettings::max_iterations`] is the budget of a step: [`drape_sequence`]
/// converges every pose (its default cap, 300), while an interactive application can stop
/// after a few iterations. Measured (book/src/solver.md; `cargo run -p
/// garmatnet-sim --release --example frame_budget`): at the paper resolution, 8 iterations
/// per frame of the gentle motion take about 0.3 s on one core and stay as close to the
/// dataset's walked drapes as fully converged frames stepped the same way.
///
/// ```no_run
/// use garmatnet_core::{CapsuleBody, Garment, Material, Pose, Resolution};
/// use garmatnet_sim::{DrapeSettings, FrameStepper, MotionGenerator};
///
/// let body = CapsuleBody::smpl_neutral();
/// let garment = Garment::tshirt(Resolution::Default, &body)?;
/// let material = Material::preset("Denim Heavy")?;
/// // Hang the shirt on its rest pose (the A-pose it is dressed in) once, to equilibrium...
/// let mut shirt = FrameStepper::new(
///     &garment, &body, &material, &DrapeSettings::default(), &garment.rest_pose,
///     garment.rest.vertices.clone(),
/// )?;
/// shirt.step(&garment.rest_pose)?;
/// // ...then follow a motion with 8 Newton iterations a frame.
/// shirt.set_settings(&DrapeSettings { max_iterations: 8, ..DrapeSettings::default() })?;
/// for pose in MotionGenerator::new(0, 20).generate() {
///     let stats = shirt.step(&pose)?;
///     println!("{} iterations, residual {:.1e}", stats.iterations, stats.final_residual);
///     let _vertices = shirt.positions();
/// }
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
///
/// [`drape_sequence`]: crate::drape_sequence
#[derive(Debug, Clone)]
pub struct FrameStepper {
    solver: DrapeSolver,
    posed: PosedBody,
    positions: Vec<Vec3>,
    anchors: Vec<Vec3>,
    follow_body: bool,
}

impl FrameStepper {
    /// `garment` of `material` at `positions` (metres, one per vertex; a previous drape, or
    /// the rest template to drape from) on `body` in `pose`, stepped with `settings`.
    ///
    /// # Errors
    /// As [`cloth_from_garment`] and [`DrapeSolver::new`]; [`CoreError::WrongLength`] or
    /// [`CoreError::NonFinite`] for positions that are not one finite point per vertex.
    pub fn new(
        garment: &Garment,
        body: &CapsuleBody,
        material: &Material,
        settings: &DrapeSettings,
        pose: &Pose,
        positions: Vec<Vec3>,
    ) -> Result<Self> {
        let model = cloth_from_garment(garment, material)?;
        Self::with_solver(DrapeSolver::new(&model, settings)?, body, pose, positions)
    }

    /// As [`FrameStepper::new`], with a solver made before (its cloth and settings).
    ///
    /// # Errors
    /// [`CoreError::WrongLength`] or [`CoreError::NonFinite`] for positions that are not one
    /// finite point per vertex of the solver's cloth.
    pub fn with_solver(
        solver: DrapeSolver,
        body: &CapsuleBody,
        pose: &Pose,
        positions: Vec<Vec3>,
    ) -> Result<Self> {
        check_positions(&positions, solver.model().vertex_count())?;
        Ok(Self {
            anchors: positions.clone(),
            positions,
            posed: body.pose(pose),
            solver,
            follow_body: true,
        })
    }

    /// Whether [`FrameStepper::step`] carries the cloth with the skin first (default true;
    /// [`SequenceSettings::follow_body`]). Off, each step starts where the cloth was and
    /// friction treats the body as still.
    ///
    /// [`SequenceSettings::follow_body`]: crate::SequenceSettings::follow_body
    #[must_use]
    pub fn follow_body(mut self, follow: bool) -> Self {
        self.follow_body = follow;
        self
    }

    /// Moves the body to `pose` and drapes the garment there with the solver's settings
    /// (at most [`DrapeSettings::max_iterations`] Newton iterations), from its current
    /// positions carried with the skin. A step that stops at the budget is not an error:
    /// its stats say `converged: false`.
    ///
    /// # Errors
    /// As [`Pose::validate`] for a NaN or absurd pose, before anything moves; as
    /// [`DrapeSolver::drape_with_anchors`], the positions then left at the last finite
    /// iterate.
    pub fn step(&mut self, pose: &Pose) -> Result<DrapeStats> {
        pose.validate()?;
        let next = self.posed.body().pose(pose);
        if self.follow_body {
            self.posed.carry_to(&next, &mut self.positions);
        }
        self.anchors.copy_from_slice(&self.positions);
        self.posed = next;
        self.solver
            .drape_with_anchors(&mut self.positions, &self.anchors, &self.posed, &[])
    }

    /// Turns the last step's drape into a recorded one (ground-truth revision 4): its
    /// vertices, which the solver's final projection left outside the body, moved until a grid
    /// of points across each of the garment's triangles (`faces`) lies outside too
    /// ([`push_mesh_outside`]: twelve points and the centroid), then rounded to f32 as
    /// datasets store them. `stats` (that step's) then record the penetration at those
    /// points (before the rounding, which moves a point by at most about 3e-8 m) and the
    /// strain of the springs; the residuals, contacts and convergence stay the solver's. The
    /// solver's contact acts at the vertices, and where a convex body part presses on the
    /// cloth (a forearm on the chest) the triangles between them cut under it by up to 5 mm.
    /// The canonical protocol records the drape at the target pose only, not along its path,
    /// so its drapes stay where revision 3's were except at such triangles; a walk goes on
    /// from each recorded drape, as a walk resumed from its last sample must.
    ///
    /// # Errors
    /// As [`ClothModel::max_strain`](crate::ClothModel::max_strain).
    pub(crate) fn record(&mut self, faces: &[[u32; 3]], stats: &mut DrapeStats) -> Result<()> {
        let pushed = push_mesh_outside(&mut self.positions, faces, &self.posed, &[]);
        round_to_f32(&mut self.positions);
        stats.max_penetration = pushed.deepest;
        stats.max_strain = self.solver.model().max_strain(&self.positions)?;
        Ok(())
    }

    /// Replaces the solver's settings (the budget of the next steps among them).
    ///
    /// # Errors
    /// As [`DrapeSolver::set_settings`].
    pub fn set_settings(&mut self, settings: &DrapeSettings) -> Result<()> {
        self.solver.set_settings(settings)
    }

    /// The solver's settings.
    #[must_use]
    pub fn settings(&self) -> &DrapeSettings {
        self.solver.settings()
    }

    /// The garment's current positions (metres).
    #[must_use]
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// The garment's current positions, to edit in place (e.g. rounded to the precision a
    /// file stores, so a resumed run continues from exactly what was saved).
    pub fn positions_mut(&mut self) -> &mut [Vec3] {
        &mut self.positions
    }

    /// The body in its current pose.
    #[must_use]
    pub fn posed_body(&self) -> &PosedBody {
        &self.posed
    }

    /// The garment's positions, giving up the stepper.
    #[must_use]
    pub fn into_positions(self) -> Vec<Vec3> {
        self.positions
    }

    /// Puts the garment at `positions` on the body in `pose` (a saved frame, say: a jump in
    /// a timeline), keeping the solver.
    ///
    /// # Errors
    /// As [`FrameStepper::with_solver`]; the stepper is unchanged then.
    pub fn restart(&mut self, pose: &Pose, positions: &[Vec3]) -> Result<()> {
        check_positions(positions, self.positions.len())?;
        self.positions.copy_from_slice(positions);
        self.anchors.copy_from_slice(positions);
        self.posed = self.posed.body().pose(pose);
        Ok(())
    }
}

/// One finite point per vertex of an `expected`-vertex garment.
fn check_positions(positions: &[Vec3], expected: usize) -> Result<()> {
    if positions.len() != expected {
        return Err(CoreError::WrongLength {
            what: "garment positions to step from".into(),
            expected: expected.to_string(),
            got: positions.len(),
        }
        .into());
    }
    if let Some(v) = positions
        .iter()
        .position(|p| !p.iter().all(|c| c.is_finite()))
    {
        ensure_finite(
            &format!("garment positions to step from (vertex {v}, metres)"),
            positions[v].iter().copied(),
        )?;
    }
    Ok(())
}

/// Rounds every coordinate to the nearest f32, the precision datasets store.
pub(crate) fn round_to_f32(positions: &mut [Vec3]) {
    for p in positions {
        *p = p.map(|c| f64::from(c as f32));
    }
}
