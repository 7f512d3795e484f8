//! Fine-tuning: a run that starts from a trained model's weights and output normalisers
//! ([`TrainConfig::init_from`](crate::TrainConfig::init_from)) instead of fresh ones, so new
//! data (poses a dataset held few of) can be taught to a model without re-draping the data it
//! was trained on.

use std::path::{Path, PathBuf};

use burn::prelude::*;
use garmatnet_core::TemplateInfo;
use garmatnet_model::{GarMatNetConfig, GarMatNetModel, MaterialRange, TrainingFabric};

use crate::error::{Error, Result};

/// The model a run starts from, checked against the run.
pub(crate) struct StartingModel {
    /// Where it was read from.
    pub(crate) path: PathBuf,
    /// Its [`GarMatNetModel::weights_fingerprint`] (as read, before the run's dropout): a
    /// resumed run must start from the same model, not from whatever lies at the path by then.
    pub(crate) fingerprint: String,
    /// Its nets (on the training device, with the run's dropout), normalisers and metadata.
    pub(crate) model: GarMatNetModel,
}

/// The architecture settings of a net config, by name, for comparison and messages (the
/// dropout, a training setting, is left out).
fn architecture(c: &GarMatNetConfig) -> [(&'static str, String); 7] {
    [
        ("vertex_count", c.vertex_count.to_string()),
        (
            "hidden",
            format!("{},{},{}", c.pose_hidden, c.material_hidden, c.hidden),
        ),
        (
            "rank",
            c.output_rank
                .map_or_else(|| "none (full head)".to_owned(), |k| k.to_string()),
        ),
        ("alpha", c.alpha.to_string()),
        ("scale_free_material", c.scale_free_material.to_string()),
        ("pose_encoding", format!("{:?}", c.pose_encoding)),
        ("frame", format!("{:?}", c.displacement_frame)),
    ]
}

impl StartingModel {
    /// Reads the model at `path` onto `device`, checks that it predicts `template` with the
    /// architecture of `net_config` (every setting but the dropout, which is `net_config`'s
    /// from then on).
    ///
    /// # Errors
    /// [`Error::Io`] if the file cannot be read; the model file's own errors
    /// ([`Error::Model`]), [`garmatnet_model::Error::TemplateMismatch`] among them for another
    /// garment; [`Error::InvalidConfig`] for another architecture, naming what differs.
    pub(crate) fn load(
        path: &Path,
        template: &TemplateInfo,
        net_config: &GarMatNetConfig,
        device: &Device,
    ) -> Result<Self> {
        let mut model = GarMatNetModel::load(path, device).map_err(|e| match e {
            garmatnet_model::Error::Io { path, source } => Error::Io { path, source },
            e => e.into(),
        })?;
        let fingerprint = model.weights_fingerprint();
        model.ensure_template(&template.hash, template.vertex_count)?;
        for (name, net) in [("fitting", &model.fitting), ("local", &model.local)] {
            let differ: Vec<String> = architecture(net.config())
                .into_iter()
                .zip(architecture(net_config))
                .filter(|(a, b)| a.1 != b.1)
                .map(|((field, theirs), (_, ours))| {
                    format!("{field}: the model's {theirs}, this run's {ours}")
                })
                .collect();
            if !differ.is_empty() {
                return Err(Error::InvalidConfig(format!(
                    "the model to start from, `{}`, has a {name} net of another architecture \
                     ({}): train with its settings (`train --init-from` takes those no flag \
                     sets from the model)",
                    path.display(),
                    differ.join("; ")
                )));
            }
        }
        model.fitting = model.fitting.with_dropout(net_config.dropout);
        model.local = model.local.with_dropout(net_config.dropout);
        Ok(Self {
            path: path.to_owned(),
            fingerprint,
            model,
        })
    }

    /// Refuses a split that tests, as fabrics never trained on, fabrics the starting model
    /// trained on: its figures would not be about unseen fabrics.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] naming them.
    pub(crate) fn check_unseen(&self, test_materials: &[String]) -> Result<()> {
        let learned = &self.model.meta.provenance.training_fabrics;
        let seen: Vec<&str> = test_materials
            .iter()
            .map(String::as_str)
            .filter(|name| learned.iter().any(|f| f.name == *name))
            .collect();
        if seen.is_empty() {
            return Ok(());
        }
        Err(Error::InvalidConfig(format!(
            "the model to start from, `{}`, trained on {}, which this split tests as unseen \
             fabrics: choose other `--test-materials` (or `none`)",
            self.path.display(),
            seen.join(", ")
        )))
    }

    /// What the fine-tuned model's provenance records about where it started.
    pub(crate) fn provenance_note(&self) -> serde_json::Value {
        let p = &self.model.meta.provenance;
        serde_json::json!({
            "path": self.path,
            "weights_fingerprint": self.fingerprint,
            "dataset_hash": p.dataset_hash,
            "command": p.command,
            "epochs": p.epochs,
            "training_fabrics": p.training_fabrics.len(),
        })
    }

    /// The fabrics the fine-tuned model has learned: the starting model's, then this run's
    /// that it lacks, in the run's order.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] for a fabric of this run named as one of the starting
    /// model's with another ω (a model file names each fabric once).
    pub(crate) fn merged_fabrics(&self, run: Vec<TrainingFabric>) -> Result<Vec<TrainingFabric>> {
        let mut all = self.model.meta.provenance.training_fabrics.clone();
        for fabric in run {
            match all.iter().find(|f| f.name == fabric.name) {
                Some(f) if f.omega == fabric.omega => {}
                Some(f) => {
                    return Err(Error::InvalidConfig(format!(
                        "the dataset's fabric `{}` (normalised ω {:?}) is not the fabric of \
                         that name the model to start from, `{}`, trained on (ω {:?}): rename \
                         one of them",
                        fabric.name,
                        fabric.omega,
                        self.path.display(),
                        f.omega
                    )));
                }
                None => all.push(fabric),
            }
        }
        Ok(all)
    }

    /// The box of every material the fine-tuned model has learned: the union of the starting
    /// model's and this run's.
    pub(crate) fn merged_range(&self, run: Option<MaterialRange>) -> Option<MaterialRange> {
        let corners = |r: MaterialRange| [r.min, r.max];
        MaterialRange::of(
            self.model
                .meta
                .provenance
                .material_range
                .into_iter()
                .chain(run)
                .flat_map(corners),
        )
    }
}

#[cfg(test)]
mod tests {
    use garmatnet_model::GarMatNetModel;

    use crate::test_util::{synthetic_dataset, training_lock};
    use crate::training::train_config::{RunOptions, TrainConfig};
    use crate::training::trainer::{tests::tiny_config, train};
    use crate::{Error, TrainSummary};

    use super::*;

    /// A synthetic dataset in a fresh directory and a model trained on it for `epochs`: the
    /// directory (kept alive), the dataset, the model file and its training summary.
    fn first_model(epochs: usize) -> (tempfile::TempDir, PathBuf, PathBuf, TrainSummary) {
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 6, 20);
        let first = dir.path().join("first.safetensors");
        let summary = train(&data, &first, &tiny_config(epochs), &RunOptions::default()).unwrap();
        (dir, data, first, summary)
    }

    #[test]
    fn a_fine_tuning_run_starts_where_its_model_left_off_and_keeps_no_worse_weights() {
        let _serial = training_lock();
        let (dir, data, first, s1) = first_model(15);
        let tuned = dir.path().join("tuned.safetensors");
        let config = TrainConfig {
            init_from: Some(first.clone()),
            learning_rate: 3e-4,
            ..tiny_config(4)
        };
        let s2: TrainSummary = train(&data, &tuned, &config, &RunOptions::default()).unwrap();
        assert!(s2.finished);
        // Same dataset, split and normalisers: the fine-tuning run's untrained dev loss is
        // the first model's kept dev loss, for each net.
        for (a, b) in [(&s1.fitting, &s2.fitting), (&s1.local, &s2.local)] {
            let (a, b) = (a.as_ref().unwrap(), b.as_ref().unwrap());
            assert!(
                (b.initial_dev_mse - a.best_dev_mse).abs() <= 1e-5 * a.best_dev_mse,
                "started at {} against the model's {}",
                b.initial_dev_mse,
                a.best_dev_mse
            );
            // The starting weights compete: nothing worse than them is kept; the loaded
            // weights train (15 epochs did not finish the toy problem).
            assert!(b.best_dev_mse < b.initial_dev_mse, "{b:?}");
            assert!(b.best_epoch > 0);
        }
        let first_model = GarMatNetModel::load(&first, &Device::flex()).unwrap();
        let model = GarMatNetModel::load(&tuned, &Device::flex()).unwrap();
        let p = &model.meta.provenance;
        assert_eq!(
            p.extra["init_from"]["path"],
            serde_json::json!(first),
            "the provenance names the starting model"
        );
        assert_eq!(
            p.training_fabrics,
            first_model.meta.provenance.training_fabrics
        );
        assert_eq!(p.material_range, first_model.meta.provenance.material_range);
        assert_eq!(model.fitting_norm, first_model.fitting_norm);
        // A fresh run records no starting model.
        assert!(first_model.meta.provenance.extra.get("init_from").is_none());
    }

    #[test]
    fn a_model_of_another_architecture_or_a_missing_file_is_refused_before_training() {
        let _serial = training_lock();
        let (dir, data, first, _) = first_model(2);
        let wider = TrainConfig {
            init_from: Some(first),
            hidden: 48,
            ..tiny_config(2)
        };
        let out = dir.path().join("wider.safetensors");
        match train(&data, &out, &wider, &RunOptions::default()) {
            Err(Error::InvalidConfig(m)) => {
                assert!(
                    m.contains("hidden: the model's 32,16,32, this run's 32,16,48"),
                    "{m}"
                );
            }
            other => panic!("expected InvalidConfig, got {other:?}"),
        }
        let missing = TrainConfig {
            init_from: Some(dir.path().join("nowhere.safetensors")),
            ..tiny_config(2)
        };
        assert!(matches!(
            train(&data, &out, &missing, &RunOptions::default()),
            Err(Error::Io { .. })
        ));
        assert!(!out.exists(), "no model is written");
    }

    #[test]
    fn the_runs_dropout_applies_and_a_split_testing_learned_fabrics_is_refused() {
        let _serial = training_lock();
        let (dir, data, first, _) = first_model(2);
        // Another dropout than the model trained with (tiny_config's 0) is the run's.
        let tuned = dir.path().join("tuned.safetensors");
        let config = TrainConfig {
            init_from: Some(first.clone()),
            dropout: 0.25,
            ..tiny_config(1)
        };
        train(&data, &tuned, &config, &RunOptions::default()).unwrap();
        let model = GarMatNetModel::load(&tuned, &Device::flex()).unwrap();
        assert_eq!(model.fitting.config().dropout, 0.25);
        assert_eq!(model.local.config().dropout, 0.25);
        // "Fabric 3" trained the first model: testing it as unseen would not be.
        let mut leaky = tiny_config(1);
        leaky.init_from = Some(first.clone());
        leaky.split.test_materials = vec!["Fabric 3".into(), "Fabric 4".into()];
        match train(
            &data,
            &dir.path().join("leaky.safetensors"),
            &leaky,
            &RunOptions::default(),
        ) {
            Err(Error::InvalidConfig(m)) => assert!(m.contains("Fabric 3, Fabric 4"), "{m}"),
            other => panic!("expected InvalidConfig, got {other:?}"),
        }
        // A fabric of the model's name with another ω cannot be recorded beside it.
        let net_config = tiny_config(1).net_config(model.vertex_count());
        let start = StartingModel::load(&first, &model.meta.template, &net_config, &Device::flex())
            .unwrap();
        let mut clash = start.model.meta.provenance.training_fabrics[0].clone();
        clash.omega[0] = (clash.omega[0] + 0.5) % 1.0;
        assert!(matches!(
            start.merged_fabrics(vec![clash]),
            Err(Error::InvalidConfig(_))
        ));
    }

    #[test]
    fn a_fine_tuning_run_resumes_only_from_the_same_starting_model() {
        let _serial = training_lock();
        let (dir, data, first, _) = first_model(2);
        let tuned = dir.path().join("tuned.safetensors");
        let config = TrainConfig {
            init_from: Some(first.clone()),
            ..tiny_config(3)
        };
        let pause = RunOptions {
            stop_after_epochs: Some(2),
            ..RunOptions::default()
        };
        assert!(!train(&data, &tuned, &config, &pause).unwrap().finished);
        // Another model at the same path: the checkpoint is not its fine-tuning.
        let other = TrainConfig {
            seed: 7,
            ..tiny_config(2)
        };
        train(&data, &first, &other, &RunOptions::default()).unwrap();
        let resume = RunOptions {
            resume: true,
            ..RunOptions::default()
        };
        assert!(matches!(
            train(&data, &tuned, &config, &resume),
            Err(Error::Checkpoint { .. })
        ));
    }
}
