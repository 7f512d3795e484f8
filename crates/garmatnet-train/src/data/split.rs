//! The paper's data split (§4.1): unseen materials and unseen poses go to test, the rest is
//! split 90/10 into train and dev with a seeded shuffle.
//!
//! The split is written next to the model (`{model stem}.split.json`), together with it at the
//! end of training, and evaluation reads it back, so a test sample can never have been
//! trained on. The model records the split's [`Split::fingerprint`], and
//! [`Split::read_for_model`] refuses a split file that is not that model's, or that names
//! samples outside the dataset.

use std::collections::BTreeSet;
use std::path::Path;

use garmatnet_core::SplitMix64;
use garmatnet_model::{MaterialRange, TrainingFabric, TrainingProvenance};
use garmatnet_sim::{DatasetSpec, SampleRecord};
use serde::{Deserialize, Serialize};

use crate::data::loader::{Fnv1a, SampleKey};
use crate::data::split_config::SplitConfig;
use crate::error::{Error, Result};

/// A concrete split of one dataset.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Split {
    /// The fingerprint of the dataset it was made for.
    pub dataset_hash: String,
    /// The configuration it was made with.
    pub config: SplitConfig,
    /// Indices of the target materials, in `config.test_materials` order.
    pub test_materials: Vec<usize>,
    /// Indices of the held-out poses.
    pub held_out_poses: Vec<usize>,
    /// Indices of the dev materials (`config.dev_materials`), if any.
    #[serde(default)]
    pub dev_materials: Vec<usize>,
    /// Indices of the dev poses (`config.dev_frame_offset`), if any, sorted.
    #[serde(default)]
    pub dev_poses: Vec<usize>,
    /// Training samples, sorted.
    pub train: Vec<SampleKey>,
    /// Development (early-stopping) samples, sorted.
    pub dev: Vec<SampleKey>,
    /// Test samples, sorted.
    pub test: Vec<SampleKey>,
    /// Samples no net trains on, sorted: those above `config.max_train_residual`, and every
    /// drape caught in the body
    /// ([`is_caught_in_body`](garmatnet_sim::SampleStats::is_caught_in_body): recorded
    /// penetration past 1 mm, which `dataset check` lists as penetrating: torn or snagged
    /// cloth). In no training or development set; test samples among them stay in `test`.
    #[serde(default)]
    pub unsettled: Vec<SampleKey>,
}

impl Split {
    /// The per-component range of normalised ω over the training samples' materials (what a
    /// model trained on this split has seen), or `None` without training samples.
    #[must_use]
    pub fn material_range(&self, spec: &DatasetSpec) -> Option<MaterialRange> {
        MaterialRange::of(
            self.train
                .iter()
                .map(|k| spec.materials[k.material].omega_normalized),
        )
    }

    /// The materials of the training samples, in the dataset's order, with their normalised
    /// ω: what a model trained on this split has learned (recorded in its file).
    #[must_use]
    pub fn training_fabrics(&self, spec: &DatasetSpec) -> Vec<TrainingFabric> {
        let mut materials: Vec<usize> = self.train.iter().map(|k| k.material).collect();
        materials.sort_unstable();
        materials.dedup();
        materials
            .into_iter()
            .map(|m| TrainingFabric {
                name: spec.materials[m].name.clone(),
                omega: spec.materials[m].omega_normalized,
            })
            .collect()
    }

    /// Splits the finished `samples` of the dataset described by `spec`.
    ///
    /// # Errors
    /// [`Error::UnknownMaterials`] if a target material is not in the dataset;
    /// [`Error::UnknownMaterials`] for an unknown dev material;
    /// [`Error::InvalidConfig`] for a dev fraction outside (0, 1), `held_out_frame_every = 0`,
    /// a `held_out_block` outside `1..held_out_frame_every`, a dev material that is also a
    /// target material, a `dev_frame_offset` outside `held_out_block..held_out_frame_every`
    /// or given with dev materials, a `max_train_residual` that is not positive, or a split
    /// that leaves train, dev or test empty.
    pub fn new(
        spec: &DatasetSpec,
        samples: &[SampleRecord],
        dataset_hash: &str,
        config: &SplitConfig,
    ) -> Result<Self> {
        if let Some(r) = config.max_train_residual
            && (r.is_nan() || r <= 0.0)
        {
            return Err(Error::InvalidConfig(format!(
                "split.max_train_residual = {r} must be positive (or absent to use every \
                 sample)"
            )));
        }
        // A drape caught in the body is torn or snagged cloth, whatever its residual: no
        // net learns from it.
        let settled = |r: &SampleRecord| {
            !r.stats.is_caught_in_body()
                && config
                    .max_train_residual
                    .is_none_or(|max| r.stats.residual <= max)
        };
        let mut unsettled: Vec<SampleKey> = samples
            .iter()
            .filter(|r| !settled(r))
            .map(SampleKey::of)
            .collect();
        unsettled.sort();
        let samples: Vec<SampleKey> = samples.iter().map(SampleKey::of).collect();
        if !(config.dev_fraction > 0.0 && config.dev_fraction < 1.0) {
            return Err(Error::InvalidConfig(format!(
                "split.dev_fraction = {} must lie strictly between 0 and 1",
                config.dev_fraction
            )));
        }
        if config.held_out_frame_every == 0 {
            return Err(Error::InvalidConfig(
                "split.held_out_frame_every must be positive".into(),
            ));
        }
        if config.held_out_block == 0 || config.held_out_block >= config.held_out_frame_every {
            return Err(Error::InvalidConfig(format!(
                "split.held_out_block = {} must lie in 1..{} (below held_out_frame_every, or \
                 every pose would be held out)",
                config.held_out_block, config.held_out_frame_every
            )));
        }
        let test_materials = if config.test_materials.is_empty() {
            Vec::new()
        } else {
            material_indices(spec, &config.test_materials)?
        };
        let dev_materials = if config.dev_materials.is_empty() {
            Vec::new()
        } else {
            material_indices(spec, &config.dev_materials)?
        };
        if let Some(&m) = dev_materials.iter().find(|m| test_materials.contains(m)) {
            return Err(Error::InvalidConfig(format!(
                "`{}` is both a test and a dev material; dev materials must be training fabrics",
                spec.materials[m].name
            )));
        }
        if let Some(offset) = config.dev_frame_offset {
            if !(config.held_out_block..config.held_out_frame_every).contains(&offset) {
                return Err(Error::InvalidConfig(format!(
                    "split.dev_frame_offset = {offset} must lie in {}..{}: frames with \
                     f % {} < {} are test frames",
                    config.held_out_block,
                    config.held_out_frame_every,
                    config.held_out_frame_every,
                    config.held_out_block
                )));
            }
            if !dev_materials.is_empty() {
                return Err(Error::InvalidConfig(
                    "split.dev_frame_offset and split.dev_materials both choose the \
                     development set; give one"
                        .into(),
                ));
            }
        }
        // The poses whose frame's phase in the held-out period passes `keep`, sorted.
        let poses_where = |keep: &dyn Fn(usize) -> bool| -> Vec<usize> {
            (0..spec.frames.len())
                .filter(|&p| keep(spec.frames[p] % config.held_out_frame_every))
                .collect()
        };
        let dev_poses = match config.dev_frame_offset {
            Some(offset) => poses_where(&|phase| phase == offset),
            None => Vec::new(),
        };
        let held_out_poses = poses_where(&|phase| phase < config.held_out_block);
        let is_test = |k: &SampleKey| {
            test_materials.contains(&k.material) || held_out_poses.binary_search(&k.pose).is_ok()
        };
        let mut test: Vec<SampleKey> = samples.iter().copied().filter(is_test).collect();
        let mut rest: Vec<SampleKey> = samples
            .iter()
            .copied()
            .filter(|k| !is_test(k) && unsettled.binary_search(k).is_err())
            .collect();
        rest.sort();
        SplitMix64::new(config.seed).shuffle(&mut rest);
        let dev_count = ((rest.len() as f64 * config.dev_fraction).round() as usize).max(1);
        if rest.len() < 2 || test.is_empty() {
            return Err(Error::InvalidConfig(format!(
                "the split leaves {} training/dev and {} test samples ({} left out as \
                 unsettled); both need samples (add materials or poses, or choose other test \
                 materials)",
                rest.len(),
                test.len(),
                unsettled.len()
            )));
        }
        let (mut train, mut dev) = if config.dev_frame_offset.is_some() {
            rest.into_iter()
                .partition(|k: &SampleKey| dev_poses.binary_search(&k.pose).is_err())
        } else if dev_materials.is_empty() {
            let dev = rest.split_off(rest.len() - dev_count);
            (rest, dev)
        } else {
            rest.into_iter()
                .partition(|k: &SampleKey| !dev_materials.contains(&k.material))
        };
        if train.is_empty() || dev.is_empty() {
            return Err(Error::InvalidConfig(format!(
                "the split leaves {} training and {} dev samples; both need samples",
                train.len(),
                dev.len()
            )));
        }
        train.sort();
        dev.sort();
        test.sort();
        Ok(Self {
            dataset_hash: dataset_hash.to_owned(),
            config: config.clone(),
            test_materials,
            held_out_poses,
            dev_materials,
            dev_poses,
            train,
            dev,
            test,
            unsettled,
        })
    }

    /// Whether `key` may be trained on by a net that is allowed its material and pose (the
    /// baseline's own samples): its drape settled and is not caught in the body.
    #[must_use]
    pub fn is_settled(&self, key: &SampleKey) -> bool {
        self.unsettled.binary_search(key).is_err()
    }

    /// Test samples of a target material at a held-out pose: the set the per-material
    /// baseline can be compared on (the paper's 4 materials × 73 poses). Without target
    /// materials, every test sample (each fabric at the held-out poses).
    #[must_use]
    pub fn comparison_test(&self) -> Vec<SampleKey> {
        self.test
            .iter()
            .copied()
            .filter(|k| {
                (self.test_materials.is_empty() || self.test_materials.contains(&k.material))
                    && self.held_out_poses.binary_search(&k.pose).is_ok()
            })
            .collect()
    }

    /// Checks that no test sample, target material or held-out pose appears in train or dev,
    /// and that train and dev do not overlap.
    ///
    /// # Errors
    /// [`Error::Split`] naming the leaking sample.
    pub fn check_no_leak(&self, path: &Path) -> Result<()> {
        let test: BTreeSet<_> = self.test.iter().collect();
        let dev: BTreeSet<_> = self.dev.iter().collect();
        for (set, name) in [(&self.train, "train"), (&self.dev, "dev")] {
            for k in set {
                let leak = test.contains(k)
                    || !self.is_settled(k)
                    || self.test_materials.contains(&k.material)
                    || self.held_out_poses.binary_search(&k.pose).is_ok()
                    || (name == "train"
                        && (dev.contains(k)
                            || self.dev_materials.contains(&k.material)
                            || self.dev_poses.binary_search(&k.pose).is_ok()));
                if leak {
                    return Err(Error::Split {
                        path: path.to_owned(),
                        message: format!(
                            "{name} sample (material {}, pose {}) belongs to the test set",
                            k.material, k.pose
                        ),
                    });
                }
            }
        }
        Ok(())
    }

    /// Writes the split as JSON, atomically.
    ///
    /// # Errors
    /// [`Error::Core`] (I/O) if the file cannot be written.
    pub fn write(&self, path: &Path) -> Result<()> {
        let bytes = serde_json::to_vec_pretty(self).map_err(|source| Error::Serialize {
            what: "the split",
            source,
        })?;
        garmatnet_core::write_bytes_atomic(path, &bytes)?;
        crate::data::files::make_readable(path);
        Ok(())
    }

    /// Reads a split and checks it against the dataset it will be used with.
    ///
    /// This checks what the file alone can tell: the dataset fingerprint, sorted
    /// duplicate-free lists ([`Split::check_well_formed`]) and no leak. It cannot check that
    /// the indices lie inside the dataset; readers that index the dataset with the split use
    /// [`Split::read_for_dataset`] or [`Split::read_for_model`].
    ///
    /// # Errors
    /// [`Error::Io`] if it cannot be read; [`Error::Split`] if it is malformed (lists
    /// unsorted or with duplicates), leaks, or was made for another dataset (`dataset_hash`
    /// differs).
    pub fn read(path: &Path, dataset_hash: &str) -> Result<Self> {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        let split: Split = serde_json::from_slice(&bytes).map_err(|e| Error::Split {
            path: path.to_owned(),
            message: format!("not a split file: {e}"),
        })?;
        if split.dataset_hash != dataset_hash {
            return Err(Error::Split {
                path: path.to_owned(),
                message: format!(
                    "it was made for dataset {} but this dataset is {dataset_hash}; evaluate on \
                     the dataset the model was trained on",
                    split.dataset_hash
                ),
            });
        }
        split.check_well_formed(path)?;
        split.check_no_leak(path)?;
        Ok(split)
    }

    /// [`Split::read`], then checks that every index lies inside the dataset `spec`
    /// ([`Split::check_within`]), so no reader indexes the dataset out of bounds.
    ///
    /// # Errors
    /// As [`Split::read`]; [`Error::Split`] naming an entry outside the dataset.
    pub fn read_for_dataset(path: &Path, spec: &DatasetSpec, dataset_hash: &str) -> Result<Self> {
        let split = Self::read(path, dataset_hash)?;
        split.check_within(spec, path)?;
        Ok(split)
    }

    /// Reads the split next to the model at `model_path` ([`crate::split_path`]) for the
    /// dataset `spec`, as [`Split::read_for_dataset`], and checks that it is the split that
    /// model was trained with ([`Split::check_model`]).
    ///
    /// # Errors
    /// As [`Split::read_for_dataset`]; [`Error::Split`] if the model records another split.
    pub fn read_for_model(
        model_path: &Path,
        provenance: &TrainingProvenance,
        spec: &DatasetSpec,
        dataset_hash: &str,
    ) -> Result<Self> {
        let path = crate::data::files::split_path(model_path);
        let split = Self::read_for_dataset(&path, spec, dataset_hash)?;
        split.check_model(&path, model_path, provenance)?;
        Ok(split)
    }

    /// A fingerprint of the split's samples and indices (not its configuration, whose floats
    /// need not survive a JSON round trip bit for bit): 16 hex digits of FNV-1a 64.
    ///
    /// The trainer records it in the model's provenance
    /// ([`TrainingProvenance::split_fingerprint`]) when it writes the model, so a split file
    /// that does not belong to the model next to it — a run killed after writing its split
    /// but before its model, a file copied from elsewhere — is refused instead of silently
    /// testing on samples the model trained on.
    #[must_use]
    pub fn fingerprint(&self) -> String {
        let mut h = Fnv1a::default();
        h.write(self.dataset_hash.as_bytes());
        let mut list = |name: &str, values: &mut dyn Iterator<Item = usize>| {
            h.write(name.as_bytes());
            for v in values {
                h.write(&(v as u64).to_le_bytes());
            }
        };
        list("test_materials", &mut self.test_materials.iter().copied());
        list("held_out_poses", &mut self.held_out_poses.iter().copied());
        list("dev_materials", &mut self.dev_materials.iter().copied());
        list("dev_poses", &mut self.dev_poses.iter().copied());
        for (name, keys) in [
            ("train", &self.train),
            ("dev", &self.dev),
            ("test", &self.test),
            ("unsettled", &self.unsettled),
        ] {
            list(
                name,
                &mut keys.iter().flat_map(|k| [k.material, k.pose].into_iter()),
            );
        }
        format!("{:016x}", h.0)
    }

    /// Checks that this split (read from `path`) is the one the model at `model_path`, with
    /// `provenance`, was trained with. A model written before the fingerprint was recorded
    /// has none and is accepted as before.
    ///
    /// # Errors
    /// [`Error::Split`] if the recorded fingerprint differs from [`Split::fingerprint`].
    pub fn check_model(
        &self,
        path: &Path,
        model_path: &Path,
        provenance: &TrainingProvenance,
    ) -> Result<()> {
        let Some(recorded) = provenance.split_fingerprint() else {
            return Ok(());
        };
        let actual = self.fingerprint();
        if recorded == actual {
            return Ok(());
        }
        Err(Error::Split {
            path: path.to_owned(),
            message: format!(
                "it is not the split `{}` was trained with (split fingerprint {actual}, the \
                 model records {recorded}): its test samples may have been trained on. A \
                 training run was probably interrupted after writing its split, or the file \
                 was replaced; finish or repeat the training with the same --out, or put the \
                 model's own split file back",
                model_path.display()
            ),
        })
    }

    /// Checks that the index lists are as the trainer writes them: the pose lists and the
    /// sample lists sorted (they are binary-searched) and no list with a duplicate.
    ///
    /// # Errors
    /// [`Error::Split`] naming the list and the first entry out of order or repeated.
    pub fn check_well_formed(&self, path: &Path) -> Result<()> {
        let refuse = |list: &str, entry: String, problem: &str| Error::Split {
            path: path.to_owned(),
            message: format!(
                "`{list}` {problem} at {entry}; the trainer writes these lists sorted and \
                 without duplicates, so the file was edited or damaged: restore it or re-train"
            ),
        };
        for (list, indices) in [
            ("held_out_poses", &self.held_out_poses),
            ("dev_poses", &self.dev_poses),
        ] {
            if let Some(w) = indices.windows(2).find(|w| w[0] >= w[1]) {
                return Err(refuse(
                    list,
                    format!("pose {}", w[1]),
                    "is not sorted or repeats an entry",
                ));
            }
        }
        for (list, indices) in [
            ("test_materials", &self.test_materials),
            ("dev_materials", &self.dev_materials),
        ] {
            let mut seen = BTreeSet::new();
            if let Some(m) = indices.iter().find(|&&m| !seen.insert(m)) {
                return Err(refuse(list, format!("material {m}"), "repeats an entry"));
            }
        }
        for (list, keys) in [
            ("train", &self.train),
            ("dev", &self.dev),
            ("test", &self.test),
            ("unsettled", &self.unsettled),
        ] {
            if let Some(w) = keys.windows(2).find(|w| w[0] >= w[1]) {
                return Err(refuse(
                    list,
                    format!("sample (material {}, pose {})", w[1].material, w[1].pose),
                    "is not sorted or repeats an entry",
                ));
            }
        }
        Ok(())
    }

    /// Checks that every material and pose index of the split lies inside the dataset
    /// `spec`, so that a hand-edited or foreign file cannot index the dataset out of bounds.
    ///
    /// # Errors
    /// [`Error::Split`] naming the first entry outside the dataset.
    pub fn check_within(&self, spec: &DatasetSpec, path: &Path) -> Result<()> {
        let (materials, poses) = (spec.materials.len(), spec.poses.len());
        let refuse = |list: &str, entry: String| Error::Split {
            path: path.to_owned(),
            message: format!(
                "`{list}` names {entry}, outside the dataset ({materials} materials, indices \
                 0..{materials}; {poses} poses, indices 0..{poses}); the file was edited or \
                 belongs to another dataset: restore it or re-train"
            ),
        };
        for (list, indices) in [
            ("test_materials", &self.test_materials),
            ("dev_materials", &self.dev_materials),
        ] {
            if let Some(m) = indices.iter().find(|&&m| m >= materials) {
                return Err(refuse(list, format!("material {m}")));
            }
        }
        for (list, indices) in [
            ("held_out_poses", &self.held_out_poses),
            ("dev_poses", &self.dev_poses),
        ] {
            if let Some(p) = indices.iter().find(|&&p| p >= poses) {
                return Err(refuse(list, format!("pose {p}")));
            }
        }
        for (list, keys) in [
            ("train", &self.train),
            ("dev", &self.dev),
            ("test", &self.test),
            ("unsettled", &self.unsettled),
        ] {
            if let Some(k) = keys
                .iter()
                .find(|k| k.material >= materials || k.pose >= poses)
            {
                return Err(refuse(
                    list,
                    format!("sample (material {}, pose {})", k.material, k.pose),
                ));
            }
        }
        Ok(())
    }
}

/// Indices of `names` among the dataset's materials.
///
/// # Errors
/// [`Error::UnknownMaterials`] listing the missing names and the available ones.
pub fn material_indices(spec: &DatasetSpec, names: &[String]) -> Result<Vec<usize>> {
    let mut out = Vec::new();
    let mut missing = Vec::new();
    for name in names {
        match spec.materials.iter().position(|m| &m.name == name) {
            // A name given twice holds out one fabric (a split's lists have no repeats).
            Some(i) if out.contains(&i) => {}
            Some(i) => out.push(i),
            None => missing.push(name.clone()),
        }
    }
    if missing.is_empty() && !out.is_empty() {
        Ok(out)
    } else {
        Err(Error::UnknownMaterials {
            missing,
            available: spec.materials.iter().map(|m| m.name.clone()).collect(),
        })
    }
}

impl crate::data::loader::TrainingDataset {
    /// The split `config` makes of this dataset's finished samples ([`Split::new`]).
    ///
    /// # Errors
    /// As [`Split::new`].
    pub fn split(&self, config: &SplitConfig) -> Result<Split> {
        Split::new(self.spec(), self.records(), self.dataset_hash(), config)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use garmatnet_core::{Pose, Resolution, TemplateInfo};
    use garmatnet_sim::{BodyInfo, MaterialEntry, SOUND_PENETRATION_M, SmoothingInfo};

    fn spec(materials: usize, poses: usize) -> DatasetSpec {
        DatasetSpec {
            template: TemplateInfo {
                resolution: Resolution::Coarse,
                vertex_count: 3,
                hash: "t".into(),
            },
            body: BodyInfo { name: "b".into() },
            materials: (0..materials)
                .map(|i| MaterialEntry {
                    name: format!("M{i}"),
                    omega: [1.0; 6],
                    omega_normalized: [0.5; 6],
                })
                .collect(),
            poses: vec![Pose::zero(); poses],
            frames: (0..poses).map(|p| 3 * p).collect(),
            solver: serde_json::Value::Null,
            smoothing: SmoothingInfo {
                lambda: 0.15,
                iterations: 80,
                weights: "uniform".into(),
            },
            ground_truth_revision: None,
            protocol: Default::default(),
            plan: Default::default(),
        }
    }

    fn all_keys(materials: usize, poses: usize) -> Vec<SampleKey> {
        (0..materials)
            .flat_map(|material| (0..poses).map(move |pose| SampleKey { material, pose }))
            .collect()
    }

    /// Records of `keys`, each with residual `residual(key)`.
    fn records(keys: &[SampleKey], residual: impl Fn(&SampleKey) -> f64) -> Vec<SampleRecord> {
        keys.iter()
            .map(|k| SampleRecord {
                material: k.material,
                pose: k.pose,
                stem: garmatnet_sim::sample_stem(k.material, k.pose),
                stats: garmatnet_sim::SampleStats {
                    iterations: 1,
                    residual: residual(k),
                    max_penetration_m: 0.0,
                    max_depth_before_projection_m: None,
                    max_strain: 0.0,
                    wall_time_ms: 0.0,
                    converged: true,
                },
            })
            .collect()
    }

    fn settled(keys: &[SampleKey]) -> Vec<SampleRecord> {
        records(keys, |_| 0.0)
    }

    fn config() -> SplitConfig {
        SplitConfig {
            test_materials: vec!["M1".into(), "M4".into()],
            ..SplitConfig::default()
        }
    }

    #[test]
    fn test_set_takes_target_materials_and_held_out_frames_and_nothing_leaks() {
        let (spec, keys) = (spec(7, 40), all_keys(7, 40));
        let split = Split::new(&spec, &settled(&keys), "h", &config()).unwrap();
        // Frames 3p divisible by 10 <=> p divisible by 10.
        assert_eq!(split.held_out_poses, vec![0, 10, 20, 30]);
        assert_eq!(split.test_materials, vec![1, 4]);
        for k in &keys {
            let expect_test = k.material == 1 || k.material == 4 || k.pose % 10 == 0;
            assert_eq!(split.test.contains(k), expect_test, "{k:?}");
        }
        split.check_no_leak(Path::new("s.json")).unwrap();
        assert_eq!(
            split.train.len() + split.dev.len() + split.test.len(),
            keys.len()
        );
        let rest = (5 * 36) as f64;
        assert_eq!(split.dev.len(), (rest * 0.1).round() as usize);
        assert_eq!(split.comparison_test().len(), 2 * 4);
        // A target named twice is held out once, and the split reads back.
        let twice = SplitConfig {
            test_materials: vec!["M1".into(), "M4".into(), "M1".into()],
            ..SplitConfig::default()
        };
        let again = Split::new(&spec, &settled(&keys), "h", &twice).unwrap();
        assert_eq!(again.test_materials, vec![1, 4]);
        again.check_well_formed(Path::new("s.json")).unwrap();
    }

    #[test]
    fn without_target_materials_every_fabric_trains_and_the_held_out_poses_test() {
        let (spec, keys) = (spec(7, 40), all_keys(7, 40));
        let every_fabric = SplitConfig {
            test_materials: Vec::new(),
            ..config()
        };
        let split = Split::new(&spec, &settled(&keys), "h", &every_fabric).unwrap();
        assert!(split.test_materials.is_empty());
        for k in &keys {
            assert_eq!(split.test.contains(k), k.pose % 10 == 0, "{k:?}");
        }
        split.check_no_leak(Path::new("s.json")).unwrap();
        // Every fabric is trained on, and the comparison set is the whole test set.
        for m in 0..7 {
            assert!(split.train.iter().any(|k| k.material == m), "M{m}");
        }
        assert_eq!(split.comparison_test(), split.test);
        assert_eq!(split.test.len(), 7 * 4);
    }

    #[test]
    fn dev_materials_take_whole_training_fabrics_and_nothing_else() {
        let (spec, keys) = (spec(7, 40), all_keys(7, 40));
        let by_fabric = SplitConfig {
            dev_materials: vec!["M2".into(), "M6".into()],
            ..config()
        };
        let split = Split::new(&spec, &settled(&keys), "h", &by_fabric).unwrap();
        assert_eq!(split.dev_materials, vec![2, 6]);
        // Every dev sample is a dev fabric at a training pose, and all of those are dev.
        for k in &keys {
            let expect_dev = (k.material == 2 || k.material == 6) && k.pose % 10 != 0;
            assert_eq!(split.dev.contains(k), expect_dev, "{k:?}");
        }
        assert_eq!(split.train.len(), 3 * 36);
        split.check_no_leak(Path::new("s.json")).unwrap();
        // A dev material's sample in train is a leak; a test material cannot be a dev one.
        let mut leaky = split.clone();
        leaky.train.push(SampleKey {
            material: 2,
            pose: 1,
        });
        assert!(matches!(
            leaky.check_no_leak(Path::new("s.json")),
            Err(Error::Split { .. })
        ));
        let both = SplitConfig {
            dev_materials: vec!["M4".into()],
            ..config()
        };
        let err = Split::new(&spec, &settled(&keys), "h", &both).unwrap_err();
        assert!(
            err.to_string().contains("both a test and a dev material"),
            "{err}"
        );
        let unknown = SplitConfig {
            dev_materials: vec!["Nope".into()],
            ..config()
        };
        assert!(matches!(
            Split::new(&spec, &settled(&keys), "h", &unknown),
            Err(Error::UnknownMaterials { .. })
        ));
        // Holding out every training fabric leaves nothing to train on.
        let all = SplitConfig {
            dev_materials: ["M0", "M2", "M3", "M5", "M6"].map(String::from).to_vec(),
            ..config()
        };
        assert!(matches!(
            Split::new(&spec, &settled(&keys), "h", &all),
            Err(Error::InvalidConfig(_))
        ));
    }

    #[test]
    fn dev_frames_take_every_training_fabric_at_those_poses_and_nothing_else() {
        let (spec, keys) = (spec(7, 40), all_keys(7, 40));
        let by_pose = SplitConfig {
            test_materials: Vec::new(),
            dev_frame_offset: Some(5),
            ..config()
        };
        let split = Split::new(&spec, &settled(&keys), "h", &by_pose).unwrap();
        // Frames 3p with 3p % 10 == 5 <=> p % 10 == 5.
        assert_eq!(split.dev_poses, vec![5, 15, 25, 35]);
        for k in &keys {
            assert_eq!(split.test.contains(k), k.pose % 10 == 0, "{k:?}");
            assert_eq!(split.dev.contains(k), k.pose % 10 == 5, "{k:?}");
            assert_eq!(split.train.contains(k), k.pose % 5 != 0, "{k:?}");
        }
        split.check_no_leak(Path::new("s.json")).unwrap();
        // A dev pose's sample in train is a leak, whatever its fabric.
        let mut leaky = split.clone();
        leaky.train.push(SampleKey {
            material: 3,
            pose: 15,
        });
        assert!(matches!(
            leaky.check_no_leak(Path::new("s.json")),
            Err(Error::Split { .. })
        ));
        // The split file round-trips, and a default config does not write the field.
        let back: Split = serde_json::from_str(&serde_json::to_string(&split).unwrap()).unwrap();
        assert_eq!(back, split);
        let default = serde_json::to_string(&SplitConfig::default()).unwrap();
        assert!(!default.contains("dev_frame_offset"), "{default}");
        // A test frame cannot be a dev frame, nor can both dev rules be given.
        for bad in [0, 10, 11] {
            let config = SplitConfig {
                dev_frame_offset: Some(bad),
                ..by_pose.clone()
            };
            let err = Split::new(&spec, &settled(&keys), "h", &config).unwrap_err();
            assert!(err.to_string().contains("dev_frame_offset"), "{err}");
        }
        let both = SplitConfig {
            dev_materials: vec!["M2".into()],
            ..by_pose
        };
        let err = Split::new(&spec, &settled(&keys), "h", &both).unwrap_err();
        assert!(err.to_string().contains("give one"), "{err}");
    }

    #[test]
    fn held_out_blocks_take_runs_of_consecutive_frames() {
        let (spec, keys) = (spec(7, 40), all_keys(7, 40));
        // Frames are 3p: p = 0..3 give frames 0, 3, 6, 9 (< 10 mod 60); p = 20..23 give
        // frames 60..69.
        let blocks = SplitConfig {
            held_out_frame_every: 60,
            held_out_block: 10,
            ..config()
        };
        let split = Split::new(&spec, &settled(&keys), "h", &blocks).unwrap();
        assert_eq!(split.held_out_poses, vec![0, 1, 2, 3, 20, 21, 22, 23]);
        split.check_no_leak(Path::new("s.json")).unwrap();
        for bad in [0, 60, 61] {
            let config = SplitConfig {
                held_out_block: bad,
                ..blocks.clone()
            };
            let err = Split::new(&spec, &settled(&keys), "h", &config).unwrap_err();
            assert!(err.to_string().contains("held_out_block"), "{err}");
        }
    }

    #[test]
    fn unsettled_drapes_are_never_trained_on_but_stay_in_the_test_set() {
        let (spec, keys) = (spec(7, 40), all_keys(7, 40));
        // Every 7th sample stopped far from equilibrium, every 7th another sits exactly at
        // the threshold (settled: the limit is inclusive).
        let residual = |k: &SampleKey| match (k.material * 40 + k.pose) % 7 {
            0 => 5.0,
            1 => 0.1,
            _ => 1e-4,
        };
        let samples = records(&keys, residual);
        let filtered = SplitConfig {
            max_train_residual: Some(0.1),
            ..config()
        };
        let split = Split::new(&spec, &samples, "h", &filtered).unwrap();
        let bad: Vec<SampleKey> = keys.iter().copied().filter(|k| residual(k) > 0.1).collect();
        assert_eq!(split.unsettled, bad);
        for k in &bad {
            assert!(!split.train.contains(k) && !split.dev.contains(k), "{k:?}");
            assert!(!split.is_settled(k));
        }
        // The test set does not depend on the filter; train + dev lose exactly the bad ones.
        let unfiltered = Split::new(&spec, &samples, "h", &config()).unwrap();
        assert!(unfiltered.unsettled.is_empty());
        assert_eq!(split.test, unfiltered.test);
        let is_test = |k: &SampleKey| split.test.binary_search(k).is_ok();
        let bad_training = bad.iter().filter(|k| !is_test(k)).count();
        assert!(bad_training > 20, "the fixture must exercise the filter");
        assert_eq!(
            split.train.len() + split.dev.len() + bad_training,
            unfiltered.train.len() + unfiltered.dev.len()
        );
        split.check_no_leak(Path::new("s.json")).unwrap();
        // An unsettled sample smuggled into training is a leak, and so reads as one.
        let mut leaky = split.clone();
        leaky.train.push(*bad.iter().find(|k| !is_test(k)).unwrap());
        assert!(matches!(
            leaky.check_no_leak(Path::new("s.json")),
            Err(Error::Split { .. })
        ));
        for r in [0.0, -1.0, f64::NAN] {
            let config = SplitConfig {
                max_train_residual: Some(r),
                ..config()
            };
            let err = Split::new(&spec, &samples, "h", &config).unwrap_err();
            assert!(err.to_string().contains("max_train_residual"), "{err}");
        }
    }

    #[test]
    fn drapes_caught_in_the_body_are_never_trained_on_but_stay_in_the_test_set() {
        let (spec, keys) = (spec(7, 40), all_keys(7, 40));
        // Every 7th drape sank 5 mm into the body (torn cloth, settled or not); every 7th
        // another sits exactly at the limit (sound: the limit is inclusive).
        let depth = |k: &SampleKey| match (k.material * 40 + k.pose) % 7 {
            0 => 5e-3,
            1 => SOUND_PENETRATION_M,
            _ => 0.0,
        };
        let samples: Vec<SampleRecord> = settled(&keys)
            .into_iter()
            .map(|mut r| {
                r.stats.max_penetration_m = depth(&SampleKey::of(&r));
                r
            })
            .collect();
        // Without any residual filter: caught drapes are left out all the same.
        let split = Split::new(&spec, &samples, "h", &config()).unwrap();
        let caught: Vec<SampleKey> = keys
            .iter()
            .copied()
            .filter(|k| depth(k) > SOUND_PENETRATION_M)
            .collect();
        assert_eq!(split.unsettled, caught);
        let clean = Split::new(&spec, &settled(&keys), "h", &config()).unwrap();
        assert_eq!(split.test, clean.test);
        let is_test = |k: &SampleKey| split.test.binary_search(k).is_ok();
        let caught_training = caught.iter().filter(|k| !is_test(k)).count();
        assert!(caught_training > 20, "the fixture must exercise the filter");
        for k in &caught {
            assert!(!split.train.contains(k) && !split.dev.contains(k), "{k:?}");
        }
        assert_eq!(
            split.train.len() + split.dev.len() + caught_training,
            clean.train.len() + clean.dev.len()
        );
    }

    #[test]
    fn a_split_written_before_the_residual_filter_reads_as_unfiltered() {
        let (spec, keys) = (spec(6, 30), all_keys(6, 30));
        let split = Split::new(&spec, &settled(&keys), "h", &config()).unwrap();
        let mut json = serde_json::to_value(&split).unwrap();
        json.as_object_mut().unwrap().remove("unsettled");
        json["config"]
            .as_object_mut()
            .unwrap()
            .remove("max_train_residual");
        let old: Split = serde_json::from_value(json).unwrap();
        assert_eq!(old.config.max_train_residual, None);
        assert!(old.unsettled.is_empty());
    }

    #[test]
    fn split_is_deterministic_per_seed() {
        let (spec, keys) = (spec(6, 30), all_keys(6, 30));
        let a = Split::new(&spec, &settled(&keys), "h", &config()).unwrap();
        let b = Split::new(&spec, &settled(&keys), "h", &config()).unwrap();
        assert_eq!(a, b);
        let other = SplitConfig {
            seed: 7,
            ..config()
        };
        let c = Split::new(&spec, &settled(&keys), "h", &other).unwrap();
        assert_ne!(a.dev, c.dev, "another seed must shuffle differently");
        assert_eq!(a.test, c.test, "the test set does not depend on the seed");
    }

    #[test]
    fn absent_target_materials_list_the_available_ones() {
        let (spec, keys) = (spec(3, 20), all_keys(3, 20));
        let err = Split::new(&spec, &settled(&keys), "h", &SplitConfig::default()).unwrap_err();
        let text = err.to_string();
        assert!(matches!(err, Error::UnknownMaterials { .. }), "{text}");
        assert!(text.contains("Cashmere") && text.contains("M2"), "{text}");
    }

    /// `split` written to a temporary file, and the file.
    fn written(split: &Split) -> (tempfile::TempDir, std::path::PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("model.split.json");
        split.write(&path).unwrap();
        (dir, path)
    }

    #[test]
    fn a_split_naming_samples_outside_the_dataset_is_refused_not_a_panic() {
        let (spec, keys) = (spec(6, 30), all_keys(6, 30));
        let split = Split::new(&spec, &settled(&keys), "h", &config()).unwrap();
        let (_dir, path) = written(&split);
        assert_eq!(Split::read_for_dataset(&path, &spec, "h").unwrap(), split);
        // The audit's file: a test key at pose 9999 (kept in order, so only the bound fails).
        let mut far_pose = split.clone();
        let key = SampleKey {
            material: 0,
            pose: 9999,
        };
        let at = far_pose.test.partition_point(|k| *k < key);
        far_pose.test.insert(at, key);
        let mut far_material = split.clone();
        far_material.test.push(SampleKey {
            material: 6,
            pose: 0,
        });
        let mut far_held_out = split.clone();
        far_held_out.held_out_poses.push(30);
        let mut far_target = split.clone();
        far_target.test_materials.push(17);
        for (bad, entry) in [
            (far_pose, "sample (material 0, pose 9999)"),
            (far_material, "sample (material 6, pose 0)"),
            (far_held_out, "pose 30"),
            (far_target, "material 17"),
        ] {
            let (_dir, path) = written(&bad);
            let err = Split::read_for_dataset(&path, &spec, "h").unwrap_err();
            let text = err.to_string();
            assert!(matches!(err, Error::Split { .. }), "{text}");
            assert!(
                text.contains(entry) && text.contains("outside the dataset"),
                "{text}"
            );
        }
    }

    #[test]
    fn a_split_with_unsorted_or_repeated_lists_is_refused() {
        let (spec, keys) = (spec(6, 30), all_keys(6, 30));
        let split = Split::new(&spec, &settled(&keys), "h", &config()).unwrap();
        let mut repeated_test = split.clone();
        repeated_test.test.insert(1, split.test[1]);
        let mut unsorted_train = split.clone();
        unsorted_train.train.swap(0, 1);
        let mut unsorted_poses = split.clone();
        unsorted_poses.held_out_poses.reverse();
        let mut repeated_target = split.clone();
        repeated_target.test_materials.push(split.test_materials[0]);
        for (bad, list) in [
            (repeated_test, "`test`"),
            (unsorted_train, "`train`"),
            (unsorted_poses, "`held_out_poses`"),
            (repeated_target, "`test_materials`"),
        ] {
            let (_dir, path) = written(&bad);
            let err = Split::read(&path, "h").unwrap_err();
            let text = err.to_string();
            assert!(matches!(err, Error::Split { .. }), "{text}");
            assert!(text.contains(list) && text.contains("sorted"), "{text}");
        }
    }

    #[test]
    fn a_split_is_refused_for_a_model_that_records_another() {
        let (spec, keys) = (spec(6, 30), all_keys(6, 30));
        let split = Split::new(&spec, &settled(&keys), "h", &config()).unwrap();
        let other_seed = SplitConfig {
            seed: 7,
            ..config()
        };
        let other = Split::new(&spec, &settled(&keys), "h", &other_seed).unwrap();
        assert_ne!(split.fingerprint(), other.fingerprint());
        // The fingerprint survives the file.
        let (dir, path) = written(&split);
        assert_eq!(
            Split::read(&path, "h").unwrap().fingerprint(),
            split.fingerprint()
        );
        let model = dir.path().join("model.safetensors");
        let recording = |fingerprint: &str| TrainingProvenance {
            extra: serde_json::json!({ (TrainingProvenance::SPLIT_FINGERPRINT_KEY): fingerprint }),
            ..TrainingProvenance::default()
        };
        let own = recording(&split.fingerprint());
        assert_eq!(
            Split::read_for_model(&model, &own, &spec, "h").unwrap(),
            split
        );
        let err = Split::read_for_model(&model, &recording(&other.fingerprint()), &spec, "h")
            .unwrap_err();
        assert!(
            matches!(err, Error::Split { .. }) && err.to_string().contains("not the split"),
            "{err}"
        );
        // A model written before the fingerprint was recorded reads its split as before.
        let legacy = TrainingProvenance::default();
        assert_eq!(
            Split::read_for_model(&model, &legacy, &spec, "h").unwrap(),
            split
        );
    }

    #[test]
    fn a_tampered_split_file_is_refused() {
        let (spec, keys) = (spec(6, 30), all_keys(6, 30));
        let mut split = Split::new(&spec, &settled(&keys), "h", &config()).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("split.json");
        split.write(&path).unwrap();
        assert_eq!(Split::read(&path, "h").unwrap(), split);
        assert!(matches!(
            Split::read(&path, "other"),
            Err(Error::Split { .. })
        ));
        split.train.push(split.test[0]);
        split.write(&path).unwrap();
        assert!(matches!(Split::read(&path, "h"), Err(Error::Split { .. })));
    }
}
