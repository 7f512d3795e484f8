//! What defines a training run ([`TrainConfig`], [`RunOptions`]) and the checks made on it
//! before any work.

use std::path::{Path, PathBuf};

use garmatnet_core::DisplacementFrame;
use garmatnet_model::{GarMatNetConfig, PoseEncoding};
use serde::{Deserialize, Serialize};

use crate::data::loader::Fnv1a;
use crate::data::split_config::SplitConfig;
use crate::error::{Error, Result};
use crate::physics::PhysicsConfig;
use crate::training::training_loop::LearningRateSchedule;

/// Everything that defines a GarMatNet training run (CLI options map onto these fields).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct TrainConfig {
    /// Seed of the weights, dropout and the epoch shuffles (the split has its own,
    /// [`SplitConfig::seed`]).
    pub seed: u64,
    /// Adam's learning rate (at the first epoch).
    pub learning_rate: f64,
    /// How the learning rate changes over each net's epochs (default: constant, as in
    /// files written before this option). Not written at its default, so a default run's
    /// fingerprint, and the checkpoints of runs begun before the option, stay valid.
    #[serde(skip_serializing_if = "LearningRateSchedule::is_constant")]
    pub learning_rate_schedule: LearningRateSchedule,
    /// Mini-batch size.
    pub batch_size: usize,
    /// The most epochs per net.
    pub max_epochs: usize,
    /// Early-stopping patience of the generally-fitting net (paper: 50).
    pub patience_fitting: usize,
    /// Early-stopping patience of the locally-detailed net (paper: 200).
    pub patience_local: usize,
    /// Width of the pose branch.
    pub pose_hidden: usize,
    /// Width of the material branch.
    pub material_hidden: usize,
    /// Width of the merged hidden layer.
    pub hidden: usize,
    /// Dropout probability.
    pub dropout: f64,
    /// Decoupled weight decay (AdamW, Loshchilov & Hutter 2019): each step shrinks every
    /// weight by `learning_rate × weight_decay` besides Adam's update. `0` (default): plain
    /// Adam, as the paper trains; not written at its default, so a default run's
    /// fingerprint, and the checkpoints of runs begun before the option, stay valid.
    #[serde(skip_serializing_if = "is_zero")]
    pub weight_decay: f64,
    /// Low-rank output head: the nets output `k` coefficients of a basis initialised with
    /// the principal components of the normalised training displacements (and fine-tuned
    /// with the weights). `None` (default): the full `3n`-wide output layer.
    pub output_rank: Option<usize>,
    /// The weight controller α (paper §3.6).
    pub alpha: f64,
    /// Make both nets blind to a common scaling of every stiffness and the density (see
    /// [`GarMatNetConfig::scale_free_material`]). Default off: the paper's 6-d ω input.
    pub scale_free_material: bool,
    /// How both nets read the pose (see [`PoseEncoding`]). Default axis-angle, the paper's
    /// input; not written at its default, so a default run's fingerprint, and the
    /// checkpoints of runs begun before the option, stay valid.
    #[serde(skip_serializing_if = "PoseEncoding::is_axis_angle")]
    pub pose_encoding: PoseEncoding,
    /// The frame of the predicted displacements.
    pub displacement_frame: DisplacementFrame,
    /// The data split.
    pub split: SplitConfig,
    /// Accept a dataset with missing samples (train on what exists).
    pub allow_incomplete_dataset: bool,
    /// Train on each training sample's mirror image too, at the mirrored pose
    /// ([`TrainingDataset::load_mirrored`](crate::TrainingDataset::load_mirrored)): twice
    /// the training rows at no solver cost. Off by default; not written while off, so a
    /// default run's fingerprint, and the checkpoints of runs begun before the option, stay
    /// valid.
    #[serde(skip_serializing_if = "is_false")]
    pub mirrored_samples: bool,
    /// Hybrid physics-informed training (issue 49): the locally-detailed net's loss adds
    /// `physics.weight` times the normalised drape energy of the full prediction at
    /// (pose, fabric) pairs drawn every step ([`PhysicsConfig`]). Off by default; not
    /// written while off, so a default run's fingerprint, and the checkpoints of runs begun
    /// before the option, stay valid.
    #[serde(skip_serializing_if = "PhysicsConfig::is_off")]
    pub physics: PhysicsConfig,
    /// Fine-tuning: start both nets from this trained model (its weights and low-rank bases,
    /// which train on, and its output normalisers, which are kept) instead of fresh nets
    /// (`train --init-from`). The model must predict the dataset's template with this
    /// configuration's architecture (the dropout is this configuration's), and must not have
    /// trained on the split's target materials; the run then trains on the dataset as any
    /// other, early stopping included, the starting weights competing as epoch 0's. A resume
    /// needs the same starting model (its
    /// [`weights_fingerprint`](garmatnet_model::GarMatNetModel::weights_fingerprint)).
    /// `None` (default): fresh nets; not written then, so a default run's fingerprint, and
    /// the checkpoints of runs begun before the option, stay valid.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub init_from: Option<PathBuf>,
    /// Compute device: `cpu`, `gpu` or `auto`.
    pub device: String,
    /// No progress: neither the bar on a terminal nor, elsewhere, the progress lines (one a
    /// minute; `GARMATNET_PROGRESS_SECS` sets the interval).
    pub quiet: bool,
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self {
            seed: 42,
            learning_rate: 1e-3,
            learning_rate_schedule: LearningRateSchedule::Constant,
            batch_size: 32,
            max_epochs: 2000,
            patience_fitting: 50,
            patience_local: 200,
            pose_hidden: 512,
            material_hidden: 64,
            hidden: 512,
            dropout: 0.1,
            weight_decay: 0.0,
            output_rank: None,
            alpha: 0.5,
            scale_free_material: false,
            pose_encoding: PoseEncoding::AxisAngle,
            // Canonical won on the gentle 30 x 200 dataset: whole-test error 10.52 vs
            // 10.97 mm (book/src/experiments/gentle-dataset.md).
            displacement_frame: DisplacementFrame::Canonical,
            split: SplitConfig::default(),
            allow_incomplete_dataset: false,
            mirrored_samples: false,
            physics: PhysicsConfig::default(),
            init_from: None,
            device: "cpu".into(),
            quiet: false,
        }
    }
}

impl TrainConfig {
    /// Checks the loop settings (the net's own settings are checked by the model crate).
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
        self.physics.validate()?;
        GarMatNetConfig {
            output_rank: None,
            ..self.net_config(1)
        }
        .validate()?;
        Ok(())
    }

    /// The network configuration for a template of `vertex_count` vertices.
    #[must_use]
    pub fn net_config(&self, vertex_count: usize) -> GarMatNetConfig {
        GarMatNetConfig::new(
            vertex_count,
            self.pose_hidden,
            self.material_hidden,
            self.hidden,
        )
        .with_dropout(self.dropout)
        .with_output_rank(self.output_rank)
        .with_alpha(self.alpha)
        .with_scale_free_material(self.scale_free_material)
        .with_pose_encoding(self.pose_encoding)
        .with_displacement_frame(self.displacement_frame)
    }

    /// Whether `self` and `other` train the same model: equal in everything but `quiet` and
    /// `device` (what [`TrainConfig::fingerprint`] leaves out).
    pub(crate) fn same_run(&self, other: &TrainConfig) -> bool {
        self.result_settings() == other.result_settings()
    }

    /// The configuration with what does not change the result (`quiet`, `device`) cleared.
    fn result_settings(&self) -> TrainConfig {
        TrainConfig {
            quiet: false,
            device: String::new(),
            ..self.clone()
        }
    }

    /// A fingerprint of everything that changes the result (not `quiet`/`device`): what
    /// checkpoints written before [`TrainConfig::resume_fingerprint`] record.
    pub(crate) fn fingerprint(&self, dataset_hash: &str) -> String {
        Self::fingerprint_of(&self.result_settings(), dataset_hash)
    }

    /// The checkpoint's fingerprint: everything that changes the result but the learning
    /// rate, so that a run that diverged resumes from its last good checkpoint with a lower
    /// rate ([`Error::Diverged`]'s advice); every other setting must match.
    pub(crate) fn resume_fingerprint(&self, dataset_hash: &str) -> String {
        let settings = TrainConfig {
            learning_rate: 0.0,
            ..self.result_settings()
        };
        Self::fingerprint_of(&settings, dataset_hash)
    }

    fn fingerprint_of(settings: &TrainConfig, dataset_hash: &str) -> String {
        let mut h = Fnv1a::default();
        h.write(&serde_json::to_vec(settings).unwrap_or_default());
        h.write(dataset_hash.as_bytes());
        format!("{:016x}", h.0)
    }
}

/// How to run a training: resume, or stop early leaving a checkpoint.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RunOptions {
    /// The command line, recorded in the model's provenance (the CLI passes its arguments).
    pub command: String,
    /// Continue from the checkpoint next to the model, if there is one.
    pub resume: bool,
    /// Stop after this many epochs (both nets together) in this run, leaving a checkpoint to
    /// resume from (time-boxed runs); `None` trains to the end.
    pub stop_after_epochs: Option<usize>,
    /// Whether a resume may go on at a lower learning rate than its checkpoint was written
    /// with: the way on after [`Error::Diverged`] (`train --resume` allows it). Without it,
    /// and for a higher rate, a checkpoint of another rate is refused.
    pub learning_rate_may_fall: bool,
}

/// The training-loop settings [`TrainConfig`] and the baseline's config share.
pub(crate) struct LoopConfig {
    pub(crate) learning_rate: f64,
    pub(crate) batch_size: usize,
    pub(crate) max_epochs: usize,
    pub(crate) patience_fitting: usize,
    pub(crate) patience_local: usize,
    pub(crate) weight_decay: f64,
}

/// Checks the loop settings of [`TrainConfig`] and the baseline's config: a positive
/// learning rate, batch size, epoch limit and patience (a patience of 0 would stop before
/// the first epoch and leave an untrained net with no dev loss to record).
pub(crate) fn check_loop_settings(c: &LoopConfig) -> Result<()> {
    if !(c.learning_rate.is_finite() && c.learning_rate > 0.0) {
        return Err(Error::InvalidConfig(format!(
            "learning_rate = {} must be a positive number",
            c.learning_rate
        )));
    }
    check_weight_decay(c.weight_decay)?;
    if c.batch_size == 0 || c.max_epochs == 0 {
        return Err(Error::InvalidConfig(
            "batch_size and max_epochs must be positive".into(),
        ));
    }
    if c.patience_fitting == 0 || c.patience_local == 0 {
        return Err(Error::InvalidConfig(format!(
            "patience_fitting = {} and patience_local = {} must be at least 1 (the epochs \
             without a better development loss before a net stops; the paper uses 50 and 200)",
            c.patience_fitting, c.patience_local
        )));
    }
    Ok(())
}

/// Checks a weight decay for [`TrainConfig`] and the baseline's config.
fn check_weight_decay(weight_decay: f64) -> Result<()> {
    if weight_decay.is_finite() && (0.0..1.0).contains(&weight_decay) {
        Ok(())
    } else {
        Err(Error::InvalidConfig(format!(
            "weight_decay = {weight_decay} must lie in [0, 1) (typical: 1e-4 to 1e-1)"
        )))
    }
}

/// Serde's test for fields left out of files at their default of zero.
#[allow(clippy::trivially_copy_pass_by_ref)] // serde's `skip_serializing_if` passes `&T`
pub(crate) fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

/// Serde's test for flags left out of files while off.
#[allow(clippy::trivially_copy_pass_by_ref)] // serde's `skip_serializing_if` passes `&T`
pub(crate) fn is_false(x: &bool) -> bool {
    !*x
}

/// The files the trainer derives from a model path `{stem}.{ext}`, as `(suffix, what)`:
/// each is written at `{stem}.{suffix}` next to the model.
const MODEL_SIBLINGS: [(&str, &str); 3] = [
    ("checkpoint", "checkpoint directory"),
    ("lock", "lock file"),
    ("split.json", "split file"),
];

/// Checks, before any work, that the model can be written at `model_path`: it is not an
/// existing directory, and its name does not end like one of the files the trainer derives
/// from a model path (a model path `m.checkpoint` is its own checkpoint directory, `m.lock`
/// its own lock file, which taking the lock truncates, and `m.split.json` the split file of
/// a model `m.*`).
///
/// # Errors
/// [`Error::InvalidConfig`] naming the path and saying what to name the model instead.
pub(crate) fn check_model_path(model_path: &Path) -> Result<()> {
    let directory = || {
        Err(Error::InvalidConfig(format!(
            "the model path `{}` is a directory, not a model file; name a file such as \
             `{}`",
            model_path.display(),
            model_path.join("model.safetensors").display()
        )))
    };
    let Some(file_name) = model_path.file_name().map(|n| n.to_string_lossy()) else {
        return directory();
    };
    // Case-insensitive, as some file systems are.
    let lower = file_name.to_ascii_lowercase();
    for (suffix, what) in MODEL_SIBLINGS {
        if let Some(stem) = lower.strip_suffix(&format!(".{suffix}")) {
            let stem = &file_name[..stem.len()];
            let stem = if stem.is_empty() { "model" } else { stem };
            return Err(Error::InvalidConfig(format!(
                "the model path `{}` ends in `.{suffix}`, the name of the {what} the trainer \
                 writes next to a model (`{{stem}}.{suffix}`), so the run would overwrite its \
                 own or another model's {what}; name the model `{}` instead",
                model_path.display(),
                model_path
                    .with_file_name(format!("{stem}.safetensors"))
                    .display()
            )));
        }
    }
    if model_path.is_dir() {
        return directory();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_at_their_defaults_leave_the_fingerprint_of_older_runs_alone() {
        // A default run serialises exactly the fields it did before the learning-rate
        // schedule, the residual filter and the pose encoding existed, so its checkpoints
        // stay resumable.
        let json = serde_json::to_value(TrainConfig::default()).unwrap();
        assert!(json.get("learning_rate_schedule").is_none(), "{json}");
        assert!(json.get("pose_encoding").is_none(), "{json}");
        assert!(json["split"].get("max_train_residual").is_none(), "{json}");
        assert!(json.get("weight_decay").is_none(), "{json}");
        assert!(json.get("physics").is_none(), "{json}");
        assert!(json.get("mirrored_samples").is_none(), "{json}");
        let mirrored = TrainConfig {
            mirrored_samples: true,
            ..TrainConfig::default()
        };
        assert_ne!(
            mirrored.fingerprint("d"),
            TrainConfig::default().fingerprint("d")
        );
        let back: TrainConfig =
            serde_json::from_value(serde_json::to_value(&mirrored).unwrap()).unwrap();
        assert_eq!(back, mirrored);
        let base = TrainConfig::default().fingerprint("d");
        let cosine = TrainConfig {
            learning_rate_schedule: LearningRateSchedule::Cosine,
            ..TrainConfig::default()
        };
        let mut filtered = TrainConfig::default();
        filtered.split.max_train_residual = Some(0.1);
        let rotations = TrainConfig {
            pose_encoding: PoseEncoding::RotationMatrix,
            ..TrainConfig::default()
        };
        assert_ne!(cosine.fingerprint("d"), base);
        assert_ne!(filtered.fingerprint("d"), base);
        assert_ne!(rotations.fingerprint("d"), base);
        let decayed = TrainConfig {
            weight_decay: 0.01,
            ..TrainConfig::default()
        };
        assert_ne!(decayed.fingerprint("d"), base);
        let back: TrainConfig =
            serde_json::from_value(serde_json::to_value(&decayed).unwrap()).unwrap();
        assert_eq!(back, decayed);
        // Written and read back, the options survive.
        let back: TrainConfig =
            serde_json::from_value(serde_json::to_value(&cosine).unwrap()).unwrap();
        assert_eq!(back, cosine);
        let back: TrainConfig =
            serde_json::from_value(serde_json::to_value(&filtered).unwrap()).unwrap();
        assert_eq!(back, filtered);
        let back: TrainConfig =
            serde_json::from_value(serde_json::to_value(&rotations).unwrap()).unwrap();
        assert_eq!(back, rotations);
    }

    #[test]
    fn a_zero_patience_is_refused_before_training() {
        for (fitting, local) in [(0, 200), (50, 0), (0, 0)] {
            let config = TrainConfig {
                patience_fitting: fitting,
                patience_local: local,
                ..TrainConfig::default()
            };
            let err = config.validate().unwrap_err();
            assert!(
                matches!(err, Error::InvalidConfig(_)) && err.to_string().contains("patience"),
                "{err}"
            );
        }
        TrainConfig::default().validate().unwrap();
    }
}
