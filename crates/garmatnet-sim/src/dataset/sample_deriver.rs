//! Deriving a sample's stored arrays from its simulated garment, exactly as the generator
//! does (the generator, the reader and shard merging all use it).

use garmatnet_core::{
    CapsuleBody, Garment, LaplacianSmoother, LaplacianWeights, Pose, Resolution, SkinnedBody,
    SmoothingSettings, Vec3,
};

use crate::dataset::manifest::DatasetSpec;
use crate::dataset::sample_arrays::SampleArrays;
use crate::error::{Error, Result, SpecField};

/// The name datasets record for the procedural body.
pub const BODY_NAME: &str = "capsule-smpl-neutral";

/// Derives a sample's stored arrays from its simulated garment exactly as the generator
/// does: the Laplacian-smoothed garment (the fitting net's target) and the posed body points.
///
/// [`crate::merge_shards`] uses it to complete samples that travelled without their derived
/// arrays (only `simulated.npy` and `stats.json`, a third of the bytes).
#[derive(Debug)]
pub struct SampleDeriver {
    body: CapsuleBody,
    garment: Garment,
    smoother: LaplacianSmoother,
}

impl SampleDeriver {
    /// The deriver for the procedural body, the T-shirt at `resolution` and `smoothing`.
    ///
    /// # Errors
    /// [`Error::Core`] if the T-shirt or the smoother cannot be built.
    pub fn new(resolution: Resolution, smoothing: SmoothingSettings) -> Result<Self> {
        let body = CapsuleBody::smpl_neutral();
        let garment = Garment::tshirt(resolution, &body)?;
        Self::with_garment(body, garment, smoothing)
    }

    /// The deriver for `garment` on `body` with `smoothing`.
    ///
    /// # Errors
    /// [`Error::Core`] if the smoother cannot be built.
    pub fn with_garment(
        body: CapsuleBody,
        garment: Garment,
        smoothing: SmoothingSettings,
    ) -> Result<Self> {
        let smoother = LaplacianSmoother::new(&garment.rest, smoothing)?;
        Ok(Self {
            body,
            garment,
            smoother,
        })
    }

    /// The deriver a dataset was written with, rebuilt from its spec; refuses a spec whose
    /// body, template or smoothing this library cannot reproduce.
    ///
    /// # Errors
    /// [`Error::Core`] with [`garmatnet_core::Error::Mismatch`] if the body is not
    /// [`BODY_NAME`] or the rebuilt template's vertex count or hash differs from the spec's;
    /// [`Error::InvalidSpec`] (field [`SpecField::Smoothing`]) for an unknown smoothing
    /// weighting.
    pub fn for_spec(spec: &DatasetSpec) -> Result<Self> {
        let mismatch = |what: &str, expected: String, got: String| {
            Error::Core(garmatnet_core::Error::Mismatch {
                what: format!("dataset's {what} (made by another version of garmatnet?)"),
                expected,
                got,
            })
        };
        if spec.body.name != BODY_NAME {
            return Err(mismatch(
                "body",
                BODY_NAME.to_owned(),
                spec.body.name.clone(),
            ));
        }
        let resolution: Resolution = spec.template.resolution;
        let weights: LaplacianWeights =
            serde_json::from_value(serde_json::Value::String(spec.smoothing.weights.clone()))
                .map_err(|_| Error::InvalidSpec {
                    field: SpecField::Smoothing,
                    entry: None,
                    problem: format!(
                        "dataset's smoothing weights `{}`: expected `uniform` or `cotangent`",
                        spec.smoothing.weights
                    ),
                })?;
        let smoothing = SmoothingSettings {
            lambda: spec.smoothing.lambda,
            iterations: spec.smoothing.iterations as usize,
            weights,
        };
        let body = CapsuleBody::smpl_neutral();
        // The style (fitted or boxy) is the one whose hash the spec records; a hash no style
        // has is reported below with the fitted shirt's.
        let garment = match Garment::for_template(resolution, &spec.template.hash, &body) {
            Ok(garment) => garment,
            Err(_) => Garment::tshirt(resolution, &body)?,
        };
        let deriver = Self::with_garment(body, garment, smoothing)?;
        let hash = format!("{:016x}", deriver.garment.template_hash());
        if deriver.garment.vertex_count() != spec.template.vertex_count
            || hash != spec.template.hash
        {
            return Err(mismatch(
                "template",
                format!(
                    "{} vertices, hash {}",
                    spec.template.vertex_count, spec.template.hash
                ),
                format!("{} vertices, hash {hash}", deriver.garment.vertex_count()),
            ));
        }
        Ok(deriver)
    }

    /// The body the garment is draped on.
    #[must_use]
    pub fn body(&self) -> &CapsuleBody {
        &self.body
    }

    /// The garment template.
    #[must_use]
    pub fn garment(&self) -> &Garment {
        &self.garment
    }

    /// The arrays stored for a drape `simulated` of the garment on `pose`.
    ///
    /// # Errors
    /// [`Error::Core`] if `simulated` does not have the template's vertex count or is not
    /// finite.
    pub fn arrays(&self, simulated: &[Vec3], pose: &Pose) -> Result<SampleArrays> {
        let smooth = self.smoother.smooth(simulated)?;
        let transforms = self.body.skeleton().skinning_transforms(pose);
        let to_f32 = |v: &[Vec3]| {
            v.iter()
                .map(|p| [p.x as f32, p.y as f32, p.z as f32])
                .collect()
        };
        Ok(SampleArrays {
            simulated: to_f32(simulated),
            smoothed: to_f32(&smooth),
            body: to_f32(&self.garment.body_points(&transforms)),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dataset::writer::tests::tiny_spec;

    #[test]
    fn a_spec_with_unknown_smoothing_weights_is_refused_by_field() {
        let mut spec = tiny_spec();
        spec.body.name = BODY_NAME.to_owned();
        spec.smoothing.weights = "harmonic".into();
        let err = SampleDeriver::for_spec(&spec).err().unwrap();
        assert!(
            matches!(
                err,
                Error::InvalidSpec {
                    field: SpecField::Smoothing,
                    entry: None,
                    ..
                }
            ),
            "{err}"
        );
        assert!(err.to_string().contains("`harmonic`"), "{err}");
    }
}
