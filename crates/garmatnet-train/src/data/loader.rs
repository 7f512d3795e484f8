//! Loading a dataset for training and evaluation: validation, the rebuilt garment template,
//! the network inputs (θ, normalised ω) and the labels of eqs. 4–5 in the model's frame.
//!
//! Samples are preloaded into flat `f32` buffers once, so an epoch only slices memory.

use std::path::Path;

use garmatnet_core::{
    CapsuleBody, DisplacementFrame, Garment, Iso3, JOINT_COUNT, MATERIAL_DIM, POSE_DIM, Pose,
    Skeleton, SkinnedBody, Vec3, decompose, field_to_frame,
};
use garmatnet_sim::{DatasetReader, DatasetSpec, MirrorMap, SampleRecord};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// How far (metres) a stored per-vertex body point may be from the rebuilt template's posed
/// anchor before the dataset is judged to belong to another template or body.
pub const BODY_POINT_TOLERANCE: f64 = 1e-3;

/// One sample, by its material and pose indices into the dataset's spec.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct SampleKey {
    /// Index into the dataset's materials.
    pub material: usize,
    /// Index into the dataset's poses.
    pub pose: usize,
}

impl SampleKey {
    /// The key of a dataset's sample record.
    #[must_use]
    pub fn of(record: &SampleRecord) -> Self {
        Self {
            material: record.material,
            pose: record.pose,
        }
    }
}

/// A validated dataset with the garment template it was made for.
#[derive(Debug)]
pub struct TrainingDataset {
    reader: DatasetReader,
    garment: Garment,
    body: CapsuleBody,
    template_hash: String,
    dataset_hash: String,
}

/// One sample's world-frame ground truth (metres), for evaluation.
#[derive(Debug, Clone)]
pub struct SampleTruth {
    /// The posed anchors the displacements are measured from (one per garment vertex).
    pub body_points: Vec<Vec3>,
    /// The Laplacian-smoothed garment.
    pub smoothed: Vec<Vec3>,
    /// The simulated garment.
    pub simulated: Vec<Vec3>,
    /// The pose's skinning transforms.
    pub transforms: [Iso3; JOINT_COUNT],
}

/// Preloaded inputs and labels of a set of samples.
///
/// A row is a sample as draped, or its mirror image ([`TrainingDataset::load_mirrored`]):
/// `keys[r]` names the sample either way, and `mirrored[r]` says which.
///
/// # Shapes
/// `poses`: `[S, 72]`; `materials`: `[S, 6]`; `d_fitting`, `d_local`: `[S, 3n]`, all
/// row-major, labels in metres in [`LoadedSamples::frame`].
#[derive(Debug, Clone, Default)]
pub struct LoadedSamples {
    /// The samples, in row order.
    pub keys: Vec<SampleKey>,
    /// Per row, whether it is its sample's mirror image (at the mirrored pose).
    pub mirrored: Vec<bool>,
    /// The garment vertex count n.
    pub vertex_count: usize,
    /// The frame of the labels.
    pub frame: DisplacementFrame,
    /// θ per sample (radians).
    pub poses: Vec<f32>,
    /// Normalised ω per sample.
    pub materials: Vec<f32>,
    /// Smoothed garment minus body points (eq. 5).
    pub d_fitting: Vec<f32>,
    /// Simulated minus smoothed garment (eq. 4).
    pub d_local: Vec<f32>,
}

impl LoadedSamples {
    /// The number of samples S.
    #[must_use]
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// Whether there are no samples.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// Appends `other`'s rows after this set's.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] when the two sets have other vertex counts or frames.
    pub fn append(&mut self, other: LoadedSamples) -> Result<()> {
        if other.vertex_count != self.vertex_count || other.frame != self.frame {
            return Err(Error::InvalidConfig(format!(
                "cannot join samples of {} vertices in the {:?} frame to samples of {} vertices \
                 in the {:?} frame",
                other.vertex_count, other.frame, self.vertex_count, self.frame
            )));
        }
        self.keys.extend(other.keys);
        self.mirrored.extend(other.mirrored);
        self.poses.extend(other.poses);
        self.materials.extend(other.materials);
        self.d_fitting.extend(other.d_fitting);
        self.d_local.extend(other.d_local);
        Ok(())
    }
}

impl TrainingDataset {
    /// Opens and validates `dir`: the manifest, completeness (unless `allow_incomplete`), and
    /// the garment template, rebuilt from the manifest's resolution on the capsule body and
    /// checked against the manifest's template hash and vertex count.
    ///
    /// # Errors
    /// [`Error::Core`] for an unreadable or malformed manifest; [`Error::Dataset`] for
    /// missing samples (named), an unknown resolution or a template mismatch.
    pub fn open(dir: impl AsRef<Path>, allow_incomplete: bool) -> Result<Self> {
        let dir = dir.as_ref();
        let reader = DatasetReader::open(dir)?;
        let spec = reader.spec();
        let bad = |message: String| Error::Dataset {
            dir: dir.to_owned(),
            message,
        };
        if reader.samples().is_empty() {
            return Err(bad("it has no finished samples".into()));
        }
        if !allow_incomplete {
            let missing: Vec<String> = reader
                .missing()
                .into_iter()
                .map(|(m, p)| garmatnet_sim::sample_stem(m, p))
                .collect();
            if let Some(first) = missing.first() {
                return Err(bad(format!(
                    "{} of {} samples are missing (first: {first}, material `{}`); finish \
                     generating it or allow an incomplete dataset",
                    missing.len(),
                    spec.plan
                        .sample_count(spec.materials.len(), spec.poses.len()),
                    spec.materials
                        [garmatnet_sim::manifest::parse_sample_stem(first).map_or(0, |(m, _)| m)]
                    .name
                )));
            }
        }
        let resolution = spec.template.resolution;
        let body = CapsuleBody::smpl_neutral();
        let garment = match Garment::for_template(resolution, &spec.template.hash, &body) {
            Ok(garment) => garment,
            Err(_) => Garment::tshirt(resolution, &body)?,
        };
        let template_hash = format!("{:016x}", garment.template_hash());
        if template_hash != spec.template.hash
            || garment.vertex_count() != spec.template.vertex_count
        {
            return Err(bad(format!(
                "it was made for template {} ({} vertices) but this build's {} T-shirt is {} \
                 ({} vertices); regenerate the dataset with this version",
                spec.template.hash,
                spec.template.vertex_count,
                resolution,
                template_hash,
                garment.vertex_count()
            )));
        }
        let dataset_hash = dataset_hash(spec, reader.samples());
        Ok(Self {
            reader,
            garment,
            body,
            template_hash,
            dataset_hash,
        })
    }

    /// The dataset directory.
    #[must_use]
    pub fn dir(&self) -> &Path {
        self.reader.dir()
    }

    /// The dataset's spec (materials, poses, frames, template).
    #[must_use]
    pub fn spec(&self) -> &DatasetSpec {
        self.reader.spec()
    }

    /// The finished samples, sorted by (material, pose).
    #[must_use]
    pub fn records(&self) -> &[SampleRecord] {
        self.reader.samples()
    }

    /// Every finished sample's key.
    #[must_use]
    pub fn keys(&self) -> Vec<SampleKey> {
        self.records().iter().map(SampleKey::of).collect()
    }

    /// The rebuilt garment template.
    #[must_use]
    pub fn garment(&self) -> &Garment {
        &self.garment
    }

    /// The capsule body the garments were draped on.
    #[must_use]
    pub fn body(&self) -> &CapsuleBody {
        &self.body
    }

    /// The body's skeleton.
    #[must_use]
    pub fn skeleton(&self) -> &Skeleton {
        self.body.skeleton()
    }

    /// The template hash (hex), as stored in the manifest and the model file.
    #[must_use]
    pub fn template_hash(&self) -> &str {
        &self.template_hash
    }

    /// A fingerprint (FNV-1a 64, hex) of the spec and the finished samples' records; it
    /// changes when samples are added, regenerated or removed, not with the array bytes.
    #[must_use]
    pub fn dataset_hash(&self) -> &str {
        &self.dataset_hash
    }

    /// The garment vertex count n.
    #[must_use]
    pub fn vertex_count(&self) -> usize {
        self.garment.vertex_count()
    }

    /// Material names, in index order.
    #[must_use]
    pub fn material_names(&self) -> Vec<String> {
        self.spec()
            .materials
            .iter()
            .map(|m| m.name.clone())
            .collect()
    }

    /// Reads one sample's world-frame ground truth.
    ///
    /// # Errors
    /// [`Error::Dataset`] if the sample is not finished or its stored body points disagree
    /// with the template's posed anchors; [`Error::Core`] for unreadable arrays (naming the
    /// sample).
    pub fn truth(&self, key: SampleKey) -> Result<SampleTruth> {
        let record = self
            .reader
            .sample(key.material, key.pose)
            .ok_or_else(|| Error::Dataset {
                dir: self.dir().to_owned(),
                message: format!(
                    "sample {} is not finished",
                    garmatnet_sim::sample_stem(key.material, key.pose)
                ),
            })?;
        let arrays = self.reader.read_sample(record)?;
        let transforms = self
            .skeleton()
            .skinning_transforms(&self.spec().poses[key.pose]);
        let body_points = self.garment.body_points(&transforms);
        if arrays.body.len() == body_points.len() {
            let worst = arrays
                .body
                .iter()
                .zip(&body_points)
                .map(|(s, b)| (to_vec3(s) - b).norm())
                // NaN wins (f64::max would drop it), so a non-finite point fails the check.
                .fold(0.0, |worst: f64, d| {
                    if worst.is_nan() || d.is_nan() {
                        f64::NAN
                    } else {
                        worst.max(d)
                    }
                });
            if worst.is_nan() || worst > BODY_POINT_TOLERANCE {
                return Err(Error::Dataset {
                    dir: self.dir().to_owned(),
                    message: format!(
                        "sample {}: stored body points are up to {:.1} mm from the template's \
                         posed anchors; the dataset was made with another body or template",
                        record.stem,
                        worst * 1e3
                    ),
                });
            }
        }
        Ok(SampleTruth {
            body_points,
            smoothed: arrays.smoothed.iter().map(to_vec3).collect(),
            simulated: arrays.simulated.iter().map(to_vec3).collect(),
            transforms,
        })
    }

    /// θ and normalised ω of a sample, as network inputs.
    #[must_use]
    pub fn inputs(&self, key: SampleKey) -> ([f32; POSE_DIM], [f32; MATERIAL_DIM]) {
        self.row_inputs(key, false)
    }

    /// The pose of `key`'s row: the sample's own or, `mirrored`, its mirror image
    /// ([`Pose::mirrored`]).
    pub(crate) fn row_pose(&self, key: SampleKey, mirrored: bool) -> Pose {
        let pose = &self.spec().poses[key.pose];
        if mirrored {
            pose.mirrored()
        } else {
            pose.clone()
        }
    }

    /// θ (of [`TrainingDataset::row_pose`]) and normalised ω of `key`'s row, as network
    /// inputs.
    pub(crate) fn row_inputs(
        &self,
        key: SampleKey,
        mirrored: bool,
    ) -> ([f32; POSE_DIM], [f32; MATERIAL_DIM]) {
        let pose = self.row_pose(key, mirrored).to_vec();
        let omega = self.spec().materials[key.material].omega_normalized;
        (
            std::array::from_fn(|i| pose[i] as f32),
            std::array::from_fn(|i| omega[i] as f32),
        )
    }

    /// Preloads `keys`' inputs and labels, the labels expressed in `frame`.
    ///
    /// # Errors
    /// As [`TrainingDataset::truth`], naming the first bad sample.
    pub fn load(&self, keys: &[SampleKey], frame: DisplacementFrame) -> Result<LoadedSamples> {
        self.load_rows(keys, frame, false)
    }

    /// Preloads the mirror images of `keys`' samples: each at the mirrored pose
    /// ([`Pose::mirrored`](garmatnet_core::Pose::mirrored)) with the mirrored drape, vertex
    /// `i` taking the reflection (x → −x) of its mirror twin's displacements
    /// ([`Garment::mirror_twins`]), the labels expressed in `frame` at the mirrored pose.
    ///
    /// The body and the template are mirror-symmetric as they are built, so this is the
    /// sample the solver would drape at the mirrored pose, up to the body mesh's own
    /// asymmetry (0.2 mm on average) and the solver's choice at a buckle: training samples
    /// for free, which give the nets the left-right symmetry that
    /// [`Predictor::with_mirror_averaging`](garmatnet_model::Predictor::with_mirror_averaging)
    /// otherwise imposes after the fact.
    ///
    /// # Errors
    /// As [`TrainingDataset::load`].
    pub fn load_mirrored(
        &self,
        keys: &[SampleKey],
        frame: DisplacementFrame,
    ) -> Result<LoadedSamples> {
        self.load_rows(keys, frame, true)
    }

    /// [`TrainingDataset::load`] or, `mirrored`, [`TrainingDataset::load_mirrored`].
    fn load_rows(
        &self,
        keys: &[SampleKey],
        frame: DisplacementFrame,
        mirrored: bool,
    ) -> Result<LoadedSamples> {
        let n3 = 3 * self.vertex_count();
        let mut out = LoadedSamples {
            keys: keys.to_vec(),
            mirrored: vec![mirrored; keys.len()],
            vertex_count: self.vertex_count(),
            frame,
            poses: Vec::with_capacity(keys.len() * POSE_DIM),
            materials: Vec::with_capacity(keys.len() * MATERIAL_DIM),
            d_fitting: Vec::with_capacity(keys.len() * n3),
            d_local: Vec::with_capacity(keys.len() * n3),
        };
        let map = if mirrored {
            Some(MirrorMap::from_twins(self.garment.mirror_twins())?)
        } else {
            None
        };
        let flat = |field: Vec<Vec3>| {
            field
                .into_iter()
                .flat_map(|v| [v.x as f32, v.y as f32, v.z as f32])
        };
        let anchors = &self.garment.anchors;
        for &key in keys {
            let truth = self.truth(key)?;
            let parts = decompose(&truth.simulated, &truth.smoothed, &truth.body_points)?;
            let (transforms, d_fitting, d_local) = match &map {
                Some(map) => (
                    self.skeleton()
                        .skinning_transforms(&self.row_pose(key, true)),
                    map.mirrored(&parts.d_fitting)?,
                    map.mirrored(&parts.d_local)?,
                ),
                None => (truth.transforms, parts.d_fitting, parts.d_local),
            };
            let fit = field_to_frame(&d_fitting, anchors, frame, &transforms)?;
            let local = field_to_frame(&d_local, anchors, frame, &transforms)?;
            let (pose, material) = self.row_inputs(key, mirrored);
            out.poses.extend(pose);
            out.materials.extend(material);
            out.d_fitting.extend(flat(fit));
            out.d_local.extend(flat(local));
        }
        Ok(out)
    }
}

fn to_vec3(p: &[f32; 3]) -> Vec3 {
    Vec3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))
}

/// FNV-1a 64 over the spec's JSON and each finished sample's record JSON.
fn dataset_hash(spec: &DatasetSpec, records: &[SampleRecord]) -> String {
    let mut hash = Fnv1a::default();
    hash.write(&serde_json::to_vec(spec).unwrap_or_default());
    for r in records {
        hash.write(&serde_json::to_vec(r).unwrap_or_default());
    }
    format!("{:016x}", hash.0)
}

/// The 64-bit FNV-1a hash, for fingerprints that must be stable across platforms.
pub(crate) struct Fnv1a(pub(crate) u64);

impl Default for Fnv1a {
    fn default() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv1a {
    pub(crate) fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

/// Creates the output directory `dir` and takes its lock (`dir/.lock`), so no second
/// process writes into it at the same time. `what` names the output in the error.
pub(crate) fn create_locked_dir(dir: &Path, what: &str) -> Result<garmatnet_core::OutputLock> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    Ok(garmatnet_core::OutputLock::acquire(
        dir.join(".lock"),
        &format!("{what} {}", dir.display()),
    )?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{synthetic_dataset, synthetic_dataset_with_plan};

    #[test]
    fn labels_decompose_the_garment_and_bad_datasets_name_the_sample() {
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 3, 4);
        let set = TrainingDataset::open(&data, false).unwrap();
        let key = SampleKey {
            material: 1,
            pose: 2,
        };
        let truth = set.truth(key).unwrap();
        let loaded = set.load(&[key], DisplacementFrame::World).unwrap();
        for i in 0..set.vertex_count() {
            for c in 0..3 {
                let rebuilt = truth.body_points[i][c]
                    + f64::from(loaded.d_fitting[3 * i + c])
                    + f64::from(loaded.d_local[3 * i + c]);
                approx::assert_abs_diff_eq!(rebuilt, truth.simulated[i][c], epsilon = 1e-5);
            }
        }
        assert_eq!(loaded.poses.len(), POSE_DIM);
        assert_eq!(loaded.materials.len(), MATERIAL_DIM);

        // A corrupt array names its sample when loaded.
        let stem = garmatnet_sim::sample_stem(1, 2);
        let npy = data.join("samples").join(&stem).join("smoothed.npy");
        std::fs::write(&npy, b"not an npy").unwrap();
        let err = set.load(&[key], DisplacementFrame::World).unwrap_err();
        assert!(err.to_string().contains(&stem), "{err}");

        // A missing sample makes the dataset incomplete, named in the error.
        std::fs::remove_dir_all(data.join("samples").join(&stem)).unwrap();
        let err = TrainingDataset::open(&data, false).unwrap_err();
        assert!(err.to_string().contains(&stem), "{err}");
        assert!(TrainingDataset::open(&data, true).is_ok());

        // Another template hash is refused.
        let manifest = data.join("manifest.json");
        let text = std::fs::read_to_string(&manifest).unwrap();
        let hash = set.template_hash().to_owned();
        std::fs::write(&manifest, text.replace(&hash, "0123456789abcdef")).unwrap();
        let err = TrainingDataset::open(&data, true).unwrap_err();
        assert!(err.to_string().contains("regenerate the dataset"), "{err}");
    }

    #[test]
    fn a_strided_dataset_is_complete_with_the_samples_its_plan_holds() {
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        let plan = garmatnet_sim::SamplePlan::Strided {
            stride: 2,
            full_poses: 1,
        };
        synthetic_dataset_with_plan(&data, 3, 4, plan);
        // Pose 0 for all three, then 1 of 3, 2 of 3 and 1 of 3: 7 samples.
        let set = TrainingDataset::open(&data, false).unwrap();
        assert_eq!(set.keys().len(), 7);
        // A sample the plan holds is still missed, and counted against the plan's total.
        let stem = garmatnet_sim::sample_stem(2, 2);
        std::fs::remove_dir_all(data.join("samples").join(&stem)).unwrap();
        let err = TrainingDataset::open(&data, false).unwrap_err().to_string();
        assert!(
            err.contains(&stem) && err.contains("1 of 7 samples"),
            "{err}"
        );
    }

    #[test]
    fn mirrored_rows_are_the_mirror_image_of_the_drape_at_the_mirrored_pose() {
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 2, 3);
        let set = TrainingDataset::open(&data, false).unwrap();
        let keys = set.keys();
        let map = MirrorMap::from_twins(set.garment().mirror_twins()).unwrap();
        let smoother = garmatnet_core::LaplacianSmoother::new(
            &set.garment().rest,
            garmatnet_core::SmoothingSettings::default(),
        )
        .unwrap();
        for frame in [DisplacementFrame::World, DisplacementFrame::Canonical] {
            let mut rows = set.load(&keys, frame).unwrap();
            let mirrored = set.load_mirrored(&keys, frame).unwrap();
            assert_eq!(mirrored.keys, keys);
            assert!(mirrored.mirrored.iter().all(|&m| m));
            rows.append(mirrored).unwrap();
            assert_eq!(rows.len(), 2 * keys.len());
            assert_eq!(rows.mirrored.iter().filter(|&&m| m).count(), keys.len());
            for (r, &key) in keys.iter().enumerate() {
                let row = keys.len() + r;
                let pose = set.spec().poses[key.pose].mirrored();
                let drape = map.mirrored(&set.truth(key).unwrap().simulated).unwrap();
                let theta: Vec<f32> = pose.to_vec().iter().map(|&v| v as f32).collect();
                assert_eq!(rows.poses[row * POSE_DIM..(row + 1) * POSE_DIM], theta[..]);
                assert_eq!(
                    rows.materials[row * MATERIAL_DIM..(row + 1) * MATERIAL_DIM],
                    rows.materials[r * MATERIAL_DIM..(r + 1) * MATERIAL_DIM]
                );
                // The row's labels, read back at the mirrored pose, rebuild the reflected
                // drape with each vertex at its twin's place, up to the body's own asymmetry.
                let transforms = set.skeleton().skinning_transforms(&pose);
                let body = set.garment().body_points(&transforms);
                let n = set.vertex_count();
                let (mut sum, mut worst) = (0.0, 0.0_f64);
                for i in 0..n {
                    let at = |v: &[f32]| {
                        let o = row * 3 * n + 3 * i;
                        Vec3::new(f64::from(v[o]), f64::from(v[o + 1]), f64::from(v[o + 2]))
                    };
                    let d = set.garment().anchors[i].from_frame(
                        &(at(&rows.d_fitting) + at(&rows.d_local)),
                        frame,
                        &transforms,
                    );
                    let err = (body[i] + d - drape[i]).norm();
                    sum += err;
                    worst = worst.max(err);
                }
                assert!(sum / n as f64 <= 1e-3 && worst <= 5e-3, "{sum} {worst}");
            }
        }
        // The split into smooth garment and wrinkles commutes with the mirror, so the
        // reflected labels are the decomposition of the reflected drape.
        let truth = set.truth(keys[1]).unwrap();
        let smoothed = smoother
            .smooth(&map.mirrored(&truth.simulated).unwrap())
            .unwrap();
        for (a, b) in smoothed.iter().zip(map.mirrored(&truth.smoothed).unwrap()) {
            assert!((a - b).norm() < 1e-5, "{a} {b}");
        }
    }
}
