//! How physical a prediction is, measured with the solver's own energy and springs, on the
//! raw prediction (before push-out) with the ground truth's own values beside it: the force
//! residual in the solver's stopping units, the deepest penetration, the largest spring
//! stretch against the sound limit `dataset check` uses, the drape energy above the
//! solver's equilibrium (the ground truth) per unit of the garment's weight, and, on a few
//! samples, the Newton iterations the solver needs to converge from the prediction.
//!
//! None of these depends on which of several nearby equilibria the solver reached, so they
//! say whether a prediction is a drape at all where the millimetre errors cannot.

use garmatnet_core::{Garment, Material, PosedBody, SignedDistance, Vec3, push_mesh_outside};
use garmatnet_sim::{
    ClothModel, DatasetSpec, DrapeSettings, DrapeSolver, SOUND_STRETCH, SequenceSettings,
    cloth_from_garment, drape_energy_and_gradient, force_residual,
};

use crate::error::{Error, Result};
use crate::evaluation::report::{NewtonFromPrediction, PhysicalQuality};

/// The deepest point of `x` inside `body` (metres, ≥ 0).
fn deepest(body: &PosedBody, x: &[Vec3]) -> f64 {
    x.iter()
        .map(|v| (-body.distance(v)).max(0.0))
        .fold(0.0, f64::max)
}

/// Physical quality, accumulated sample by sample.
pub(crate) struct QualityAccumulator {
    garment: Garment,
    materials: Vec<Material>,
    models: Vec<Option<ClothModel>>,
    solvers: Vec<Option<DrapeSolver>>,
    settings: DrapeSettings,
    stretch: Vec<f64>,
    truth_stretch: Vec<f64>,
    above_mm: Vec<f64>,
    residual: Vec<f64>,
    truth_residual: Vec<f64>,
    depth_mm: Vec<f64>,
    truth_depth_mm: Vec<f64>,
    /// Per polished sample: iterations from the prediction, converged, the ground truth's
    /// own iterations, and the polished drape's mean distance to the ground truth (mm).
    polished: Vec<(u64, bool, u64, f64)>,
}

impl QualityAccumulator {
    /// For the samples of a dataset of `spec` on `garment`, with the solver settings its
    /// manifest records.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] if the manifest's solver settings or a fabric cannot be read.
    pub(crate) fn new(garment: &Garment, spec: &DatasetSpec) -> Result<Self> {
        let settings = SequenceSettings::from_manifest(&spec.solver)
            .map_err(|e| {
                Error::InvalidConfig(format!("the dataset's solver settings are unreadable: {e}"))
            })?
            .drape;
        let materials = spec
            .materials
            .iter()
            .map(|m| Material::from_normalized(m.omega_normalized))
            .collect::<garmatnet_core::Result<Vec<_>>>()?;
        Ok(Self::from_parts(garment, materials, settings))
    }

    /// For samples of `materials` (indexed as the samples name them) under `settings`.
    pub(crate) fn from_parts(
        garment: &Garment,
        materials: Vec<Material>,
        settings: DrapeSettings,
    ) -> Self {
        Self {
            garment: garment.clone(),
            models: vec![None; materials.len()],
            solvers: (0..materials.len()).map(|_| None).collect(),
            materials,
            settings,
            stretch: Vec::new(),
            truth_stretch: Vec::new(),
            above_mm: Vec::new(),
            residual: Vec::new(),
            truth_residual: Vec::new(),
            depth_mm: Vec::new(),
            truth_depth_mm: Vec::new(),
            polished: Vec::new(),
        }
    }

    /// The cloth model of fabric `material`, made on first use.
    fn model(&mut self, material: usize) -> Result<&ClothModel> {
        Ok(match &mut self.models[material] {
            Some(model) => model,
            slot => slot.insert(cloth_from_garment(
                &self.garment,
                &self.materials[material],
            )?),
        })
    }

    /// Adds one sample: the raw prediction `x` (before push-out) and the ground truth
    /// `truth` of fabric `material` on `body`.
    ///
    /// # Errors
    /// As [`cloth_from_garment`] and [`drape_energy_and_gradient`] (non-finite positions).
    pub(crate) fn add(
        &mut self,
        material: usize,
        body: &PosedBody,
        x: &[Vec3],
        truth: &[Vec3],
    ) -> Result<()> {
        let settings = self.settings.clone();
        let model = self.model(material)?;
        let weight: f64 = model.masses().iter().sum::<f64>() * settings.gravity;
        let (predicted, gradient) = drape_energy_and_gradient(model, &settings, body, x)?;
        let (settled, truth_gradient) = drape_energy_and_gradient(model, &settings, body, truth)?;
        // No vertex is pinned; friction, which is not part of the energy, is left out.
        let free = vec![false; x.len()];
        let (residual, _) = force_residual(&gradient, model.masses(), &free, settings.gravity);
        let (truth_residual, _) =
            force_residual(&truth_gradient, model.masses(), &free, settings.gravity);
        let (stretch, truth_stretch) = (model.max_strain(x)?, model.max_strain(truth)?);
        self.above_mm
            .push(1e3 * (predicted.total() - settled.total()) / weight);
        self.stretch.push(stretch);
        self.truth_stretch.push(truth_stretch);
        self.residual.push(residual);
        self.truth_residual.push(truth_residual);
        self.depth_mm.push(1e3 * deepest(body, x));
        self.truth_depth_mm.push(1e3 * deepest(body, truth));
        Ok(())
    }

    /// Drapes fabric `material` on `body` with the solver, from `start` (the prediction,
    /// pushed out of the body) to its residual criterion, and records the iterations it
    /// took beside `truth_iterations`, the ground truth's own, and how far the result lies
    /// from `truth`.
    ///
    /// # Errors
    /// As [`DrapeSolver::new`] and [`DrapeSolver::drape`].
    pub(crate) fn polish(
        &mut self,
        material: usize,
        body: &PosedBody,
        start: &[Vec3],
        truth: &[Vec3],
        truth_iterations: u64,
    ) -> Result<()> {
        let mut solver = match self.solvers[material].take() {
            Some(solver) => solver,
            None => {
                let settings = self.settings.clone();
                DrapeSolver::new(self.model(material)?, &settings)?
            }
        };
        let mut x = start.to_vec();
        let stats = solver.drape(&mut x, body, &[])?;
        self.solvers[material] = Some(solver);
        // Recorded as a sample is (ground-truth revision 4): the triangles pushed out of the
        // body between their vertices too.
        push_mesh_outside(&mut x, &self.garment.rest.faces, body, &[]);
        let distance_mm = 1e3
            * x.iter()
                .zip(truth)
                .map(|(a, b)| (a - b).norm())
                .sum::<f64>()
            / x.len().max(1) as f64;
        self.polished.push((
            stats.iterations as u64,
            stats.converged,
            truth_iterations,
            distance_mm,
        ));
        Ok(())
    }

    /// The statistics, or `None` before any sample.
    pub(crate) fn finish(&self) -> Option<PhysicalQuality> {
        let n = self.stretch.len();
        if n == 0 {
            return None;
        }
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let worst = |v: &[f64]| v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let median = |v: &[f64]| {
            let mut sorted = v.to_vec();
            sorted.sort_by(f64::total_cmp);
            sorted[sorted.len() / 2]
        };
        let newton = (!self.polished.is_empty()).then(|| {
            let k = self.polished.len() as f64;
            NewtonFromPrediction {
                samples: self.polished.len(),
                mean_iterations: self.polished.iter().map(|p| p.0 as f64).sum::<f64>() / k,
                converged: self.polished.iter().filter(|p| p.1).count(),
                truth_mean_iterations: self.polished.iter().map(|p| p.2 as f64).sum::<f64>() / k,
                mean_distance_to_truth_mm: self.polished.iter().map(|p| p.3).sum::<f64>() / k,
            }
        });
        Some(PhysicalQuality {
            samples: n,
            sound_stretch: SOUND_STRETCH,
            mean_max_stretch: mean(&self.stretch),
            worst_stretch: worst(&self.stretch),
            past_sound_stretch: self.stretch.iter().filter(|&&s| s > SOUND_STRETCH).count(),
            truth_mean_max_stretch: mean(&self.truth_stretch),
            mean_energy_above_truth_mm: mean(&self.above_mm),
            median_energy_above_truth_mm: median(&self.above_mm),
            median_residual: median(&self.residual),
            truth_median_residual: median(&self.truth_residual),
            mean_depth_mm: mean(&self.depth_mm),
            worst_depth_mm: worst(&self.depth_mm),
            truth_worst_depth_mm: worst(&self.truth_depth_mm),
            newton,
        })
    }
}
#[cfg(test)]
mod tests {
    use super::*;
    use garmatnet_core::{CapsuleBody, Pose, Resolution};
    use garmatnet_sim::{CanonicalDraper, DrapeStats, canonical_settings};

    /// `preset` draped at the zero pose on the coarse shirt by the canonical protocol: the
    /// drape, its solver stats, the posed body and an accumulator for that fabric alone.
    fn zero_pose_drape(preset: &str) -> (Vec<Vec3>, DrapeStats, PosedBody, QualityAccumulator) {
        let body = CapsuleBody::smpl_neutral();
        let garment = Garment::tshirt(Resolution::Coarse, &body).unwrap();
        let material = Material::preset(preset).unwrap();
        let settings = canonical_settings();
        let draper = CanonicalDraper::new(&garment, &body, &material, &settings).unwrap();
        let pose = Pose::zero();
        let (truth, stats) = draper.drape(&pose).unwrap();
        let q = QualityAccumulator::from_parts(&garment, vec![material], settings.drape);
        (truth, stats, body.pose(&pose), q)
    }

    /// The ground truth against itself is 0 above and its own stretch; the same drape
    /// stretched by 10 % about its centre reads a stretch near 0.1 more and a positive
    /// energy above it; a drape pulled into the body reads a contact energy above it.
    #[test]
    fn a_stretched_or_sunken_drape_reads_above_the_ground_truth() {
        let (truth, stats, posed, mut q) = zero_pose_drape("Cotton Jersey");
        q.add(0, &posed, &truth, &truth).unwrap();
        let centre = truth.iter().sum::<Vec3>() / truth.len() as f64;
        let stretched: Vec<Vec3> = truth.iter().map(|v| centre + (v - centre) * 1.1).collect();
        q.add(0, &posed, &stretched, &truth).unwrap();
        let sunken: Vec<Vec3> = truth.iter().map(|v| centre + (v - centre) * 0.8).collect();
        q.add(0, &posed, &sunken, &truth).unwrap();
        let r = q.finish().unwrap();
        assert_eq!(r.samples, 3);
        assert!(
            (q.truth_stretch[0] - stats.max_strain).abs() < 1e-3,
            "{r:?}"
        );
        assert_eq!(q.above_mm[0], 0.0);
        assert!((q.stretch[1] - (1.1 * (1.0 + q.truth_stretch[1]) - 1.0)).abs() < 1e-9);
        assert!(q.above_mm[1] > 1.0, "{:?}", q.above_mm);
        assert!(q.above_mm[2] > 1.0, "{:?}", q.above_mm);
        assert_eq!(r.past_sound_stretch, 0);
        assert!(r.mean_energy_above_truth_mm > 0.0);
        // The solver's own drape balances its forces up to what friction holds and what
        // storing it in f32 moves (measured: 6.4 vertex weights here); the stretched and
        // sunken drapes are far from balanced, and the sunken one lies inside the body.
        assert!(q.truth_residual[0].is_finite(), "{:?}", q.truth_residual);
        assert!(
            q.residual[1] > 10.0 * q.truth_residual[1],
            "{:?}",
            q.residual
        );
        assert!(
            q.residual[2] > 10.0 * q.truth_residual[2],
            "{:?}",
            q.residual
        );
        assert!(q.truth_depth_mm[0] <= 1.0, "{:?}", q.truth_depth_mm);
        assert!(q.depth_mm[2] > 5.0, "{:?}", q.depth_mm);
        assert!(r.newton.is_none());
    }

    /// Polishing the ground truth itself converges quickly and stays near it; polishing a
    /// stretched copy takes more iterations and ends farther from it. A revision-4 truth has
    /// its triangles pushed off the body between their vertices, which the solver's
    /// equilibrium does not hold: on the coarse shirt, whose chords over the arms reach deeper
    /// than the 3 mm contact margin, polishing the truth moves it 3.6 mm on average (the
    /// stretched copy ends 8.1 mm from it).
    #[test]
    fn polishing_counts_the_newton_iterations_from_a_start() {
        let (truth, stats, posed, mut q) = zero_pose_drape("Denim Heavy");
        q.add(0, &posed, &truth, &truth).unwrap();
        q.polish(0, &posed, &truth, &truth, stats.iterations as u64)
            .unwrap();
        let centre = truth.iter().sum::<Vec3>() / truth.len() as f64;
        let stretched: Vec<Vec3> = truth.iter().map(|v| centre + (v - centre) * 1.05).collect();
        q.polish(0, &posed, &stretched, &truth, stats.iterations as u64)
            .unwrap();
        let (at_truth, from_stretched) = (q.polished[0], q.polished[1]);
        assert!(at_truth.1 && from_stretched.1, "{:?}", q.polished);
        assert!(at_truth.0 < from_stretched.0, "{:?}", q.polished);
        assert!(
            at_truth.3 < 5.0 && at_truth.3 < 0.5 * from_stretched.3,
            "{:?}",
            q.polished
        );
        let n = q.finish().unwrap().newton.unwrap();
        assert_eq!((n.samples, n.converged), (2, 2));
        assert_eq!(n.truth_mean_iterations, stats.iterations as f64);
    }
}
