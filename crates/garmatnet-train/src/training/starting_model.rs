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
    /// Its nets (on the training device), normalisers and metadata.
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
    /// Reads the model at `path` onto `device` and checks that it predicts `template` with
    /// the architecture of `net_config` (every setting but the dropout).
    ///
    /// # Errors
    /// The model file's own errors ([`Error::Model`]); [`Error::InvalidConfig`] for another
    /// template or another architecture, naming what differs.
    pub(crate) fn load(
        path: &Path,
        template: &TemplateInfo,
        net_config: &GarMatNetConfig,
        device: &Device,
    ) -> Result<Self> {
        let model = GarMatNetModel::load(path, device)?;
        if model.meta.template != *template {
            return Err(Error::InvalidConfig(format!(
                "the model to start from, `{}`, predicts another garment ({:?}, {} vertices, \
                 template {}) than the dataset's ({:?}, {} vertices, template {}): start from \
                 a model of the dataset's template",
                path.display(),
                model.meta.template.resolution,
                model.meta.template.vertex_count,
                model.meta.template.hash,
                template.resolution,
                template.vertex_count,
                template.hash,
            )));
        }
        for net in [&model.fitting, &model.local] {
            let differ: Vec<String> = architecture(net.config())
                .into_iter()
                .zip(architecture(net_config))
                .filter(|(a, b)| a.1 != b.1)
                .map(|((name, theirs), (_, ours))| {
                    format!("{name}: the model's {theirs}, this run's {ours}")
                })
                .collect();
            if !differ.is_empty() {
                return Err(Error::InvalidConfig(format!(
                    "the model to start from, `{}`, has another architecture ({}): train with \
                     its settings (the `train` command takes them from the model)",
                    path.display(),
                    differ.join("; ")
                )));
            }
        }
        Ok(Self {
            path: path.to_owned(),
            model,
        })
    }

    /// What the fine-tuned model's provenance records about where it started.
    pub(crate) fn provenance_note(&self) -> serde_json::Value {
        let p = &self.model.meta.provenance;
        serde_json::json!({
            "path": self.path,
            "dataset_hash": p.dataset_hash,
            "command": p.command,
            "epochs": p.epochs,
            "training_fabrics": p.training_fabrics.len(),
        })
    }

    /// The fabrics the fine-tuned model has learned: the starting model's, then this run's
    /// that it lacks (same name and ω), in the run's order.
    pub(crate) fn merged_fabrics(&self, run: Vec<TrainingFabric>) -> Vec<TrainingFabric> {
        let mut all = self.model.meta.provenance.training_fabrics.clone();
        for fabric in run {
            if !all.contains(&fabric) {
                all.push(fabric);
            }
        }
        all
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

    #[test]
    fn a_fine_tuning_run_starts_where_its_model_left_off_and_keeps_no_worse_weights() {
        let _serial = training_lock();
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 6, 20);
        let first = dir.path().join("first.safetensors");
        let s1 = train(&data, &first, &tiny_config(15), &RunOptions::default()).unwrap();
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
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 6, 20);
        let first = dir.path().join("first.safetensors");
        train(&data, &first, &tiny_config(2), &RunOptions::default()).unwrap();
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
            Err(Error::Model(garmatnet_model::Error::Io { .. }))
        ));
        assert!(!out.exists(), "no model is written");
    }
}
