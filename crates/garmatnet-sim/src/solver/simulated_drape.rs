//! The simulator's drape of what a prediction is compared with: one pose, or a sequence of
//! poses walked as a dataset walks them, timed.

use std::time::Instant;

use garmatnet_core::{CapsuleBody, Error as CoreError, Garment, Material, Pose, Real, Vec3};

use crate::error::Result;
use crate::solver::garment_drape::{SequenceSettings, drape_sequence};

/// The simulator's drape of one (pose, material): the ground truth a prediction is compared
/// with.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulatedDrape {
    /// The settled garment (metres).
    pub vertices: Vec<Vec3>,
    /// Wall-clock time of the whole drape: rest drape, walk to the pose, converge (ms).
    pub wall_ms: Real,
    /// Whether the final converge met the residual tolerances.
    pub converged: bool,
}

/// Drapes `garment` of `material` on `body` at `pose` with the dataset generator's solver and
/// settings (from the rest garment, through intermediate poses), on this thread.
///
/// # Errors
/// The solver's errors, e.g. a material outside the physical range.
pub fn simulate_drape(
    garment: &Garment,
    body: &CapsuleBody,
    pose: &Pose,
    material: &Material,
    settings: &SequenceSettings,
) -> Result<SimulatedDrape> {
    // One pose: its drape's time runs from the start, rest drape and walk included.
    simulate_sequence(
        garment,
        body,
        std::slice::from_ref(pose),
        material,
        settings,
    )?
    .pop()
    .ok_or_else(|| {
        CoreError::Mismatch {
            what: "drapes returned by the simulator".into(),
            expected: "1".into(),
            got: "0".into(),
        }
        .into()
    })
}

/// The simulator's drapes along `poses`, in order, as a dataset walks them
/// ([`drape_sequence`]: the rest drape, then each pose reached through intermediate poses and
/// converged): the ground truth to hold a predicted sequence against. Each drape's `wall_ms`
/// is the time since the previous one (the first includes the rest drape).
///
/// # Errors
/// The solver's errors.
pub fn simulate_sequence(
    garment: &Garment,
    body: &CapsuleBody,
    poses: &[Pose],
    material: &Material,
    settings: &SequenceSettings,
) -> Result<Vec<SimulatedDrape>> {
    let mut drapes = Vec::with_capacity(poses.len());
    let mut last = Instant::now();
    let stats = drape_sequence(garment, body, material, poses, settings, None, |_, x, _| {
        let now = Instant::now();
        drapes.push(SimulatedDrape {
            vertices: x.to_vec(),
            wall_ms: (now - last).as_secs_f64() * 1e3,
            converged: false,
        });
        last = now;
        Ok(())
    })?;
    // `stats` holds the rest drape first, then one per pose.
    for (drape, stat) in drapes.iter_mut().zip(stats.iter().skip(1)) {
        drape.converged = stat.converged;
    }
    Ok(drapes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::generator::MotionGenerator;
    use garmatnet_core::Resolution;

    #[test]
    fn a_simulated_sequence_walks_as_a_single_drape_does() -> anyhow::Result<()> {
        let body = CapsuleBody::smpl_neutral();
        let shirt = Garment::tshirt(Resolution::Coarse, &body)?;
        let motion = MotionGenerator::new(0, 240).generate();
        let silk = Material::preset("Silk Chiffon")?;
        let settings = SequenceSettings::default();
        let drapes = simulate_sequence(&shirt, &body, &motion[2..4], &silk, &settings)?;
        assert_eq!(drapes.len(), 2);
        // Its first frame is the single drape of that pose: the same walk from rest.
        let single = simulate_drape(&shirt, &body, &motion[2], &silk, &settings)?;
        assert_eq!(drapes[0].vertices, single.vertices);
        assert_eq!(drapes[0].converged, single.converged);
        assert_ne!(drapes[1].vertices, drapes[0].vertices);
        assert!(drapes.iter().all(|d| d.wall_ms > 0.0));
        Ok(())
    }
}
