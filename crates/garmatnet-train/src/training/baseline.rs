//! The paper's baseline (§4.1): TailorNet-style nets without the material input, one pair
//! (fitting + local) per target material, trained only on that material's samples.
//!
//! Per target material the held-out poses are test; the material's remaining samples are
//! split 90/10 into train/dev with the same seeded shuffle rule as GarMatNet's split.
//!
//! **Replication** (the paper's "we replicate the remaining data 67 times"): one baseline
//! epoch makes `k` shuffled passes over the material's training samples — the index list is
//! repeated `k` times and shuffled as one — so that an epoch sees about as many instances as
//! a GarMatNet epoch. By default `k = max(1, round(N_garmatnet_train / N_material_train))`.
//! Early stopping checks the dev loss once per (replicated) epoch.
//!
//! # Directory layout
//! `baseline.json` ([`BaselineManifest`]: configs, normalisers, splits) and per material
//! `m{index}-fitting.bpk`, `m{index}-local.bpk` (Burn burnpack records).

use std::path::{Path, PathBuf};

use burn::module::Module;
use burn::prelude::*;
use burn::store::ModuleRecord;
use burn::tensor::Bytes;
use garmatnet_core::{POSE_DIM, SplitMix64};
use garmatnet_model::{BaselineNet, BaselineNetConfig, OutputNormalizer, select_device};
use serde::{Deserialize, Serialize};

use crate::data::loader::{SampleKey, TrainingDataset};
use crate::data::split::Split;
use crate::data::split_config::SplitConfig;
use crate::error::{Error, Result};
use crate::training::train_config::{LoopConfig, TrainConfig, check_loop_settings};
use crate::training::trainer::NetSummary;
use crate::training::training_loop::{
    DeviceSet, LearningRateSchedule, LoopSettings, NetSets, Outcome, fit_net, fit_normalizer,
};

/// The baseline format version.
pub const BASELINE_VERSION: u32 = 1;

/// The manifest file in a baseline directory.
pub const BASELINE_MANIFEST: &str = "baseline.json";

/// Settings of a baseline training run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct BaselineConfig {
    /// Seed of weights and shuffles.
    pub seed: u64,
    /// Adam's learning rate (at the first epoch).
    pub learning_rate: f64,
    /// How the learning rate changes over each net's epochs.
    pub learning_rate_schedule: LearningRateSchedule,
    /// Mini-batch size.
    pub batch_size: usize,
    /// The most epochs per net.
    pub max_epochs: usize,
    /// Early-stopping patience of the fitting net.
    pub patience_fitting: usize,
    /// Early-stopping patience of the local net.
    pub patience_local: usize,
    /// Width of the first hidden layer.
    pub pose_hidden: usize,
    /// Width of the second hidden layer.
    pub hidden: usize,
    /// Dropout probability.
    pub dropout: f64,
    /// Decoupled weight decay (AdamW); `0` (default): plain Adam. Not written at its
    /// default.
    #[serde(skip_serializing_if = "crate::training::train_config::is_zero")]
    pub weight_decay: f64,
    /// Passes over a material's training samples per epoch; `None`: match GarMatNet's
    /// training-set size (see the module docs).
    pub replicate: Option<usize>,
    /// The split (target materials, held-out poses, dev fraction), as for GarMatNet.
    pub split: SplitConfig,
    /// Accept a dataset with missing samples.
    pub allow_incomplete_dataset: bool,
    /// Compute device.
    pub device: String,
    /// No progress: neither the bar on a terminal nor, elsewhere, the progress lines (one a
    /// minute; `GARMATNET_PROGRESS_SECS` sets the interval).
    pub quiet: bool,
}

impl Default for BaselineConfig {
    fn default() -> Self {
        Self::from_train_config(&TrainConfig::default())
    }
}

impl BaselineConfig {
    /// The same hyperparameters as a GarMatNet run (the paper tunes them once for both).
    #[must_use]
    pub fn from_train_config(c: &TrainConfig) -> Self {
        Self {
            seed: c.seed,
            learning_rate: c.learning_rate,
            learning_rate_schedule: c.learning_rate_schedule,
            batch_size: c.batch_size,
            max_epochs: c.max_epochs,
            patience_fitting: c.patience_fitting,
            patience_local: c.patience_local,
            pose_hidden: c.pose_hidden,
            hidden: c.hidden,
            dropout: c.dropout,
            weight_decay: c.weight_decay,
            replicate: None,
            split: c.split.clone(),
            allow_incomplete_dataset: c.allow_incomplete_dataset,
            device: c.device.clone(),
            quiet: c.quiet,
        }
    }
}

impl BaselineConfig {
    /// Checks the loop settings as [`TrainConfig::validate`] does (learning rate, batch size,
    /// epochs, patience, weight decay) and the replication; the net's sizes are checked when
    /// it is built.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] naming the field.
    pub fn validate(&self) -> Result<()> {
        check_loop_settings(&LoopConfig {
            learning_rate: self.learning_rate,
            batch_size: self.batch_size,
            max_epochs: self.max_epochs,
            patience_fitting: self.patience_fitting,
            patience_local: self.patience_local,
            weight_decay: self.weight_decay,
        })?;
        if self.replicate == Some(0) {
            return Err(Error::InvalidConfig(
                "replicate = 0: an epoch needs at least one pass over the training samples \
                 (or leave it unset to match GarMatNet's training-set size)"
                    .into(),
            ));
        }
        Ok(())
    }
}

/// One material's entry in `baseline.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BaselineMaterialEntry {
    /// The material's name.
    pub name: String,
    /// Its index in the dataset.
    pub material: usize,
    /// Weight file of the fitting net.
    pub fitting_file: String,
    /// Weight file of the local net.
    pub local_file: String,
    /// The fitting net's output normaliser.
    pub fitting_norm: OutputNormalizer,
    /// The local net's output normaliser.
    pub local_norm: OutputNormalizer,
    /// Passes per epoch used.
    pub replicate: usize,
    /// Training, dev and test sample counts.
    pub samples: [usize; 3],
    /// The fitting net's training.
    pub fitting: NetSummary,
    /// The local net's training.
    pub local: NetSummary,
}

/// `baseline.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BaselineManifest {
    /// [`BASELINE_VERSION`].
    pub version: u32,
    /// The dataset fingerprint.
    pub dataset_hash: String,
    /// The garment template hash.
    pub template_hash: String,
    /// The template's vertex count n.
    pub vertex_count: usize,
    /// The net configuration (shared by all materials).
    pub net: BaselineNetConfig,
    /// The training settings.
    pub config: BaselineConfig,
    /// One entry per target material.
    pub materials: Vec<BaselineMaterialEntry>,
}

/// A loaded per-material baseline pair.
#[derive(Debug, Clone)]
pub struct BaselineMaterial {
    /// The material's index in the dataset.
    pub material: usize,
    /// The material's name.
    pub name: String,
    /// The fitting net (plain device).
    pub fitting: BaselineNet,
    /// The local net.
    pub local: BaselineNet,
    /// The fitting net's normaliser.
    pub fitting_norm: OutputNormalizer,
    /// The local net's normaliser.
    pub local_norm: OutputNormalizer,
}

/// A loaded baseline directory.
#[derive(Debug, Clone)]
pub struct Baseline {
    /// `baseline.json`.
    pub manifest: BaselineManifest,
    /// The nets, in manifest order.
    pub materials: Vec<BaselineMaterial>,
}

/// Trains one baseline pair per target material and writes them to `out_dir`.
///
/// # Errors
/// As [`crate::train`]; [`Error::InvalidConfig`] if a material has fewer than two
/// non-held-out samples.
pub fn train_baseline(
    data_dir: &Path,
    out_dir: &Path,
    config: &BaselineConfig,
) -> Result<BaselineManifest> {
    config.validate()?;
    let data = TrainingDataset::open(data_dir, config.allow_incomplete_dataset)?;
    let keys = data.keys();
    let split = data.split(&config.split)?;
    if split.test_materials.is_empty() {
        return Err(Error::InvalidConfig(
            "the baseline trains one net pair per target material, and the split has none; \
             name the target materials (e.g. the paper's four, the default)"
                .into(),
        ));
    }
    let device = select_device(&config.device)?;
    let ad = device.clone().autodiff();
    let n = data.vertex_count();
    let net =
        BaselineNetConfig::new(n, config.pose_hidden, config.hidden).with_dropout(config.dropout);
    net.validate()?;
    let _lock = crate::data::loader::create_locked_dir(out_dir, "baseline")?;
    let progress = crate::training::training_loop::epoch_progress(config.max_epochs, config.quiet);
    let mut entries = Vec::new();
    for &m in &split.test_materials {
        let name = data.spec().materials[m].name.clone();
        let mut own: Vec<SampleKey> = keys
            .iter()
            .copied()
            .filter(|k| {
                k.material == m
                    && split.held_out_poses.binary_search(&k.pose).is_err()
                    && split.is_settled(k)
            })
            .collect();
        if own.len() < 2 {
            return Err(Error::InvalidConfig(format!(
                "baseline material `{name}` has {} settled samples outside the held-out poses; \
                 at least 2 are needed",
                own.len()
            )));
        }
        // The development samples: the material's own at the split's development poses
        // (`--dev-frames`), else a seeded random fraction of them.
        let (mut train, mut dev): (Vec<SampleKey>, Vec<SampleKey>) = if split.dev_poses.is_empty() {
            SplitMix64::new(config.split.seed ^ m as u64).shuffle(&mut own);
            let dev_count =
                ((own.len() as f64 * config.split.dev_fraction).round() as usize).max(1);
            let dev = own.split_off(own.len() - dev_count);
            (own, dev)
        } else {
            own.into_iter()
                .partition(|k| split.dev_poses.binary_search(&k.pose).is_err())
        };
        if train.is_empty() || dev.is_empty() {
            return Err(Error::InvalidConfig(format!(
                "baseline material `{name}` has {} training and {} development samples; \
                 both need at least one",
                train.len(),
                dev.len()
            )));
        }
        train.sort();
        dev.sort();
        let test_count = keys
            .iter()
            .filter(|k| k.material == m && split.held_out_poses.binary_search(&k.pose).is_ok())
            .count();
        let replicate = config.replicate.unwrap_or_else(|| {
            ((split.train.len() as f64 / train.len() as f64).round() as usize).max(1)
        });
        let frame = garmatnet_core::DisplacementFrame::World;
        let train_set = data.load(&train, frame)?;
        let dev_set = data.load(&dev, frame)?;
        let mut trained = Vec::new();
        for (part, labels_train, labels_dev, patience) in [
            (
                "fitting",
                &train_set.d_fitting,
                &dev_set.d_fitting,
                config.patience_fitting,
            ),
            (
                "local",
                &train_set.d_local,
                &dev_set.d_local,
                config.patience_local,
            ),
        ] {
            let norm = fit_normalizer(labels_train, 3 * n)?;
            let sets = NetSets {
                train: DeviceSet::new(
                    &train_set.poses,
                    &train_set.materials,
                    labels_train,
                    &norm,
                    &ad,
                ),
                dev: DeviceSet::new(
                    &dev_set.poses,
                    &dev_set.materials,
                    labels_dev,
                    &norm,
                    &device,
                ),
            };
            let seed = config.seed
                ^ (m as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15)
                ^ u64::from(part == "local");
            ad.seed(seed);
            let settings = LoopSettings {
                keep_start: false,
                name: format!("baseline {name} {part}"),
                learning_rate: config.learning_rate,
                schedule: config.learning_rate_schedule,
                batch_size: config.batch_size,
                max_epochs: config.max_epochs,
                patience,
                weight_decay: config.weight_decay,
                replicate,
                seed,
            };
            let Outcome::Done(best, progress_state) =
                fit_net(net.init(&ad), &sets, &settings, None, &mut None, &progress)?
            else {
                unreachable!("a run without an epoch budget always finishes");
            };
            let file = format!("m{m:03}-{part}.bpk");
            write_net(&out_dir.join(&file), &best)?;
            trained.push((file, norm, NetSummary::from(&progress_state)));
        }
        let (local_file, local_norm, local) = trained.pop().expect("two nets were trained");
        let (fitting_file, fitting_norm, fitting) = trained.pop().expect("two nets were trained");
        entries.push(BaselineMaterialEntry {
            name,
            material: m,
            fitting_file,
            local_file,
            fitting_norm,
            local_norm,
            replicate,
            samples: [train.len(), dev.len(), test_count],
            fitting,
            local,
        });
    }
    progress.finish();
    let manifest = BaselineManifest {
        version: BASELINE_VERSION,
        dataset_hash: data.dataset_hash().to_owned(),
        template_hash: data.template_hash().to_owned(),
        vertex_count: n,
        net,
        config: config.clone(),
        materials: entries,
    };
    let json = serde_json::to_vec_pretty(&manifest).map_err(|source| Error::Serialize {
        what: "the baseline manifest",
        source,
    })?;
    let manifest_path = out_dir.join(BASELINE_MANIFEST);
    garmatnet_core::write_bytes_atomic(&manifest_path, &json)?;
    crate::data::files::make_readable(&manifest_path);
    Ok(manifest)
}

impl Baseline {
    /// Loads a baseline directory and checks it against a model's `split` of `data`
    /// ([`Baseline::load`], then [`Baseline::check_compatible`]): what `eval` and `bench`
    /// do before computing or writing anything.
    ///
    /// # Errors
    /// As the two.
    pub fn load_for(
        dir: &Path,
        device: &Device,
        data: &TrainingDataset,
        split: &Split,
    ) -> Result<Self> {
        let baseline = Self::load(dir, device)?;
        baseline.check_compatible(data, split)?;
        Ok(baseline)
    }

    /// Loads a baseline directory written by [`train_baseline`].
    ///
    /// # Errors
    /// [`Error::Io`] if `baseline.json` cannot be read; [`Error::Checkpoint`] for a corrupt
    /// manifest or weight file: an invalid net configuration, a normaliser that is not
    /// finite, has a negative std or not 3 values per template vertex.
    pub fn load(dir: &Path, device: &Device) -> Result<Self> {
        let path = dir.join(BASELINE_MANIFEST);
        let bytes = std::fs::read(&path).map_err(|e| Error::io(&path, e))?;
        let corrupt = |message: String| Error::Checkpoint {
            path: path.clone(),
            message,
        };
        let manifest: BaselineManifest = serde_json::from_slice(&bytes)
            .map_err(|e| corrupt(format!("bad baseline.json: {e}")))?;
        if manifest.version != BASELINE_VERSION {
            return Err(corrupt(format!("version {}", manifest.version)));
        }
        // The net is built from the stored configuration before its weights are loaded, and
        // the normalisers de-normalise 3n values: check both, or a hand-edited manifest
        // panics (or silently mis-scales) far from here.
        let net = &manifest.net;
        net.validate()
            .map_err(|e| corrupt(format!("the stored net configuration: {e}")))?;
        let n = manifest.vertex_count;
        if net.vertex_count != n || net.pose_dim != POSE_DIM {
            return Err(corrupt(format!(
                "the stored net has {} vertices and a {}-value pose input, but the baseline's \
                 template has {n} vertices and poses have {POSE_DIM} values; train the \
                 baseline again",
                net.vertex_count, net.pose_dim
            )));
        }
        // Deserialising already validated each normaliser (`OutputNormalizer::from_parts`);
        // what it cannot know is the template's size.
        let checked_norm = |e: &BaselineMaterialEntry, part: &str, norm: &OutputNormalizer| {
            if norm.dim() != 3 * n {
                return Err(corrupt(format!(
                    "`{}` {part} normaliser has {} values, the template's {n} vertices need {}; \
                     train the baseline again",
                    e.name,
                    norm.dim(),
                    3 * n
                )));
            }
            Ok(norm.clone())
        };
        let mut materials = Vec::new();
        for e in &manifest.materials {
            let fitting_norm = checked_norm(e, "fitting", &e.fitting_norm)?;
            let local_norm = checked_norm(e, "local", &e.local_norm)?;
            let load = |file: &str| -> Result<BaselineNet> {
                let p: PathBuf = dir.join(file);
                let bytes = std::fs::read(&p).map_err(|err| Error::io(&p, err))?;
                let record = ModuleRecord::from_bytes(Bytes::from_bytes_vec(bytes))
                    .map_err(|err| corrupt(format!("{file}: {err}")))?;
                manifest
                    .net
                    .init(device)
                    .try_load_record(record)
                    .map_err(|err| corrupt(format!("{file}: {err}")))
            };
            materials.push(BaselineMaterial {
                material: e.material,
                name: e.name.clone(),
                fitting: load(&e.fitting_file)?.valid(),
                local: load(&e.local_file)?.valid(),
                fitting_norm,
                local_norm,
            });
        }
        Ok(Self {
            manifest,
            materials,
        })
    }

    /// Checks that this baseline can be compared with a model on `split` of the dataset
    /// `data`: same garment template, same dataset and the same held-out poses (a baseline
    /// trained with other held-out poses may have trained on the comparison samples), and a
    /// net for every target material of the split (so both are measured on the same
    /// samples; a split without target materials tests every fabric and cannot be compared).
    ///
    /// # Errors
    /// [`Error::Dataset`] saying what differs and how to retrain.
    pub fn check_compatible(&self, data: &TrainingDataset, split: &Split) -> Result<()> {
        let mismatch = |message: String| Error::Dataset {
            dir: data.dir().to_owned(),
            message,
        };
        if self.manifest.template_hash != data.template_hash()
            || self.manifest.vertex_count != data.vertex_count()
        {
            return Err(mismatch(
                "the baseline was trained for another garment template".into(),
            ));
        }
        let (theirs, ours) = (&self.manifest.config.split, &split.config);
        if self.manifest.dataset_hash != data.dataset_hash()
            || (theirs.held_out_frame_every, theirs.held_out_block)
                != (ours.held_out_frame_every, ours.held_out_block)
        {
            return Err(mismatch(format!(
                "the baseline was trained on dataset {} holding out {}, the model's split is \
                 of dataset {} holding out {}: it may have trained on the poses it would be \
                 tested on; train the baseline on this dataset with the model's --held-out",
                self.manifest.dataset_hash,
                theirs.held_out_rule(),
                data.dataset_hash(),
                ours.held_out_rule()
            )));
        }
        // Table 2 sets the baseline's error beside GarMatNet's on the same samples, so it
        // needs a net for every fabric the split tests (else its row would be an average
        // over fewer fabrics than GarMatNet's).
        let names = |materials: &mut dyn Iterator<Item = usize>| {
            materials
                .map(|m| data.spec().materials[m].name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let trained = names(&mut self.materials.iter().map(|m| m.material));
        if split.test_materials.is_empty() {
            return Err(mismatch(format!(
                "the model's split holds out no target fabric (it trained on every fabric), so \
                 every fabric is tested at the held-out poses, and the baseline has nets for \
                 {trained} only; compare with a model trained with target materials, or leave \
                 out the baseline"
            )));
        }
        let missing: Vec<usize> = split
            .test_materials
            .iter()
            .copied()
            .filter(|m| !self.materials.iter().any(|b| b.material == *m))
            .collect();
        if !missing.is_empty() {
            return Err(mismatch(format!(
                "the baseline has no net for the model's target material(s) {} (it has {trained}); \
                 train the baseline with the model's --test-materials",
                names(&mut missing.iter().copied())
            )));
        }
        Ok(())
    }
}

fn write_net(path: &Path, net: &BaselineNet) -> Result<()> {
    let bytes = net
        .clone()
        .into_record()
        .into_bytes()
        .map_err(|e| Error::Checkpoint {
            path: path.to_owned(),
            message: format!("cannot encode the baseline net: {e}"),
        })?;
    garmatnet_core::write_bytes_atomic(path, &bytes)?;
    crate::data::files::make_readable(path);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{synthetic_dataset, training_lock};
    use crate::training::trainer::tests::tiny_config;

    /// A baseline directory of one material with untrained nets for a 3-vertex template,
    /// written without training, and its manifest as JSON.
    fn hand_written_baseline(dir: &Path) -> serde_json::Value {
        let net = BaselineNetConfig::new(3, 4, 4);
        let device = select_device("cpu").unwrap();
        for part in ["fitting", "local"] {
            write_net(&dir.join(format!("m000-{part}.bpk")), &net.init(&device)).unwrap();
        }
        let summary = NetSummary {
            epochs: 1,
            best_epoch: 1,
            best_dev_mse: 0.5,
            initial_dev_mse: 1.0,
            last_train_mse: 0.5,
            seconds_per_epoch: 0.1,
        };
        let manifest = BaselineManifest {
            version: BASELINE_VERSION,
            dataset_hash: "d".into(),
            template_hash: "t".into(),
            vertex_count: 3,
            net,
            config: BaselineConfig::default(),
            materials: vec![BaselineMaterialEntry {
                name: "Linen".into(),
                material: 0,
                fitting_file: "m000-fitting.bpk".into(),
                local_file: "m000-local.bpk".into(),
                fitting_norm: OutputNormalizer::identity(9),
                local_norm: OutputNormalizer::identity(9),
                replicate: 1,
                samples: [2, 1, 1],
                fitting: summary.clone(),
                local: summary,
            }],
        };
        serde_json::to_value(&manifest).unwrap()
    }

    #[test]
    fn an_edited_baseline_manifest_is_refused_not_a_panic() {
        let dir = tempfile::tempdir().unwrap();
        let good = hand_written_baseline(dir.path());
        let device = select_device("cpu").unwrap();
        let load = |manifest: &serde_json::Value| {
            std::fs::write(
                dir.path().join(BASELINE_MANIFEST),
                serde_json::to_vec(manifest).unwrap(),
            )
            .unwrap();
            Baseline::load(dir.path(), &device)
        };
        let loaded = load(&good).unwrap();
        assert_eq!(loaded.materials[0].fitting_norm.dim(), 9);
        let edited = |edit: &dyn Fn(&mut serde_json::Value)| {
            let mut manifest = good.clone();
            edit(&mut manifest);
            manifest
        };
        let norm = |v: &mut serde_json::Value| v["materials"][0]["local_norm"].take();
        for (bad, expect) in [
            (
                edited(&|m| m["net"]["hidden"] = 0.into()),
                "net configuration",
            ),
            (
                edited(&|m| m["net"]["dropout"] = 1.5.into()),
                "net configuration",
            ),
            (
                edited(&|m| m["net"]["vertex_count"] = 4.into()),
                "4 vertices",
            ),
            (
                edited(&|m| m["net"]["pose_dim"] = 73.into()),
                "73-value pose",
            ),
            (
                edited(&|m| {
                    norm(m);
                    m["materials"][0]["local_norm"] =
                        serde_json::json!({ "mean": [0.0, 0.0, 0.0], "std": [1.0, 1.0, 1.0] });
                }),
                "local normaliser has 3 values",
            ),
            (
                edited(&|m| m["materials"][0]["fitting_norm"]["std"][4] = (-1.0).into()),
                "normaliser std",
            ),
            (
                edited(&|m| {
                    m["materials"][0]["fitting_norm"]["mean"] = serde_json::json!(vec![0.0; 8]);
                }),
                "std",
            ),
        ] {
            let err = load(&bad).unwrap_err();
            let text = err.to_string();
            assert!(matches!(err, Error::Checkpoint { .. }), "{text}");
            assert!(text.contains(expect), "{expect:?} not in {text}");
        }
    }

    #[test]
    fn a_baseline_config_with_zero_patience_or_replication_is_refused() {
        for bad in [
            BaselineConfig {
                patience_fitting: 0,
                ..BaselineConfig::default()
            },
            BaselineConfig {
                patience_local: 0,
                ..BaselineConfig::default()
            },
            BaselineConfig {
                replicate: Some(0),
                ..BaselineConfig::default()
            },
            BaselineConfig {
                learning_rate: f64::NAN,
                ..BaselineConfig::default()
            },
        ] {
            assert!(
                matches!(bad.validate(), Err(Error::InvalidConfig(_))),
                "{bad:?}"
            );
            // Refused before the dataset is even opened.
            let dir = tempfile::tempdir().unwrap();
            let err = train_baseline(&dir.path().join("none"), dir.path(), &bad).unwrap_err();
            assert!(matches!(err, Error::InvalidConfig(_)), "{err}");
        }
        BaselineConfig::default().validate().unwrap();
    }

    #[test]
    fn the_baseline_takes_its_development_samples_at_the_dev_frames() {
        let _serial = training_lock();
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 4, 20);
        let mut config = BaselineConfig {
            max_epochs: 1,
            ..BaselineConfig::from_train_config(&tiny_config(1))
        };
        // Every 5th frame tested: 16 own poses per target, 2 of them (10 %) random dev.
        config.split.held_out_frame_every = 5;
        let random = train_baseline(&data, &dir.path().join("random"), &config).unwrap();
        assert!(
            random.materials.iter().all(|m| m.samples == [14, 2, 4]),
            "{random:?}"
        );
        // Frames 3, 8, 13, 18 are the development poses: 4 of each target's 16.
        config.split.dev_frame_offset = Some(3);
        let by_pose = train_baseline(&data, &dir.path().join("poses"), &config).unwrap();
        assert!(
            by_pose.materials.iter().all(|m| m.samples == [12, 4, 4]),
            "{by_pose:?}"
        );
    }
}
