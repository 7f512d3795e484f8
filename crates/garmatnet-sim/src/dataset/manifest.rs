//! The dataset manifest (`DIR/manifest.json`) and the per-sample completion marker; the
//! whole on-disk layout is in the book's dataset-format chapter (`book/src/dataset-format.md`)
//! and on [`crate::DatasetWriter`].

use std::path::{Path, PathBuf};

use garmatnet_core::{Error, Pose, Result, TemplateInfo};
use serde::{Deserialize, Serialize};

use crate::error::SpecField;
use crate::solver::canonical::DrapeProtocol;

/// The on-disk format version this crate reads and writes.
pub const DATASET_FORMAT_VERSION: u32 = 1;

/// The ground-truth revision: which version of the drapes this crate's solver makes, for the
/// same inputs and settings. It is bumped by every change that moves a drape (the settings in
/// a manifest cannot show a change of code), recorded in every new dataset's manifest
/// ([`DatasetSpec::ground_truth_revision`]), and a dataset is only resumed, extended
/// (`--reuse`) or merged with drapes of its own revision, so one dataset never mixes two
/// solvers. `tests/ground_truth_revision.rs` holds a fixture of this revision's drapes and
/// fails when they move.
///
/// - **1**: the solver that made the 30 × 200 dataset (`e4d34195bfac4646`) of the model
///   shipped before revision 2's, before revisions were recorded (its manifest has none).
/// - **2**: the final projection out of the body takes Newton steps scaled by the distance
///   field's gradient length (garmatnet-core's `push_outside`), so it reaches the surface in
///   the blend regions of the body's capsules. A vertex left inside the body in a crevice
///   lands elsewhere than in revision 1, and a walk continues from there: Felt's drapes along
///   the brisk motion (default resolution, seed 0) equal revision 1's to frame 6 and differ
///   by up to 17 mm from frame 7 on. The model shipped up to version 0.3 learned this
///   revision's walks.
/// - **3**: each sample is draped on its own by the canonical protocol
///   ([`crate::CanonicalDraper`], recorded as [`DatasetSpec::protocol`]), so a drape is a
///   function of (pose, fabric, settings) and not of the walk that reached it; the T-shirt is
///   the fitted one dressed in the A-pose; and the body and the rest drape changed. The arms blend into the trunk only within 10 cm of
///   the shoulders (garmatnet-core's `LimbRoot`), so a gap between a lowered arm and the
///   ribs stays open; the neutral skeleton is made exactly mirror-symmetric (SMPL's joints
///   averaged with their mirrored twins, moves of at most 12 mm, the head's), which moves the T-shirt
///   template with it; and the rest drape lands the shirt frictionless for
///   `LANDING_ITERATIONS` Newton iterations, then settles it with friction. T-pose drapes
///   are mirror-symmetric (0.0–0.1 mm on six fabrics at coarse resolution, from 60–84 mm).
///   Where two body parts press into each other the body leaves the cloth a channel about
///   1 cm wide, its lips rounded (garmatnet-core's `PINCH_HALF_WIDTH`, `PINCH_SMOOTHING`), and the fitted shirt's springs are at least 0.7
///   of their pattern length (`FITTED_MIN_REST_FRACTION`), so hanging and raised arms do
///   not tear the cloth. A rest drape that does not settle within the iteration cap is
///   restarted from its mirror average ([`crate::settle_rest_drape`]); of the presets only
///   Spandex's changes with it (it drifted 22 mm to the body's left), so the revision stays
///   3, and the Spandex samples of datasets made before version 0.7.0 are stale.
/// - **4**: the final projection out of the body keeps the cloth's triangles out between
///   their vertices too: after the vertices, garmatnet-core's `push_mesh_outside` moves them
///   until a grid of points across each triangle (quarters of its edges and the centroid)
///   lies outside the body. Revision 3's drapes at the everyday suite cut up to
///   4.92 mm under the body between their vertices where a convex part pressed on the cloth
///   (a forearm on the chest); in canonical samples the vertices of such triangles move out
///   by up to a few millimetres and every other vertex stays where revision 3 put it (the
///   path is unchanged), while a walk goes on from each pushed frame, so its later frames
///   differ more.
pub const GROUND_TRUTH_REVISION: u32 = 4;

/// The body the garments were draped on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BodyInfo {
    /// The body model's name, e.g. `"capsule-smpl-neutral"`.
    pub name: String,
}

/// One fabric of the dataset, by value so the dataset does not depend on a preset library.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MaterialEntry {
    /// The material's name (unique within the dataset).
    pub name: String,
    /// Physical parameters ω: structural vertical and horizontal, flexion vertical and
    /// horizontal, shear stiffness (N/m) and density (kg/m²).
    pub omega: [f64; 6],
    /// ω mapped to the network's normalised input range.
    pub omega_normalized: [f64; 6],
}

/// The Laplacian smoothing that produced the `smoothed` arrays.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SmoothingInfo {
    /// Smoothing strength λ per iteration.
    pub lambda: f64,
    /// Number of smoothing iterations.
    pub iterations: u32,
    /// The Laplacian weighting scheme, e.g. `"uniform"` or `"cotangent"`.
    pub weights: String,
}

/// What the solver reported for one sample.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SampleStats {
    /// Solver iterations used.
    pub iterations: u64,
    /// Final residual: RMS over free vertices of net force over weight, `|f_i| / (m_i g)`
    /// (dimensionless; [`crate::DrapeStats::final_residual`]).
    pub residual: f64,
    /// Deepest garment penetration into the body (metres, ≥ 0), after the solver's final
    /// projection: since ground-truth revision 4 at the vertices and at points across every
    /// triangle ([`crate::DrapeStats::max_penetration`]), before rounding to f32 (which
    /// moves a point by at most about 3e-8 m).
    pub max_penetration_m: f64,
    /// Deepest vertex inside the body before that projection (metres, ≥ 0;
    /// [`crate::DrapeStats::max_depth_before_projection`]): where the contact did not hold
    /// the cloth out. `None` in datasets made before it was recorded (absent from their
    /// manifests).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_depth_before_projection_m: Option<f64>,
    /// Largest edge strain (relative length change, dimensionless).
    pub max_strain: f64,
    /// Wall-clock time of the sample (milliseconds): by the canonical protocol, the path
    /// from the rest drape to the pose plus the final converge (the rest drape itself not
    /// included); in a walk, the walk from the previous pose (or the rest drape, for a
    /// material's first pose) plus the final converge.
    pub wall_time_ms: f64,
    /// Whether the solver met its tolerance.
    pub converged: bool,
}

/// A finished sample: the material and pose it drapes, where its arrays are, and its stats.
/// Written as the sample's `stats.json` completion marker and listed in the manifest.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SampleRecord {
    /// Index into [`DatasetSpec::materials`].
    pub material: usize,
    /// Index into [`DatasetSpec::poses`].
    pub pose: usize,
    /// The sample's directory name under `DIR/samples/` ([`sample_stem`]).
    pub stem: String,
    /// The solver's report.
    pub stats: SampleStats,
}

/// Which (material, pose) samples a dataset holds.
///
/// Poses, not fabrics, limit the nets' accuracy away from their training poses: a fabric the
/// model never saw errs like a training fabric at the same pose, and the error falls with the
/// training poses as their count to the power −0.3 (the book's *Results*). A
/// [`SamplePlan::Strided`] dataset therefore drapes each pose past its first `full_poses` for
/// every `stride`-th fabric only, rotating with the pose, so the same solver time covers
/// `stride` times the poses, and every fabric still drapes every `stride`-th of them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum SamplePlan {
    /// Every material at every pose (every dataset made before plans were recorded).
    #[default]
    Full,
    /// Every material at the first `full_poses` poses; each later pose `p` for the materials
    /// `m` with `m % stride == p % stride` alone.
    Strided {
        /// The rotation's period: each later pose drapes about one fabric in `stride`.
        stride: usize,
        /// How many of the first poses every material drapes.
        full_poses: usize,
    },
}

impl SamplePlan {
    /// Whether the plan holds the sample of `material` at `pose` (a stride of 0, which
    /// [`DatasetSpec::validate`] refuses, holds every one).
    #[must_use]
    pub fn includes(&self, material: usize, pose: usize) -> bool {
        match *self {
            Self::Full => true,
            Self::Strided { stride, full_poses } => {
                pose < full_poses || stride == 0 || material % stride == pose % stride
            }
        }
    }

    /// The samples the plan holds out of `materials` × `poses`.
    #[must_use]
    pub fn sample_count(&self, materials: usize, poses: usize) -> usize {
        (0..materials)
            .map(|m| self.material_sample_count(m, poses))
            .sum()
    }

    /// The samples the plan holds of `material` among `poses` poses.
    #[must_use]
    pub fn material_sample_count(&self, material: usize, poses: usize) -> usize {
        (0..poses).filter(|&p| self.includes(material, p)).count()
    }

    /// Whether this is [`SamplePlan::Full`].
    #[must_use]
    pub fn is_full(&self) -> bool {
        *self == Self::Full
    }
}

impl std::fmt::Display for SamplePlan {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Self::Full => f.write_str("every material at every pose"),
            Self::Strided { stride, full_poses } => write!(
                f,
                "every material at the first {full_poses} poses, then pose p for the \
                 materials m with m % {stride} == p % {stride}"
            ),
        }
    }
}

/// Everything that defines a dataset before any sample exists: written once into the
/// manifest; a resumed or merged run must match it exactly.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DatasetSpec {
    /// The garment template.
    pub template: TemplateInfo,
    /// The body model.
    pub body: BodyInfo,
    /// The fabrics; samples refer to them by index.
    pub materials: Vec<MaterialEntry>,
    /// The poses (each a 72-vector); samples refer to them by index.
    pub poses: Vec<Pose>,
    /// For each pose, its frame index in the source sequence (for train/test splits).
    pub frames: Vec<usize>,
    /// The solver settings, as the solver serialises them.
    pub solver: serde_json::Value,
    /// The smoothing that produced the `smoothed` arrays.
    pub smoothing: SmoothingInfo,
    /// The [`GROUND_TRUTH_REVISION`] of the solver that draped the samples; `None` for
    /// datasets made before revisions were recorded (absent from their manifests, which
    /// read and write back unchanged).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ground_truth_revision: Option<u32>,
    /// How the samples were draped; absent (a walk) in manifests made before the canonical
    /// protocol, which read and write back unchanged.
    #[serde(default, skip_serializing_if = "is_walk")]
    pub protocol: DrapeProtocol,
    /// Which (material, pose) samples the dataset holds; absent (every one) in manifests of
    /// full datasets, which read and write back unchanged.
    #[serde(default, skip_serializing_if = "SamplePlan::is_full")]
    pub plan: SamplePlan,
}

fn is_walk(protocol: &DrapeProtocol) -> bool {
    *protocol == DrapeProtocol::Walk
}

/// The content of `DIR/manifest.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// Always [`DATASET_FORMAT_VERSION`].
    pub format_version: u32,
    /// What the dataset contains.
    #[serde(flatten)]
    pub spec: DatasetSpec,
    /// The finished samples, sorted by (material, pose).
    pub samples: Vec<SampleRecord>,
}

impl DatasetSpec {
    /// Checks that the spec is self-consistent.
    ///
    /// # Errors
    /// [`crate::Error::InvalidSpec`] for no materials or poses or a zero vertex count
    /// ([`SpecField::Materials`], [`SpecField::Poses`] or [`SpecField::Template`], whichever is
    /// empty first), an invalid pose ([`SpecField::Poses`] with its index), or a material
    /// ([`SpecField::Materials`] with its index) whose name appears twice, whose ω is not
    /// finite or outside the material bounds, or whose `omega_normalized` is not its ω's
    /// normalised coordinates; [`SpecField::Plan`] for a strided plan whose stride is 0 or more
    /// than the materials, or with the walk protocol; [`Error::Mismatch`] if `frames` and
    /// `poses` differ in length.
    pub fn validate(&self) -> crate::Result<()> {
        let invalid = |field, entry, problem| crate::Error::InvalidSpec {
            field,
            entry,
            problem,
        };
        let empty = [
            (self.materials.is_empty(), SpecField::Materials),
            (self.poses.is_empty(), SpecField::Poses),
            (self.template.vertex_count == 0, SpecField::Template),
        ]
        .into_iter()
        .find_map(|(empty, field)| empty.then_some(field));
        if let Some(field) = empty {
            return Err(invalid(
                field,
                None,
                format!(
                    "a dataset needs at least one material, one pose and one template vertex \
                     (got {} materials, {} poses, {} vertices)",
                    self.materials.len(),
                    self.poses.len(),
                    self.template.vertex_count
                ),
            ));
        }
        if self.frames.len() != self.poses.len() {
            return Err(Error::Mismatch {
                what: "dataset frame indices (one per pose)".into(),
                expected: self.poses.len().to_string(),
                got: self.frames.len().to_string(),
            }
            .into());
        }
        if let SamplePlan::Strided { stride, .. } = self.plan {
            let problem = if stride == 0 || stride > self.materials.len() {
                Some(format!(
                    "a plan with stride {stride} over {} materials leaves poses no material \
                     drapes: choose a stride from 1 to the number of materials",
                    self.materials.len()
                ))
            } else if self.protocol == DrapeProtocol::Walk {
                Some(
                    "a walk drapes every pose of its material in order, so its dataset holds \
                     every sample: a strided plan needs the canonical protocol"
                        .to_owned(),
                )
            } else {
                None
            };
            if let Some(problem) = problem {
                return Err(invalid(SpecField::Plan, None, problem));
            }
        }
        for (i, pose) in self.poses.iter().enumerate() {
            pose.validate().map_err(|e| {
                invalid(SpecField::Poses, Some(i), format!("dataset pose {i}: {e}"))
            })?;
        }
        for (i, m) in self.materials.iter().enumerate() {
            let bad_material = |problem| invalid(SpecField::Materials, Some(i), problem);
            if self.materials[..i].iter().any(|o| o.name == m.name) {
                return Err(bad_material(format!(
                    "material name `{}` appears twice; names must be unique",
                    m.name
                )));
            }
            if m.omega
                .iter()
                .chain(&m.omega_normalized)
                .any(|v| !v.is_finite())
            {
                return Err(bad_material(format!(
                    "material `{}` has a non-finite parameter",
                    m.name
                )));
            }
            // The nets train on `omega_normalized` and a predictor normalises `omega`: the
            // two must be one fabric, inside the bounds a model can be asked about.
            let material = garmatnet_core::Material::from_array(m.omega)
                .map_err(|e| bad_material(format!("material `{}`: {e}", m.name)))?;
            let expected = material.to_normalized();
            if let Some(k) =
                (0..expected.len()).find(|&k| (expected[k] - m.omega_normalized[k]).abs() > 1e-9)
            {
                return Err(bad_material(format!(
                    "material `{}`: omega_normalized[{k}] = {} is not its omega's normalised \
                     coordinate {} (n = (ln v - ln lo) / (ln hi - ln lo)): the manifest was edited or \
                     written by other code; restore it, or write both from one Material",
                    m.name, m.omega_normalized[k], expected[k]
                )));
            }
        }
        Ok(())
    }
}

impl Manifest {
    /// Reads and validates `DIR/manifest.json`.
    ///
    /// # Errors
    /// [`Error::Io`] if it cannot be read; [`Error::Parse`] for malformed JSON, an unknown
    /// format version or an inconsistent spec.
    pub fn read(dir: &Path) -> Result<Self> {
        let path = manifest_path(dir);
        let bytes = std::fs::read(&path).map_err(|e| Error::io(&path, e))?;
        let parse = |line, message| Error::Parse {
            path: path.clone(),
            line,
            message,
        };
        let version: serde_json::Value = serde_json::from_slice(&bytes)
            .map_err(|e| parse(Some(e.line()), format!("not valid JSON: {e}")))?;
        let found = version
            .get("format_version")
            .and_then(serde_json::Value::as_u64);
        if found != Some(u64::from(DATASET_FORMAT_VERSION)) {
            return Err(parse(
                None,
                format!(
                    "format_version is {found:?}; this garmatnet reads version \
                     {DATASET_FORMAT_VERSION}: regenerate the dataset"
                ),
            ));
        }
        let manifest: Manifest = serde_json::from_value(version)
            .map_err(|e| parse(None, format!("not a garmatnet dataset manifest: {e}")))?;
        manifest
            .spec
            .validate()
            .map_err(|e| parse(None, e.to_string()))?;
        Ok(manifest)
    }

    /// Writes `DIR/manifest.json` atomically.
    ///
    /// # Errors
    /// [`Error::Io`] if the directory is not writable.
    pub fn write(&self, dir: &Path) -> Result<()> {
        let path = manifest_path(dir);
        let bytes = serde_json::to_vec_pretty(self).map_err(|e| Error::io(&path, e.into()))?;
        garmatnet_core::write_bytes_atomic(&path, &bytes)
    }
}

/// A ground-truth revision for messages: the number, or what an unrecorded one means.
#[must_use]
pub fn revision_label(revision: Option<u32>) -> String {
    match revision {
        Some(r) => r.to_string(),
        None => "unrecorded (made before datasets recorded it: revision 1, or 2 if made \
                 after 2026-11-24, when adding \"ground_truth_revision\": 2 to its \
                 manifest.json lets this version resume it)"
            .to_owned(),
    }
}

/// `DIR/manifest.json`.
#[must_use]
pub fn manifest_path(dir: &Path) -> PathBuf {
    dir.join("manifest.json")
}

/// The poses at `path`: a dataset directory's (its manifest's, in order), else a pose
/// file's ([`garmatnet_core::read_poses`]: .json, .npz or .npy).
///
/// # Errors
/// As [`Manifest::read`] for a dataset directory, as [`garmatnet_core::read_poses`] otherwise.
pub fn read_poses_or_dataset(path: &Path) -> Result<Vec<Pose>> {
    if manifest_path(path).exists() {
        Ok(Manifest::read(path)?.spec.poses)
    } else {
        garmatnet_core::read_poses(path)
    }
}

/// The directory name of sample (`material`, `pose`): `m{material:03}_p{pose:04}`, e.g.
/// `m003_p0123` (more digits when the indices need them).
#[must_use]
pub fn sample_stem(material: usize, pose: usize) -> String {
    format!("m{material:03}_p{pose:04}")
}

/// The inverse of [`sample_stem`]: `Some((material, pose))` for a well-formed stem.
#[must_use]
pub fn parse_sample_stem(stem: &str) -> Option<(usize, usize)> {
    let (m, p) = stem.strip_prefix('m')?.split_once("_p")?;
    let all_digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    if !all_digits(m) || !all_digits(p) {
        return None;
    }
    let parsed = (m.parse().ok()?, p.parse().ok()?);
    // Only the canonical spelling, so one sample never has two directories.
    (sample_stem(parsed.0, parsed.1) == stem).then_some(parsed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stems_round_trip_and_reject_variants() {
        assert_eq!(sample_stem(3, 123), "m003_p0123");
        assert_eq!(parse_sample_stem("m003_p0123"), Some((3, 123)));
        assert_eq!(
            parse_sample_stem(&sample_stem(1234, 56789)),
            Some((1234, 56789))
        );
        for bad in [
            "m3_p123",
            "m003_p0123.tmp",
            "x003_p0123",
            "m003p0123",
            "m_p",
            "m-01_p0001",
        ] {
            assert_eq!(parse_sample_stem(bad), None, "{bad}");
        }
    }

    #[test]
    fn a_strided_plan_rotates_the_fabrics_after_its_full_poses() {
        let plan = SamplePlan::Strided {
            stride: 3,
            full_poses: 2,
        };
        let held = |p: usize| (0..7).filter(|&m| plan.includes(m, p)).collect::<Vec<_>>();
        assert_eq!(held(0), (0..7).collect::<Vec<_>>());
        assert_eq!(held(1), (0..7).collect::<Vec<_>>());
        assert_eq!(held(2), [2, 5]);
        assert_eq!(held(3), [0, 3, 6]);
        assert_eq!(held(4), [1, 4]);
        // 2 full poses of 7, then 2 + 3 + 2 + 2 + 3 + 2 over poses 2..8.
        assert_eq!(plan.sample_count(7, 8), 14 + 14);
        assert_eq!(SamplePlan::Full.sample_count(7, 8), 56);
        assert!((0..8).all(|p| SamplePlan::Full.includes(6, p)));
    }

    #[test]
    fn a_full_plan_is_not_written_and_a_strided_one_round_trips() {
        let full = serde_json::to_value(Manifest {
            format_version: DATASET_FORMAT_VERSION,
            spec: crate::dataset::writer::tests::tiny_spec(),
            samples: Vec::new(),
        })
        .unwrap();
        // Manifests of full datasets read and write back as they were made.
        assert!(full.get("plan").is_none(), "{full}");
        let mut spec = crate::dataset::writer::tests::tiny_spec();
        spec.protocol = DrapeProtocol::Canonical;
        spec.plan = SamplePlan::Strided {
            stride: 2,
            full_poses: 1,
        };
        let json = serde_json::to_value(&spec).unwrap();
        assert_eq!(
            json["plan"],
            serde_json::json!({ "kind": "strided", "stride": 2, "full_poses": 1 })
        );
        let back: DatasetSpec = serde_json::from_value(json).unwrap();
        assert_eq!(back, spec);
        spec.validate().unwrap();
        for stride in [0, spec.materials.len() + 1] {
            spec.plan = SamplePlan::Strided {
                stride,
                full_poses: 0,
            };
            let err = spec.validate().unwrap_err();
            assert!(
                matches!(
                    err,
                    crate::Error::InvalidSpec {
                        field: SpecField::Plan,
                        ..
                    }
                ),
                "{err}"
            );
        }
    }
}
