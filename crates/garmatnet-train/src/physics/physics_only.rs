//! Physics-only training (`garmatnet train --physics-only`): GarMatNet's two nets learned
//! from the solver's energy alone, with no dataset, for one garment and body. Every step
//! draws fresh (pose, fabric) pairs and lowers [`TwoNetPhysicsLoss::total`]: the normalised
//! energy of the full prediction, plus the fitting net's distance to the Laplacian-smoothed
//! full prediction (detached), so the two nets split the drape as the supervised labels do.
//! Early stopping watches the same loss on a fixed held-out batch. Checkpoints and resume
//! work as in supervised training ([`crate::training::checkpoint`]; both nets are one module there).

use std::path::{Path, PathBuf};
use std::time::Instant;

use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer};
use burn::prelude::*;
use garmatnet_core::{
    CapsuleBody, Garment, LaplacianSmoother, MATERIAL_DIM, Resolution, SmoothingSettings,
    SplitMix64, TemplateInfo,
};
use garmatnet_model::{
    GarMatNet, GarMatNetModel, MaterialRange, ModelMeta, TrainingProvenance, select_device,
};
use garmatnet_sim::DrapeSettings;
use serde::{Deserialize, Serialize};

use crate::data::loader::Fnv1a;
use crate::error::DIVERGENCE_LOSS;
use crate::error::{Error, Result};
use crate::physics::batch::{PhysicsBatch, PhysicsPoses};
use crate::physics::two_net_loss::{NormalizerTensors, TwoNetPhysicsLoss, rest_offset_normalizers};
use crate::progress::Progress;
use crate::training::checkpoint::{CHECKPOINT_VERSION, CheckpointDir, CheckpointState, Phase};
use crate::training::train_config::{RunOptions, TrainConfig, check_model_path};
use crate::training::trainer::NetSummary;
use crate::training::training_loop::{epoch_progress, initial_progress};

/// Both nets as one module, so one optimiser and one checkpoint file carry them.
#[derive(Module, Debug)]
struct TwoNets {
    fitting: GarMatNet,
    local: GarMatNet,
}

/// Everything that defines a physics-only run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PhysicsOnlyConfig {
    /// The nets, learning rate, seed, epochs, device and displacement frame, as supervised
    /// training reads them; `batch_size` is the (pose, fabric) pairs per step and
    /// `patience_local` the early-stopping patience. The dataset's fields (split) are unused.
    pub train: TrainConfig,
    /// The garment's mesh resolution.
    pub resolution: Resolution,
    /// Steps per epoch (each on fresh pairs).
    pub steps_per_epoch: usize,
    /// Pairs of the fixed held-out batch that early stopping watches.
    pub held_out_pairs: usize,
    /// Which poses the pairs take (default: the datasets' independent-pose sampler).
    pub poses: PhysicsPoses,
    /// The fitting net's output scale (metres; [`rest_offset_normalizers`]).
    pub fitting_std: f64,
    /// The local net's output scale (metres).
    pub local_std: f64,
}

impl Default for PhysicsOnlyConfig {
    fn default() -> Self {
        Self {
            train: TrainConfig {
                batch_size: 8,
                max_epochs: 200,
                patience_local: 20,
                dropout: 0.0,
                ..TrainConfig::default()
            },
            resolution: Resolution::Default,
            steps_per_epoch: 50,
            held_out_pairs: 16,
            poses: PhysicsPoses::default(),
            fitting_std: 0.02,
            local_std: 0.005,
        }
    }
}

impl PhysicsOnlyConfig {
    /// Checks the settings.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] naming the field; as [`TrainConfig::validate`].
    pub fn validate(&self) -> Result<()> {
        self.train.validate()?;
        if self.steps_per_epoch == 0 || self.held_out_pairs == 0 {
            return Err(Error::InvalidConfig(
                "physics-only training needs at least one step per epoch and one held-out \
                 pair"
                    .into(),
            ));
        }
        self.poses.validate()?;
        for (what, v) in [("fitting", self.fitting_std), ("local", self.local_std)] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::InvalidConfig(format!(
                    "the {what} net's output scale {v} m must be positive and finite"
                )));
            }
        }
        Ok(())
    }

    fn fingerprint(&self, template_hash: u64) -> String {
        let settings = PhysicsOnlyConfig {
            train: TrainConfig {
                quiet: false,
                device: String::new(),
                ..self.train.clone()
            },
            ..self.clone()
        };
        let mut h = Fnv1a::default();
        h.write(b"physics-only");
        h.write(&serde_json::to_vec(&settings).unwrap_or_default());
        h.write(&template_hash.to_le_bytes());
        format!("{:016x}", h.0)
    }
}

/// What a physics-only run did.
#[derive(Debug, Clone)]
pub struct PhysicsOnlySummary {
    /// Whether the model was written (false: stopped by `stop_after_epochs`, resumable).
    pub finished: bool,
    /// The model file.
    pub model_path: PathBuf,
    /// The checkpoint directory.
    pub checkpoint_dir: PathBuf,
    /// The epoch a resume started from, if it was one.
    pub resumed_from: Option<usize>,
    /// The counters: `best_dev_mse` and `initial_dev_mse` hold the held-out physics loss
    /// (normalised energy in metres plus the decomposition MSE).
    pub progress: NetSummary,
}

/// Trains both nets from the drape energy alone and writes the model to `model_path`,
/// resuming from its checkpoint with `options.resume`. Every step draws fresh (pose,
/// fabric) pairs and lowers the normalised energy of the full prediction plus the fitting
/// net's distance to the Laplacian-smoothed full prediction; early stopping watches the
/// same loss on a fixed held-out batch.
///
/// # Errors
/// [`Error::InvalidConfig`] for invalid settings; [`Error::Checkpoint`] for a checkpoint of
/// another configuration; [`Error::Diverged`] if the loss stops being finite or explodes;
/// I/O and model errors from writing the checkpoint and model.
pub fn train_physics_only(
    model_path: &Path,
    config: &PhysicsOnlyConfig,
    options: &RunOptions,
) -> Result<PhysicsOnlySummary> {
    config.validate()?;
    check_model_path(model_path)?;
    let t = &config.train;
    let device = select_device(&t.device)?;
    let ad = device.clone().autodiff();
    let body = CapsuleBody::smpl_neutral();
    let garment = Garment::tshirt(config.resolution, &body)?;
    let smoother = LaplacianSmoother::new(&garment.rest, SmoothingSettings::default())?;
    let settings = DrapeSettings::default();
    let (fitting_norm, local_norm) =
        rest_offset_normalizers(&garment, config.fitting_std, config.local_std)?;
    let norms_on = |d: &Device| {
        (
            NormalizerTensors::new(&fitting_norm, d),
            NormalizerTensors::new(&local_norm, d),
        )
    };
    let ((train_f, train_l), (eval_f, eval_l)) = (norms_on(&ad), norms_on(&device));
    let net_config = t.net_config(garment.vertex_count());
    net_config.validate()?;

    let (_lock, checkpoint, saved) = CheckpointDir::open_for_run(model_path, options.resume)?;
    let fingerprint = config.fingerprint(garment.template_hash());
    if let Some(s) = &saved
        && (s.fingerprint != fingerprint || s.phase != Phase::Physics)
    {
        return Err(Error::Checkpoint {
            path: checkpoint.path().to_owned(),
            message: "it was written by another run; delete it or train with the original \
                      settings"
                .into(),
        });
    }

    let poses = config.poses.source()?;
    let draw = |rng: &mut SplitMix64, size: usize, on: &Device| {
        PhysicsBatch::draw(
            &garment,
            &body,
            &settings,
            t.displacement_frame,
            poses.as_ref(),
            rng,
            size,
            on,
        )
    };
    let held_out = draw(
        &mut SplitMix64::new(t.seed ^ 0x005E_ED0F_4E1D),
        config.held_out_pairs,
        &device,
    )?;
    let held_out_loss = |nets: &TwoNets| -> Result<f64> {
        let loss = TwoNetPhysicsLoss::new(
            &nets.fitting,
            &nets.local,
            &eval_f,
            &eval_l,
            &held_out,
            &smoother,
        )?;
        Ok(f64::from(loss.total().into_scalar::<f32>()))
    };

    ad.seed(t.seed);
    let fitting = net_config.init(&ad);
    ad.seed(t.seed ^ 1);
    let local = net_config.init(&ad);
    let mut nets = TwoNets { fitting, local };
    let mut best = nets.clone();
    let mut optimizer: ModuleOptimizer = AdamConfig::new().init();
    let mut state = CheckpointState {
        version: CHECKPOINT_VERSION,
        fingerprint,
        learning_rate: Some(t.learning_rate),
        learning_rate_changes: Vec::new(),
        phase: Phase::Physics,
        fitting_done: None,
        progress: initial_progress(t.seed),
        current_file: String::new(),
        best_file: String::new(),
        optimizer_file: String::new(),
    };
    let resumed_from = saved.as_ref().map(|s| s.progress.epoch);
    match saved {
        Some(s) if s.progress.epoch > 0 => {
            nets = checkpoint.load_module(&s.current_file, nets)?;
            best = checkpoint.load_module(&s.best_file, best)?;
            optimizer = checkpoint.load_optimizer(&s.optimizer_file, optimizer)?;
            state = s;
        }
        _ => state.progress.initial_dev = held_out_loss(&nets.valid())?,
    }
    let progress: Progress = epoch_progress(t.max_epochs, t.quiet);
    progress.set_prefix("physics");
    progress.start_at(t.max_epochs as u64, state.progress.epoch as u64);
    let mut budget = options.stop_after_epochs;
    let diverged = |epoch, loss| Error::Diverged {
        net: "physics-only".into(),
        epoch,
        loss,
        learning_rate: t.learning_rate,
        kept: " and train again".into(),
    };
    let mut finished = true;
    while state.progress.epoch < t.max_epochs && state.progress.since_best < t.patience_local {
        if budget == Some(0) {
            finished = false;
            break;
        }
        let started = Instant::now();
        let epoch = state.progress.epoch;
        let mut rng = SplitMix64::new(state.progress.rng_state);
        ad.seed(rng.next_u64());
        let rate = t
            .learning_rate_schedule
            .rate(t.learning_rate, epoch, t.max_epochs);
        let mut loss_sum = 0.0;
        for _ in 0..config.steps_per_epoch {
            let batch = draw(&mut rng, t.batch_size, &ad)?;
            let loss = TwoNetPhysicsLoss::new(
                &nets.fitting,
                &nets.local,
                &train_f,
                &train_l,
                &batch,
                &smoother,
            )?
            .total();
            let value = f64::from(loss.clone().into_scalar::<f32>());
            if !value.is_finite() || value > DIVERGENCE_LOSS {
                return Err(diverged(epoch + 1, value));
            }
            loss_sum += value;
            let grads = GradientsParams::from_grads(loss.backward(), &nets);
            nets = optimizer.step(rate, nets, grads);
        }
        let dev = held_out_loss(&nets.valid())?;
        if !dev.is_finite() {
            return Err(diverged(epoch + 1, dev));
        }
        let p = &mut state.progress;
        p.epoch += 1;
        p.last_train = loss_sum / config.steps_per_epoch as f64;
        p.rng_state = rng.next_u64();
        if dev < p.best_dev {
            (p.best_dev, p.best_epoch, p.since_best) = (dev, p.epoch, 0);
            best = nets.clone();
        } else {
            p.since_best += 1;
        }
        p.seconds += started.elapsed().as_secs_f64();
        checkpoint.save(&mut state, &nets, &best, &optimizer)?;
        if let Some(b) = budget.as_mut() {
            *b -= 1;
        }
        let p = &state.progress;
        progress.set_message(&format!(
            "train {:.4}  held-out {dev:.4}  best {:.4} @{}",
            p.last_train, p.best_dev, p.best_epoch
        ));
        progress.set_position(p.epoch as u64);
    }
    progress.end_stage();
    let summary = |finished| PhysicsOnlySummary {
        finished,
        model_path: model_path.to_owned(),
        checkpoint_dir: checkpoint.path().to_owned(),
        resumed_from,
        progress: NetSummary::from(&state.progress),
    };
    if !finished {
        return Ok(summary(false));
    }
    progress.finish();
    let best = best.valid();
    let unit_box = [[0.0; MATERIAL_DIM], [1.0; MATERIAL_DIM]];
    let model = GarMatNetModel {
        fitting: best.fitting,
        local: best.local,
        fitting_norm,
        local_norm,
        meta: ModelMeta {
            template: TemplateInfo::of(&garment),
            provenance: TrainingProvenance {
                dataset_hash: "physics-only".into(),
                command: options.command.clone(),
                seed: t.seed,
                epochs: state.progress.epoch,
                losses: [
                    ("held_out_physics_loss".to_owned(), state.progress.best_dev),
                    ("train_physics_loss".to_owned(), state.progress.last_train),
                ]
                .into_iter()
                .collect(),
                material_range: MaterialRange::of(unit_box),
                training_fabrics: Vec::new(),
                extra: serde_json::json!({
                    "physics_only": config,
                    "progress": NetSummary::from(&state.progress),
                }),
            },
        },
    };
    model.save(model_path)?;
    checkpoint.remove();
    Ok(summary(true))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::training_lock;

    fn toy(max_epochs: usize) -> PhysicsOnlyConfig {
        PhysicsOnlyConfig {
            train: TrainConfig {
                learning_rate: 1e-3,
                batch_size: 2,
                max_epochs,
                patience_local: 100,
                pose_hidden: 32,
                material_hidden: 16,
                hidden: 64,
                dropout: 0.0,
                quiet: true,
                ..TrainConfig::default()
            },
            resolution: Resolution::Coarse,
            steps_per_epoch: 4,
            held_out_pairs: 3,
            ..PhysicsOnlyConfig::default()
        }
    }

    /// A toy physics-only run: no dataset; the held-out physics loss falls, nothing is NaN,
    /// the model loads, and a run stopped after one epoch resumes to the uninterrupted
    /// run's numbers.
    #[test]
    fn a_toy_physics_only_run_lowers_the_held_out_loss_and_resumes_exactly() {
        let _serial = training_lock();
        // One worker thread, so Burn's CPU sums split the same way in both runs.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let train_physics_only =
            |path: &std::path::Path, config: &PhysicsOnlyConfig, options: &RunOptions| {
                pool.install(|| super::train_physics_only(path, config, options))
            };
        let dir = tempfile::tempdir().unwrap();
        let config = toy(3);
        let full_path = dir.path().join("full.safetensors");
        let full = train_physics_only(&full_path, &config, &RunOptions::default()).unwrap();
        assert!(full.finished && full_path.exists() && !full.checkpoint_dir.exists());
        let p = &full.progress;
        eprintln!(
            "physics-only toy: held-out loss {:.4} -> {:.4}, {:.2} s per epoch of {} steps",
            p.initial_dev_mse, p.best_dev_mse, p.seconds_per_epoch, config.steps_per_epoch
        );
        assert!(p.best_dev_mse.is_finite() && p.last_train_mse.is_finite());
        assert!(p.best_dev_mse < p.initial_dev_mse, "{p:?}");
        let model = GarMatNetModel::load(&full_path, &Device::flex()).unwrap();
        assert_eq!(model.meta.provenance.dataset_hash, "physics-only");

        let path = dir.path().join("resumed.safetensors");
        let stop = |n| RunOptions {
            resume: true,
            stop_after_epochs: Some(n),
            ..RunOptions::default()
        };
        let first = train_physics_only(&path, &config, &stop(1)).unwrap();
        assert!(!first.finished && !path.exists());
        let last = train_physics_only(&path, &config, &stop(100)).unwrap();
        assert_eq!(last.resumed_from, Some(1));
        assert!(last.finished);
        // Every test that seeds or draws from Burn's global random state holds
        // `training_lock`, and this one runs in a one-thread pool, so the resumed run ends on
        // the uninterrupted run's numbers bit for bit.
        assert_eq!(
            last.progress.best_dev_mse.to_bits(),
            full.progress.best_dev_mse.to_bits(),
            "{} vs {}",
            last.progress.best_dev_mse,
            full.progress.best_dev_mse
        );
        assert!(last.progress.last_train_mse.is_finite());
        // Another configuration does not resume this one's checkpoint.
        let _ = train_physics_only(&path, &config, &stop(1)).unwrap();
        let other = PhysicsOnlyConfig {
            steps_per_epoch: 5,
            ..config
        };
        assert!(matches!(
            train_physics_only(&path, &other, &stop(1)),
            Err(Error::Checkpoint { .. })
        ));
        assert!(matches!(
            PhysicsOnlyConfig {
                fitting_std: 0.0,
                ..toy(1)
            }
            .validate(),
            Err(Error::InvalidConfig(_))
        ));
    }
}
