//! How physical a prediction is, measured with the solver's own energy: the largest spring
//! stretch against the sound limit `dataset check` uses, and the drape energy above the
//! solver's equilibrium (the ground truth) per unit of the garment's weight.

use garmatnet_core::{Garment, Material, PosedBody, Vec3};
use garmatnet_sim::{
    ClothModel, DatasetSpec, DrapeSettings, SOUND_STRETCH, SequenceSettings, cloth_from_garment,
    drape_energy_and_gradient,
};

use crate::error::{Error, Result};
use crate::report::PhysicalQuality;

/// The largest strain `|x_a - x_b| / L - 1` over `model`'s springs (as the solver's
/// `DrapeStats::max_strain` and `dataset check` measure it).
#[must_use]
pub fn max_stretch(model: &ClothModel, x: &[Vec3]) -> f64 {
    model
        .springs()
        .iter()
        .filter(|s| s.rest_length > 0.0)
        .map(|s| ((x[s.a] - x[s.b]).norm() - s.rest_length) / s.rest_length)
        .fold(f64::NEG_INFINITY, f64::max)
}

/// Physical quality, accumulated sample by sample.
pub(crate) struct QualityAccumulator {
    garment: Garment,
    materials: Vec<Material>,
    models: Vec<Option<ClothModel>>,
    settings: DrapeSettings,
    stretch: Vec<f64>,
    truth_stretch: Vec<f64>,
    above_mm: Vec<f64>,
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
            materials,
            settings,
            stretch: Vec::new(),
            truth_stretch: Vec::new(),
            above_mm: Vec::new(),
        }
    }

    /// Adds one sample: the prediction `x` and the ground truth `truth` of fabric `material`
    /// on `body`.
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
        let model = match &mut self.models[material] {
            Some(model) => model,
            slot => slot.insert(cloth_from_garment(
                &self.garment,
                &self.materials[material],
            )?),
        };
        let weight: f64 = model.masses().iter().sum::<f64>() * self.settings.gravity;
        let (predicted, _) = drape_energy_and_gradient(model, &self.settings, body, x)?;
        let (settled, _) = drape_energy_and_gradient(model, &self.settings, body, truth)?;
        self.above_mm
            .push(1e3 * (predicted.total() - settled.total()) / weight);
        self.stretch.push(max_stretch(model, x));
        self.truth_stretch.push(max_stretch(model, truth));
        Ok(())
    }

    /// The statistics, or `None` before any sample.
    pub(crate) fn finish(&self) -> Option<PhysicalQuality> {
        let n = self.stretch.len();
        if n == 0 {
            return None;
        }
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let mut sorted = self.above_mm.clone();
        sorted.sort_by(f64::total_cmp);
        Some(PhysicalQuality {
            samples: n,
            sound_stretch: SOUND_STRETCH,
            mean_max_stretch: mean(&self.stretch),
            worst_stretch: self
                .stretch
                .iter()
                .copied()
                .fold(f64::NEG_INFINITY, f64::max),
            past_sound_stretch: self.stretch.iter().filter(|&&s| s > SOUND_STRETCH).count(),
            truth_mean_max_stretch: mean(&self.truth_stretch),
            mean_energy_above_truth_mm: mean(&self.above_mm),
            median_energy_above_truth_mm: sorted[n / 2],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use garmatnet_core::{CapsuleBody, Pose, Resolution};
    use garmatnet_sim::{CanonicalDraper, canonical_settings};

    /// The ground truth against itself is 0 above and its own stretch; the same drape
    /// stretched by 10 % about its centre reads a stretch near 0.1 more and a positive
    /// energy above it; a drape pulled into the body reads a contact energy above it.
    #[test]
    fn a_stretched_or_sunken_drape_reads_above_the_ground_truth() {
        let body = CapsuleBody::smpl_neutral();
        let garment = Garment::tshirt(Resolution::Coarse, &body).unwrap();
        let material = Material::preset("Cotton Jersey").unwrap();
        let settings = canonical_settings();
        let draper = CanonicalDraper::new(&garment, &body, &material, &settings).unwrap();
        let pose = Pose::zero();
        let (truth, stats) = draper.drape(&pose).unwrap();
        let posed = body.pose(&pose);
        let mut q = QualityAccumulator::from_parts(&garment, vec![material], settings.drape);
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
    }
}
