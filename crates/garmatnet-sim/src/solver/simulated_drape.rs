//! The simulator's drape of what a prediction is compared with, timed: one pose by the
//! canonical protocol, as a dataset drapes it, or a sequence of poses walked in
//! order, as an animation moves.

use std::time::Instant;

use garmatnet_core::{CapsuleBody, Garment, Material, Pose, Real, Vec3};

use crate::error::Result;
use crate::solver::canonical::CanonicalDraper;
#[cfg(doc)]
use crate::solver::canonical::canonical_settings;
use crate::solver::garment_drape::{SequenceSettings, drape_sequence};

/// The simulator's drape of one (pose, material): the ground truth a prediction is compared
/// with.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulatedDrape {
    /// The settled garment (metres).
    pub vertices: Vec<Vec3>,
    /// Wall-clock time of the whole drape (ms): the rest drape, the path (or walk) to the
    /// pose, the converge.
    pub wall_ms: Real,
    /// Whether the final converge met the residual tolerances.
    pub converged: bool,
}

/// Drapes `garment` of `material` on `body` at `pose` by the canonical protocol of
/// ground-truth revision 4 ([`CanonicalDraper`]: the rest drape carried along the canonical
/// path to `pose`, then converged, its triangles pushed out of the body, rounded to f32), on
/// this thread. With [`canonical_settings`] and the dataset's template and body, this is the
/// sample a revision-4 dataset made with the default settings holds for (pose, fabric).
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
    // One pose: its drape's time runs from the start, rest drape included.
    let started = Instant::now();
    let (vertices, stats) = CanonicalDraper::new(garment, body, material, settings)?.drape(pose)?;
    Ok(SimulatedDrape {
        vertices,
        wall_ms: started.elapsed().as_secs_f64() * 1e3,
        converged: stats.converged,
    })
}

/// The simulator's drapes along `poses`, in order, as an animation walks them
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
    use crate::solver::canonical::canonical_settings;
    use garmatnet_core::Resolution;

    #[test]
    fn a_simulated_sequence_walks_from_the_rest_drape() -> anyhow::Result<()> {
        let body = CapsuleBody::smpl_neutral();
        let shirt = Garment::tshirt(Resolution::Coarse, &body)?;
        let motion = MotionGenerator::new(0, 240).generate();
        let silk = Material::preset("Silk Chiffon")?;
        let settings = SequenceSettings::default();
        let drapes = simulate_sequence(&shirt, &body, &motion[2..4], &silk, &settings)?;
        assert_eq!(drapes.len(), 2);
        assert_ne!(drapes[1].vertices, drapes[0].vertices);
        assert!(drapes.iter().all(|d| d.wall_ms > 0.0));
        assert!(
            drapes
                .iter()
                .all(|d| d.vertices.iter().all(|v| v.iter().all(|c| c.is_finite())))
        );
        Ok(())
    }

    #[test]
    fn a_simulated_drape_is_the_canonical_sample() -> anyhow::Result<()> {
        let body = CapsuleBody::smpl_neutral();
        let shirt = Garment::tshirt(Resolution::Coarse, &body)?;
        let pose = MotionGenerator::new(0, 240).generate()[3].clone();
        let silk = Material::preset("Silk Chiffon")?;
        let settings = canonical_settings();
        let single = simulate_drape(&shirt, &body, &pose, &silk, &settings)?;
        let (sample, stats) =
            CanonicalDraper::new(&shirt, &body, &silk, &settings)?.drape(&pose)?;
        assert_eq!(single.vertices, sample);
        assert_eq!(single.converged, stats.converged);
        assert!(single.wall_ms > 0.0);
        Ok(())
    }
}
