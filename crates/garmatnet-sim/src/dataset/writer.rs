//! Writing a draping dataset to disk, resumably and safely from many threads.
//!
//! # On-disk layout (format version 1)
//!
//! ```text
//! DIR/
//!   manifest.json           the dataset (see below), rewritten atomically
//!   .lock                   held (OS file lock) by the one process writing DIR
//!   samples/
//!     m003_p0123/           sample of material 3 and pose 123 (sample_stem)
//!       simulated.npy       float32 [vertex_count, 3], solver output (metres)
//!       smoothed.npy        float32 [vertex_count, 3], Laplacian-smoothed simulated
//!       body.npy            float32 [m, 3], posed body points (metres)
//!       stats.json          completion marker, written last: a SampleRecord
//! ```
//!
//! `manifest.json` holds `format_version` (1), `template` (`resolution`, `vertex_count`,
//! `hash`), `body` (`name`), `materials` (`name`, physical `omega` as structural vertical,
//! structural horizontal, flexion vertical, flexion horizontal, shear (N/m) and density
//! (kg/m²), and `omega_normalized`), `poses` (72-vectors), `frames` (each pose's index in its
//! source sequence), `solver` (the solver's settings, free-form JSON), `smoothing`
//! (`lambda`, `iterations`, `weights`) and `samples`: one record per finished sample with
//! `material` and `pose` indices, `stem` and `stats` (`iterations`, `residual`,
//! `max_penetration_m`, `max_strain`, `wall_time_ms`, `converged`). Materials and poses are
//! stored by value and referenced by index.
//!
//! # Crash safety, resumption, shards
//!
//! Every file is written to a temporary and renamed, so no file is ever half-written. A
//! sample's arrays are written before its `stats.json`, and a sample counts as done exactly
//! when that marker exists: the markers, not `manifest.json`'s `samples` list, are the truth.
//! Opening a directory rebuilds the list from the markers, so a run killed at any point loses
//! at most the samples in flight, and shard outputs are merged by copying their `samples/*`
//! directories into one directory and opening it ([`crate::merge_shards`] does exactly that). A
//! shard `i/k` ([`crate::Shard`]) takes the materials whose index `% k == i`, so each shard walks
//! whole pose sequences and can warm-start each pose from the previous one.

use std::collections::BTreeMap;

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use garmatnet_core::error::ensure_finite;
use garmatnet_core::{Error, OutputLock, Result};

use crate::dataset::manifest::{
    DATASET_FORMAT_VERSION, DatasetSpec, Manifest, SamplePlan, SampleRecord, SampleStats,
    manifest_path, parse_sample_stem, revision_label, sample_stem,
};
use crate::dataset::sample_arrays::{SampleArrays, write_points_npy};
use crate::error::SpecField;
use crate::solver::canonical::DrapeProtocol;
use crate::solver::garment_drape::SequenceSettings;

/// How often at most [`DatasetWriter::write_sample`] rewrites `manifest.json` (the markers
/// are the truth, so a stale list costs nothing but is rebuilt on the next open).
const MANIFEST_INTERVAL: Duration = Duration::from_secs(2);

/// `DIR/samples`.
#[must_use]
pub fn samples_dir(dir: &Path) -> PathBuf {
    dir.join("samples")
}

/// `DIR/samples/{stem}/stats.json`, the completion marker.
fn marker_path(dir: &Path, stem: &str) -> PathBuf {
    samples_dir(dir).join(stem).join("stats.json")
}

/// The finished samples of `dir`, from their markers, sorted by (material, pose). Sample
/// directories without a marker (in flight when a run died) are ignored.
///
/// # Errors
/// [`Error::Io`] if `samples/` cannot be listed; [`Error::Parse`] naming the marker for a
/// malformed marker, one whose indices disagree with its directory name, or indices outside
/// `spec`.
pub fn scan_samples(dir: &Path, spec: &DatasetSpec) -> Result<Vec<SampleRecord>> {
    let root = samples_dir(dir);
    let entries = match std::fs::read_dir(&root) {
        Ok(entries) => entries,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(Error::io(&root, e)),
    };
    let mut records = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| Error::io(&root, e))?;
        let name = entry.file_name();
        let Some((material, pose)) = name.to_str().and_then(parse_sample_stem) else {
            continue;
        };
        let stem = sample_stem(material, pose);
        let marker = marker_path(dir, &stem);
        let bytes = match std::fs::read(&marker) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
            Err(e) => return Err(Error::io(&marker, e)),
        };
        let parse = |message: String| Error::Parse {
            path: marker.clone(),
            line: None,
            message,
        };
        let record: SampleRecord = serde_json::from_slice(&bytes)
            .map_err(|e| parse(format!("sample {stem}: malformed completion marker: {e}")))?;
        if (record.material, record.pose) != (material, pose) || record.stem != stem {
            return Err(parse(format!(
                "sample {stem}: marker says material {} pose {} (stem `{}`)",
                record.material, record.pose, record.stem
            )));
        }
        if material >= spec.materials.len() || pose >= spec.poses.len() {
            return Err(parse(format!(
                "sample {stem}: indices outside the dataset's {} materials x {} poses",
                spec.materials.len(),
                spec.poses.len()
            )));
        }
        records.push(record);
    }
    records.sort_by_key(|r| (r.material, r.pose));
    Ok(records)
}

/// Writes samples into a dataset directory; share it between threads by reference.
///
/// Holds `DIR/.lock` for its lifetime so that a second process cannot write the same
/// directory. The manifest is rewritten at most every two seconds while writing and on
/// [`DatasetWriter::flush`] and drop.
#[derive(Debug)]
pub struct DatasetWriter {
    dir: PathBuf,
    spec: DatasetSpec,
    state: Mutex<WriterState>,
    _lock: OutputLock,
}

#[derive(Debug)]
struct WriterState {
    done: BTreeMap<(usize, usize), SampleRecord>,
    last_manifest: Instant,
    dirty: bool,
}

impl DatasetWriter {
    /// Creates `dir` (if needed) for `spec`, or opens it to resume: an existing dataset must
    /// have exactly this spec; its finished samples are recovered from their markers.
    ///
    /// # Errors
    /// [`crate::Error::InvalidSpec`] for an inconsistent spec; [`Error::Io`] if the directory is
    /// not writable, or with kind `WouldBlock` if another process (or writer) holds its lock;
    /// [`crate::Error::SpecMismatch`] if the existing manifest has a different revision,
    /// protocol, template, body, materials, poses, frames, solver or smoothing settings or
    /// sample plan;
    /// [`Error::Parse`] for a malformed existing manifest or marker.
    pub fn open(dir: impl AsRef<Path>, spec: DatasetSpec) -> crate::Result<Self> {
        let dir = dir.as_ref().to_owned();
        spec.validate()?;
        std::fs::create_dir_all(samples_dir(&dir)).map_err(|e| Error::io(&dir, e))?;
        let lock = OutputLock::acquire(dir.join(".lock"), &format!("dataset {}", dir.display()))?;
        // Compare through JSON so that floats parsed back from the manifest compare exactly.
        let spec_json = serde_json::to_value(&spec).map_err(|e| Error::io(&dir, e.into()))?;
        let mut spec: DatasetSpec =
            serde_json::from_value(spec_json).map_err(|e| Error::io(&dir, e.into()))?;
        if manifest_path(&dir).exists() {
            let existing = Manifest::read(&dir)?;
            ensure_same_spec(&existing.spec, &spec)?;
            // The same settings may be spelt differently (a field added since, at the value
            // it reads as): the manifest keeps its own spelling.
            spec.solver = existing.spec.solver;
        }
        let records = scan_samples(&dir, &spec)?;
        let writer = Self {
            dir,
            spec,
            state: Mutex::new(WriterState {
                done: records
                    .into_iter()
                    .map(|r| ((r.material, r.pose), r))
                    .collect(),
                last_manifest: Instant::now(),
                dirty: true,
            }),
            _lock: lock,
        };
        writer.flush()?;
        Ok(writer)
    }

    /// The dataset directory.
    #[must_use]
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The dataset's spec.
    #[must_use]
    pub fn spec(&self) -> &DatasetSpec {
        &self.spec
    }

    /// Whether sample (`material`, `pose`) is finished (its marker was written).
    #[must_use]
    pub fn is_done(&self, material: usize, pose: usize) -> bool {
        self.lock_state().done.contains_key(&(material, pose))
    }

    /// Number of finished samples.
    #[must_use]
    pub fn done_count(&self) -> usize {
        self.lock_state().done.len()
    }

    /// Writes sample (`material`, `pose`): its three arrays, then its completion marker, then
    /// (at most every two seconds) the manifest. Rewriting a finished sample replaces it.
    ///
    /// # Shapes
    /// `arrays.simulated`, `arrays.smoothed`: `[vertex_count, 3]`; `arrays.body`: `[m, 3]`.
    ///
    /// # Errors
    /// [`crate::Error::SampleOutOfRange`] for indices outside the dataset,
    /// [`crate::Error::SampleOutsidePlan`] for a sample its plan does not hold;
    /// [`Error::NonFinite`] (naming the sample and the stat) for non-finite stats;
    /// [`Error::Mismatch`] / [`Error::NonFinite`] (naming the sample) for bad arrays;
    /// [`Error::Io`] if a file cannot be written.
    pub fn write_sample(
        &self,
        material: usize,
        pose: usize,
        arrays: &SampleArrays,
        stats: SampleStats,
    ) -> crate::Result<()> {
        if material >= self.spec.materials.len() || pose >= self.spec.poses.len() {
            return Err(crate::Error::SampleOutOfRange {
                material,
                pose,
                materials: self.spec.materials.len(),
                poses: self.spec.poses.len(),
            });
        }
        if let SamplePlan::Strided { stride, full_poses } = self.spec.plan
            && !self.spec.plan.includes(material, pose)
        {
            return Err(crate::Error::SampleOutsidePlan {
                material,
                pose,
                stride,
                full_poses,
            });
        }
        let stem = sample_stem(material, pose);
        let numbers = [
            stats.residual,
            stats.max_penetration_m,
            stats.max_depth_before_projection_m.unwrap_or(0.0),
            stats.max_strain,
            stats.wall_time_ms,
        ];
        ensure_finite(
            &format!(
                "solver stats of sample {stem} (residual, max_penetration_m, \
                 max_depth_before_projection_m, max_strain, wall_time_ms)"
            ),
            numbers,
        )?;
        arrays.validate(&stem, self.spec.template.vertex_count)?;
        let sample_dir = samples_dir(&self.dir).join(&stem);
        std::fs::create_dir_all(&sample_dir).map_err(|e| Error::io(&sample_dir, e))?;
        // A rewrite must not leave the old marker vouching for half-replaced arrays.
        let marker = marker_path(&self.dir, &stem);
        match std::fs::remove_file(&marker) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                return Err(Error::io(&marker, e).into());
            }
            _ => {}
        }
        for (name, points) in arrays.by_name() {
            write_points_npy(&sample_dir.join(format!("{name}.npy")), points)?;
        }
        let record = SampleRecord {
            material,
            pose,
            stem,
            stats,
        };
        let bytes = serde_json::to_vec_pretty(&record).map_err(|e| Error::io(&marker, e.into()))?;
        garmatnet_core::write_bytes_atomic(&marker, &bytes)?;

        let mut state = self.lock_state();
        state.done.insert((material, pose), record);
        state.dirty = true;
        if state.last_manifest.elapsed() >= MANIFEST_INTERVAL {
            self.write_manifest(&mut state)?;
        }
        Ok(())
    }

    /// Rewrites the manifest now if samples were recorded since the last rewrite.
    ///
    /// # Errors
    /// [`Error::Io`] if it cannot be written.
    pub fn flush(&self) -> Result<()> {
        let mut state = self.lock_state();
        if state.dirty {
            self.write_manifest(&mut state)
        } else {
            Ok(())
        }
    }

    fn write_manifest(&self, state: &mut WriterState) -> Result<()> {
        let manifest = Manifest {
            format_version: DATASET_FORMAT_VERSION,
            spec: self.spec.clone(),
            samples: state.done.values().cloned().collect(),
        };
        manifest.write(&self.dir)?;
        state.last_manifest = Instant::now();
        state.dirty = false;
        Ok(())
    }

    /// Drops the writer as a killed process would: lock released, manifest not rewritten.
    #[cfg(test)]
    fn simulate_kill(self) {
        self.lock_state().dirty = false;
    }

    fn lock_state(&self) -> std::sync::MutexGuard<'_, WriterState> {
        // A panic in another writer thread cannot leave the map inconsistent (each insert
        // is one call), so a poisoned lock is still usable.
        self.state
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

impl Drop for DatasetWriter {
    fn drop(&mut self) {
        // Best effort: the markers already hold everything, the next open heals the list.
        let _ = self.flush();
    }
}

pub(crate) fn ensure_same_spec(existing: &DatasetSpec, new: &DatasetSpec) -> crate::Result<()> {
    compare_specs(existing, new, SpecScope::Whole, &|what| {
        format!("existing dataset's {what} (use a new directory or the same settings)")
    })
}

/// What [`compare_specs`] compares beyond the revision, protocol, template, body, solver and
/// smoothing, which make a sample what it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum SpecScope {
    /// Everything: the same dataset (resumed or merged).
    Whole,
    /// A dataset whose samples another one reuses: the materials and the plan may differ, and
    /// so may the poses under the canonical protocol, where a sample depends on its own pose
    /// alone (they are matched by value); a walk's poses must be the same.
    Reuse,
}

/// Compares two specs field by field (how far: `scope`), naming the first difference through
/// `describe(field)`.
pub(crate) fn compare_specs(
    existing: &DatasetSpec,
    new: &DatasetSpec,
    scope: SpecScope,
    describe: &dyn Fn(&str) -> String,
) -> crate::Result<()> {
    let whole = scope == SpecScope::Whole;
    let differs =
        |field: SpecField, what: &str, expected: String, got: String| crate::Error::SpecMismatch {
            field,
            what: describe(what),
            expected,
            got,
        };
    if existing.ground_truth_revision != new.ground_truth_revision {
        // Compared first: with another solver every other field may match and the drapes
        // still differ.
        return Err(differs(
            SpecField::GroundTruthRevision,
            "ground-truth revision (which solver's drapes; a dataset holds one revision's)",
            revision_label(existing.ground_truth_revision),
            revision_label(new.ground_truth_revision),
        ));
    }
    if existing.protocol != new.protocol {
        return Err(differs(
            SpecField::Protocol,
            "drape protocol (a dataset holds one protocol's drapes)",
            existing.protocol.name().to_owned(),
            new.protocol.name().to_owned(),
        ));
    }
    if existing.template != new.template {
        return Err(differs(
            SpecField::Template,
            "template",
            format!("{:?}", existing.template),
            format!("{:?}", new.template),
        ));
    }
    if existing.body != new.body {
        return Err(differs(
            SpecField::Body,
            "body",
            existing.body.name.clone(),
            new.body.name.clone(),
        ));
    }
    let names = |s: &DatasetSpec| {
        s.materials
            .iter()
            .map(|m| m.name.clone())
            .collect::<Vec<_>>()
            .join(", ")
    };
    if whole && existing.materials != new.materials {
        return Err(differs(
            SpecField::Materials,
            "materials",
            names(existing),
            names(new),
        ));
    }
    let poses = whole || existing.protocol == DrapeProtocol::Walk;
    if poses && (existing.poses != new.poses || existing.frames != new.frames) {
        let first = (0..existing.poses.len().max(new.poses.len()))
            .find(|&i| {
                existing.poses.get(i) != new.poses.get(i)
                    || existing.frames.get(i) != new.frames.get(i)
            })
            .unwrap_or(0);
        return Err(differs(
            SpecField::Poses,
            "poses",
            format!("{} poses", existing.poses.len()),
            format!(
                "{} poses, first difference at pose {first}",
                new.poses.len()
            ),
        ));
    }
    if !same_solver(&existing.solver, &new.solver) {
        return Err(differs(
            SpecField::Solver,
            "solver settings",
            existing.solver.to_string(),
            new.solver.to_string(),
        ));
    }
    if existing.smoothing != new.smoothing {
        return Err(differs(
            SpecField::Smoothing,
            "smoothing",
            format!("{:?}", existing.smoothing),
            format!("{:?}", new.smoothing),
        ));
    }
    if whole && existing.plan != new.plan {
        return Err(differs(
            SpecField::Plan,
            "sample plan",
            existing.plan.to_string(),
            new.plan.to_string(),
        ));
    }
    Ok(())
}

/// Whether two manifests' solver settings describe the same walk: equal as written, or equal
/// as [`SequenceSettings::from_manifest`] reads them (a manifest written before a setting
/// existed lacks it, and reads it as the walk was made) with neither spelling out a value
/// those settings do not hold as written (an unknown key, say).
fn same_solver(a: &serde_json::Value, b: &serde_json::Value) -> bool {
    if a == b {
        return true;
    }
    let canonical = |v: &serde_json::Value| {
        SequenceSettings::from_manifest(v)
            .ok()
            .and_then(|s| serde_json::to_value(s).ok())
    };
    match (canonical(a), canonical(b)) {
        (Some(ca), Some(cb)) => ca == cb && written_in(a, &ca) && written_in(b, &cb),
        _ => false,
    }
}

/// Whether every value `raw` spells out is in `canonical` as written.
fn written_in(raw: &serde_json::Value, canonical: &serde_json::Value) -> bool {
    match (raw, canonical) {
        (serde_json::Value::Object(r), serde_json::Value::Object(c)) => r
            .iter()
            .all(|(key, value)| c.get(key).is_some_and(|v| written_in(value, v))),
        _ => raw == canonical,
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::dataset::manifest::{BodyInfo, MaterialEntry, SmoothingInfo};
    use garmatnet_core::{JointLimits, Resolution, SplitMix64, TemplateInfo};

    pub(crate) const VERTICES: usize = 10;

    /// 3 materials x 4 poses x 10 vertices.
    pub(crate) fn tiny_spec() -> DatasetSpec {
        let limits = JointLimits::default();
        let mut rng = SplitMix64::new(9);
        DatasetSpec {
            template: TemplateInfo {
                resolution: Resolution::Coarse,
                vertex_count: VERTICES,
                hash: "abc123".into(),
            },
            body: BodyInfo {
                name: "capsule-smpl-neutral".into(),
            },
            materials: (0..3)
                .map(|i| {
                    let omega_normalized = [0.1 * i as f64, 0.2, 0.3, 0.4, 0.5, 0.6];
                    MaterialEntry {
                        name: format!("fabric{i}"),
                        omega: garmatnet_core::Material::from_normalized(omega_normalized)
                            .unwrap()
                            .as_array(),
                        omega_normalized,
                    }
                })
                .collect(),
            poses: (0..4).map(|_| limits.sample(&mut rng, 0.8)).collect(),
            frames: vec![0, 10, 20, 30],
            solver: serde_json::json!({ "tolerance": 1e-6, "max_iterations": 200 }),
            smoothing: SmoothingInfo {
                lambda: 0.5,
                iterations: 20,
                weights: "uniform".into(),
            },
            ground_truth_revision: Some(crate::GROUND_TRUTH_REVISION),
            protocol: Default::default(),
            plan: Default::default(),
        }
    }

    pub(crate) fn arrays(material: usize, pose: usize) -> SampleArrays {
        let v = |k: usize| {
            (0..VERTICES)
                .map(|i| [material as f32, pose as f32, (i + k) as f32 * 0.01])
                .collect()
        };
        SampleArrays {
            simulated: v(0),
            smoothed: v(1),
            body: v(2)[..4].to_vec(),
        }
    }

    pub(crate) fn stats(residual: f64) -> SampleStats {
        SampleStats {
            iterations: 12,
            residual,
            max_penetration_m: 1e-3,
            max_depth_before_projection_m: Some(2e-3),
            max_strain: 0.05,
            wall_time_ms: 3.0,
            converged: true,
        }
    }

    #[test]
    fn a_spec_whose_fabric_is_out_of_bounds_or_inconsistent_is_refused() {
        assert!(tiny_spec().validate().is_ok());
        let mut inconsistent = tiny_spec();
        inconsistent.materials[1].omega_normalized = [5.0, -3.0, 0.3, 0.4, 0.5, 0.6];
        let err = inconsistent.validate().unwrap_err();
        let bad_material = |err: &crate::Error, index: usize| {
            matches!(
                err,
                crate::Error::InvalidSpec {
                    field: SpecField::Materials,
                    entry: Some(i),
                    ..
                } if *i == index
            )
        };
        assert!(bad_material(&err, 1), "{err}");
        let err = err.to_string();
        assert!(
            err.contains("fabric1") && err.contains("omega_normalized[0]"),
            "{err}"
        );
        let mut out_of_bounds = tiny_spec();
        out_of_bounds.materials[2].omega[5] = 1e6;
        let err = out_of_bounds.validate().unwrap_err();
        assert!(bad_material(&err, 2), "{err}");
        assert!(err.to_string().contains("fabric2"), "{err}");
        let mut twice = tiny_spec();
        twice.materials[2].name = twice.materials[0].name.clone();
        let err = twice.validate().unwrap_err();
        assert!(bad_material(&err, 2), "{err}");
        assert!(err.to_string().contains("appears twice"), "{err}");
        let mut no_poses = tiny_spec();
        no_poses.poses.clear();
        no_poses.frames.clear();
        let err = no_poses.validate().unwrap_err();
        assert!(
            matches!(
                err,
                crate::Error::InvalidSpec {
                    field: SpecField::Poses,
                    entry: None,
                    ..
                }
            ),
            "{err}"
        );
    }

    #[test]
    fn a_dataset_of_another_ground_truth_revision_is_not_resumed() {
        let dir = tempfile::tempdir().unwrap();
        let w = DatasetWriter::open(dir.path(), tiny_spec()).unwrap();
        w.write_sample(0, 0, &arrays(0, 0), stats(1e-6)).unwrap();
        drop(w);
        let mut newer = tiny_spec();
        newer.ground_truth_revision = Some(crate::GROUND_TRUTH_REVISION + 1);
        let err = DatasetWriter::open(dir.path(), newer)
            .err()
            .unwrap()
            .to_string();
        assert!(
            err.contains("ground-truth revision") && err.contains("new directory"),
            "{err}"
        );
        // Refused without touching it: the same revision still resumes with its sample.
        let w = DatasetWriter::open(dir.path(), tiny_spec()).unwrap();
        assert_eq!(w.done_count(), 1);
    }

    #[test]
    fn manifests_made_before_revisions_were_recorded_read_and_write_back_unchanged() {
        let dir = tempfile::tempdir().unwrap();
        let mut older = tiny_spec();
        older.ground_truth_revision = None;
        let w = DatasetWriter::open(dir.path(), older.clone()).unwrap();
        w.write_sample(1, 2, &arrays(1, 2), stats(1e-6)).unwrap();
        drop(w);
        let raw = std::fs::read_to_string(manifest_path(dir.path())).unwrap();
        assert!(!raw.contains("ground_truth_revision"), "{raw}");
        assert_eq!(Manifest::read(dir.path()).unwrap().spec, older);
        // This build drapes another revision than such a dataset may hold: not resumed.
        let err = DatasetWriter::open(dir.path(), tiny_spec())
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("unrecorded"), "{err}");
    }

    #[test]
    fn writes_manifest_and_samples_then_resumes_after_a_kill() {
        let dir = tempfile::tempdir().unwrap();
        let spec = tiny_spec();
        {
            let w = DatasetWriter::open(dir.path(), spec.clone()).unwrap();
            w.write_sample(0, 1, &arrays(0, 1), stats(1e-7)).unwrap();
            w.write_sample(2, 3, &arrays(2, 3), stats(2e-7)).unwrap();
            // A sample in flight when the run dies: arrays written, no marker yet.
            let inflight = samples_dir(dir.path()).join(sample_stem(1, 0));
            std::fs::create_dir_all(&inflight).unwrap();
            write_points_npy(&inflight.join("simulated.npy"), &arrays(1, 0).simulated).unwrap();
            w.simulate_kill();
        }
        // The manifest on disk predates the samples; reopening heals it from the markers.
        assert!(Manifest::read(dir.path()).unwrap().samples.is_empty());
        let w = DatasetWriter::open(dir.path(), spec.clone()).unwrap();
        assert!(w.is_done(0, 1) && w.is_done(2, 3));
        assert!(!w.is_done(1, 0), "a sample without marker must be redone");
        assert_eq!(w.done_count(), 2);
        let manifest = Manifest::read(dir.path()).unwrap();
        assert_eq!(manifest.format_version, DATASET_FORMAT_VERSION);
        assert_eq!(manifest.spec, spec);
        let listed: Vec<_> = manifest
            .samples
            .iter()
            .map(|r| (r.material, r.pose))
            .collect();
        assert_eq!(listed, vec![(0, 1), (2, 3)]);
        assert_eq!(manifest.samples[1].stats, stats(2e-7));
    }

    #[test]
    fn second_writer_is_refused_by_the_lock() {
        let dir = tempfile::tempdir().unwrap();
        let first = DatasetWriter::open(dir.path(), tiny_spec()).unwrap();
        let err = DatasetWriter::open(dir.path(), tiny_spec()).unwrap_err();
        assert!(
            matches!(&err, crate::Error::Core(Error::Io { source, .. }) if source.kind() == std::io::ErrorKind::WouldBlock),
            "{err}"
        );
        drop(first);
        DatasetWriter::open(dir.path(), tiny_spec()).unwrap();
    }

    #[test]
    fn resuming_with_a_different_spec_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        drop(DatasetWriter::open(dir.path(), tiny_spec()).unwrap());
        let mut other = tiny_spec();
        other.template.hash = "def456".into();
        assert!(matches!(
            DatasetWriter::open(dir.path(), other),
            Err(crate::Error::SpecMismatch {
                field: SpecField::Template,
                ..
            })
        ));
        let mut other = tiny_spec();
        other.materials[1].omega[4] += 1e-9;
        assert!(matches!(
            DatasetWriter::open(dir.path(), other),
            Err(crate::Error::SpecMismatch {
                field: SpecField::Materials,
                ..
            })
        ));
        // Settings the solver does not know are compared as written.
        let mut other = tiny_spec();
        other.solver["tolerance"] = serde_json::json!(1e-7);
        assert!(matches!(
            DatasetWriter::open(dir.path(), other),
            Err(crate::Error::SpecMismatch {
                field: SpecField::Solver,
                ..
            })
        ));
        let mut other = tiny_spec();
        other.poses.pop();
        other.frames.pop();
        let err = DatasetWriter::open(dir.path(), other).unwrap_err();
        assert!(
            matches!(
                err,
                crate::Error::SpecMismatch {
                    field: SpecField::Poses,
                    ..
                }
            ) && err.to_string().contains("pose 3"),
            "{err}"
        );
    }

    #[test]
    fn a_dataset_made_before_a_setting_existed_resumes_with_the_same_walk() {
        use crate::FactorPrecision;
        // Written before the factor's precision was a setting: no `drape.factor_precision`,
        // which reads as double, today's default.
        let mut before = tiny_spec();
        before.solver = serde_json::to_value(SequenceSettings::default()).unwrap();
        before.solver["drape"]
            .as_object_mut()
            .unwrap()
            .remove("factor_precision");
        let dir = tempfile::tempdir().unwrap();
        drop(DatasetWriter::open(dir.path(), before.clone()).unwrap());
        // Today's defaults spell it out, and resume; the manifest keeps its own spelling.
        let mut today = tiny_spec();
        today.solver = serde_json::to_value(SequenceSettings::default()).unwrap();
        assert_ne!(today.solver, before.solver);
        let writer = DatasetWriter::open(dir.path(), today.clone()).unwrap();
        writer
            .write_sample(0, 0, &arrays(0, 0), stats(0.0))
            .unwrap();
        writer.flush().unwrap();
        drop(writer);
        assert_eq!(
            Manifest::read(dir.path()).unwrap().spec.solver,
            before.solver
        );
        // Mixed precision is a different walk: refused.
        let mut settings = SequenceSettings::default();
        settings.drape.factor_precision = FactorPrecision::Mixed;
        today.solver = serde_json::to_value(&settings).unwrap();
        assert!(matches!(
            DatasetWriter::open(dir.path(), today),
            Err(crate::Error::SpecMismatch {
                field: SpecField::Solver,
                ..
            })
        ));
    }

    #[test]
    fn bad_samples_are_refused_before_anything_is_written() {
        let dir = tempfile::tempdir().unwrap();
        let w = DatasetWriter::open(dir.path(), tiny_spec()).unwrap();
        assert!(matches!(
            w.write_sample(3, 0, &arrays(0, 0), stats(0.0)),
            Err(crate::Error::SampleOutOfRange {
                material: 3,
                pose: 0,
                materials: 3,
                poses: 4
            })
        ));
        let mut short = arrays(0, 0);
        short.simulated.pop();
        assert!(matches!(
            w.write_sample(0, 0, &short, stats(0.0)),
            Err(crate::Error::Core(Error::Mismatch { .. }))
        ));
        let mut nan = arrays(0, 0);
        nan.body[0][1] = f32::NAN;
        assert!(matches!(
            w.write_sample(0, 0, &nan, stats(0.0)),
            Err(crate::Error::Core(Error::NonFinite { .. }))
        ));
        let err = w
            .write_sample(0, 0, &arrays(0, 0), stats(f64::NAN))
            .unwrap_err();
        assert!(
            matches!(&err, crate::Error::Core(Error::NonFinite { what, index: 0 })
                if what.contains("m000_p0000")),
            "{err}"
        );
        assert_eq!(w.done_count(), 0);
        assert_eq!(
            std::fs::read_dir(samples_dir(dir.path())).unwrap().count(),
            0
        );
    }

    #[test]
    fn concurrent_writers_from_threads_record_every_sample() {
        let dir = tempfile::tempdir().unwrap();
        let w = DatasetWriter::open(dir.path(), tiny_spec()).unwrap();
        std::thread::scope(|s| {
            for m in 0..3 {
                let w = &w;
                s.spawn(move || {
                    for p in 0..4 {
                        w.write_sample(m, p, &arrays(m, p), stats(1e-6)).unwrap();
                    }
                });
            }
        });
        w.flush().unwrap();
        assert_eq!(Manifest::read(dir.path()).unwrap().samples.len(), 12);
    }
}
