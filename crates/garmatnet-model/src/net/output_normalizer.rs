//! Per-coordinate output normalisation (paper §3.5, "we normalize our output").
//!
//! The networks predict `(d − mean) / std` for each of the 3n displacement coordinates, so
//! every output has unit scale whatever the vertex's typical displacement.

use garmatnet_core::Real;
use garmatnet_core::error::ensure_finite;
use serde::{Deserialize, Serialize};

use crate::error::Result;

/// The smallest per-coordinate standard deviation (metres); smaller ones are raised to it.
///
/// A coordinate that never moves (e.g. `D_local` at a corner the smoother holds fixed) has
/// std 0. Raising it to 10 µm (not to 1, which would turn every small net error there into a
/// metre-sized spike) keeps normalising finite and a unit net error there costs 10 µm.
pub const MIN_STD: Real = 1e-5;

/// Mean and standard deviation of each displacement coordinate over the training set
/// (metres), vertex-major (`x0 y0 z0 x1 …`).
///
/// Deserialising goes through [`OutputNormalizer::from_parts`], so a stored normaliser with
/// lengths that differ, a NaN or a negative std is refused when it is read, not used.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "NormalizerParts")]
pub struct OutputNormalizer {
    mean: Vec<Real>,
    std: Vec<Real>,
}

/// The serialised form of an [`OutputNormalizer`], validated on the way in.
#[derive(Deserialize)]
struct NormalizerParts {
    mean: Vec<Real>,
    std: Vec<Real>,
}

impl TryFrom<NormalizerParts> for OutputNormalizer {
    type Error = crate::error::Error;

    fn try_from(parts: NormalizerParts) -> Result<Self> {
        Self::from_parts(parts.mean, parts.std)
    }
}

impl OutputNormalizer {
    /// Fits mean and std (population) over `samples`, each of length `3n`.
    ///
    /// # Errors
    /// [`crate::Error::EmptyInput`] for no samples;
    /// [`garmatnet_core::Error::WrongLength`] if the samples differ in length;
    /// [`garmatnet_core::Error::NonFinite`] for NaN or infinity.
    pub fn fit<S: AsRef<[Real]>>(samples: &[S]) -> Result<Self> {
        let Some(first) = samples.first() else {
            return Err(crate::error::Error::EmptyInput {
                what: "fitting an output normaliser",
                needs: "at least one sample",
            });
        };
        let dim = first.as_ref().len();
        let mut mean = vec![0.0; dim];
        for s in samples {
            let s = s.as_ref();
            if s.len() != dim {
                return Err(garmatnet_core::Error::WrongLength {
                    what: "displacement sample".into(),
                    expected: dim.to_string(),
                    got: s.len(),
                }
                .into());
            }
            ensure_finite("displacement sample", s.iter().copied())?;
            mean.iter_mut().zip(s).for_each(|(m, v)| *m += v);
        }
        let count = samples.len() as Real;
        mean.iter_mut().for_each(|m| *m /= count);
        let mut var = vec![0.0; dim];
        for s in samples {
            for ((v, x), m) in var.iter_mut().zip(s.as_ref()).zip(&mean) {
                *v += (x - m) * (x - m);
            }
        }
        let std = var.into_iter().map(|v| (v / count).sqrt()).collect();
        Self::from_parts(mean, std)
    }

    /// A normaliser from stored mean and std; stds below [`MIN_STD`] are raised to it.
    ///
    /// # Errors
    /// [`garmatnet_core::Error::WrongLength`] if the lengths differ;
    /// [`garmatnet_core::Error::NonFinite`] for NaN or infinity; negative stds are
    /// [`garmatnet_core::Error::OutOfRange`].
    pub fn from_parts(mean: Vec<Real>, std: Vec<Real>) -> Result<Self> {
        if mean.len() != std.len() {
            return Err(garmatnet_core::Error::WrongLength {
                what: "normaliser std".into(),
                expected: mean.len().to_string(),
                got: std.len(),
            }
            .into());
        }
        ensure_finite("normaliser mean", mean.iter().copied())?;
        ensure_finite("normaliser std", std.iter().copied())?;
        if let Some(&bad) = std.iter().find(|&&s| s < 0.0) {
            return Err(garmatnet_core::Error::OutOfRange {
                what: "normaliser std (m)".into(),
                value: bad,
                min: 0.0,
                max: Real::INFINITY,
                hint: String::new(),
            }
            .into());
        }
        let std = std.into_iter().map(|s| s.max(MIN_STD)).collect();
        Ok(Self { mean, std })
    }

    /// The identity normaliser (mean 0, std 1) of `dim` coordinates.
    #[must_use]
    pub fn identity(dim: usize) -> Self {
        Self {
            mean: vec![0.0; dim],
            std: vec![1.0; dim],
        }
    }

    /// The number of coordinates, 3n.
    #[must_use]
    pub fn dim(&self) -> usize {
        self.mean.len()
    }

    /// Per-coordinate means (metres).
    #[must_use]
    pub fn mean(&self) -> &[Real] {
        &self.mean
    }

    /// Per-coordinate standard deviations (metres), already guarded against zero.
    #[must_use]
    pub fn std(&self) -> &[Real] {
        &self.std
    }

    /// `(d − mean) / std` for a full `3n` vector.
    ///
    /// # Panics
    /// If `values.len() != 3n` (callers size their buffers from the model).
    #[must_use]
    pub fn normalize(&self, values: &[Real]) -> Vec<Real> {
        assert_eq!(values.len(), self.dim(), "normalize: length must be 3n");
        values
            .iter()
            .zip(&self.mean)
            .zip(&self.std)
            .map(|((v, m), s)| (v - m) / s)
            .collect()
    }

    /// `y · std + mean` for a full `3n` vector of network outputs.
    ///
    /// # Panics
    /// If `values.len() != 3n`.
    #[must_use]
    pub fn denormalize(&self, values: &[f32]) -> Vec<Real> {
        assert_eq!(values.len(), self.dim(), "denormalize: length must be 3n");
        values
            .iter()
            .zip(&self.mean)
            .zip(&self.std)
            .map(|((&v, m), s)| v as Real * s + m)
            .collect()
    }

    /// Denormalises outputs of a vertex subset: `values[3i + c]` belongs to `vertices[i]`.
    ///
    /// # Panics
    /// If the lengths disagree or a vertex is out of range (checked when the head was built).
    #[must_use]
    pub fn denormalize_vertices(&self, values: &[f32], vertices: &[usize]) -> Vec<Real> {
        assert_eq!(
            values.len(),
            3 * vertices.len(),
            "denormalize_vertices: 3 values per vertex"
        );
        values
            .iter()
            .enumerate()
            .map(|(i, &v)| {
                let k = 3 * vertices[i / 3] + i % 3;
                v as Real * self.std[k] + self.mean[k]
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    #[test]
    fn fit_centres_and_scales_and_guards_constant_coordinates() {
        let samples = vec![vec![1.0, 5.0, 0.3], vec![3.0, 5.0, -0.3]];
        let n = OutputNormalizer::fit(&samples).unwrap();
        assert_relative_eq!(n.mean()[0], 2.0);
        assert_relative_eq!(n.std()[0], 1.0);
        assert_eq!(
            n.std()[1],
            MIN_STD,
            "zero variance must become the floor, not 1 m"
        );
        assert_relative_eq!(n.std()[2], 0.3);
        let z = n.normalize(&samples[0]);
        assert_relative_eq!(z[0], -1.0);
        assert_relative_eq!(z[1], 0.0);
        assert!(z.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn bad_inputs_are_refused() {
        assert!(matches!(
            OutputNormalizer::fit::<Vec<Real>>(&[]),
            Err(crate::Error::EmptyInput { .. })
        ));
        assert!(OutputNormalizer::fit(&[vec![1.0], vec![1.0, 2.0]]).is_err());
        assert!(OutputNormalizer::fit(&[vec![f64::NAN]]).is_err());
        assert!(OutputNormalizer::from_parts(vec![0.0], vec![-1.0]).is_err());
        assert!(OutputNormalizer::from_parts(vec![0.0], vec![]).is_err());
    }

    #[test]
    fn a_stored_normaliser_is_validated_when_read() {
        let read = |json: &str| serde_json::from_str::<OutputNormalizer>(json);
        for bad in [
            r#"{"mean": [0.0, 1.0], "std": [1.0]}"#,
            r#"{"mean": [0.0], "std": [-0.5]}"#,
        ] {
            assert!(read(bad).is_err(), "{bad} was accepted");
        }
        // A zero std reads as the floor, as when it was fitted.
        let n = read(r#"{"mean": [0.0], "std": [0.0]}"#).unwrap();
        assert_eq!(n.std(), &[MIN_STD]);
    }

    #[test]
    fn serde_round_trip() {
        let n = OutputNormalizer::from_parts(vec![0.1, -0.2], vec![0.01, 0.0]).unwrap();
        let back: OutputNormalizer =
            serde_json::from_str(&serde_json::to_string(&n).unwrap()).unwrap();
        assert_eq!(n, back);
    }

    proptest! {
        #[test]
        fn normalize_denormalize_round_trip(
            data in prop::collection::vec(prop::collection::vec(-0.1f64..0.1, 6), 2..6)
        ) {
            let n = OutputNormalizer::fit(&data).unwrap();
            for s in &data {
                let z: Vec<f32> = n.normalize(s).iter().map(|&v| v as f32).collect();
                let back = n.denormalize(&z);
                for (a, b) in back.iter().zip(s) {
                    prop_assert!((a - b).abs() < 1e-6 * (1.0 + b.abs()) + 1e-7);
                }
                let sub = n.denormalize_vertices(&z[3..6], &[1]);
                for (a, b) in sub.iter().zip(&back[3..6]) {
                    prop_assert_eq!(a, b);
                }
            }
        }
    }
}
