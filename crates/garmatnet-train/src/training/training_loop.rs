//! The training loop shared by GarMatNet's two nets and the baseline: Adam on the MSE of
//! normalised outputs, mini-batches from preloaded device tensors, early stopping on the dev
//! loss, divergence detection and per-epoch checkpoints.
//!
//! Every epoch's shuffle and dropout seed derive from the RNG state saved in the checkpoint,
//! so a resumed run repeats an uninterrupted one on the CPU.

use std::time::Instant;

use burn::module::Module;
use burn::nn::loss::{MseLoss, Reduction};
use burn::optim::{AdamConfig, AdamWConfig, GradientsParams, ModuleOptimizer};
use burn::prelude::*;
use garmatnet_core::MATERIAL_DIM;
use garmatnet_core::{POSE_DIM, SplitMix64};
use garmatnet_model::{BaselineNet, GarMatNet, OutputNormalizer};
use serde::{Deserialize, Serialize};

use crate::data::loader::LoadedSamples;
use crate::error::DIVERGENCE_LOSS;
use crate::error::{Error, Result};
use crate::progress::Progress;
use crate::training::checkpoint::{CheckpointDir, CheckpointState, NetProgress};

pub(crate) fn initial_progress(seed: u64) -> NetProgress {
    NetProgress {
        epoch: 0,
        best_dev: f64::INFINITY,
        best_epoch: 0,
        since_best: 0,
        initial_dev: f64::NAN,
        last_train: f64::NAN,
        seconds: 0.0,
        rng_state: seed,
    }
}

/// Epoch progress on stderr (epoch, losses, best, ETA): a bar on a terminal, a line a
/// minute in a log ([`crate::Progress`]), nothing when `quiet`.
pub(crate) fn epoch_progress(max_epochs: usize, quiet: bool) -> Progress {
    Progress::stderr(
        max_epochs as u64,
        "epoch",
        "{prefix:>8} [{bar:30}] {pos}/{len} epochs  {msg}  ETA {eta}",
        quiet,
    )
}

/// The smallest per-coordinate std (metres) the trainer stores: the model crate's
/// [`garmatnet_model::MIN_STD`] (10 µm), so a coordinate that never moves costs 10 µm per unit
/// of net error instead of a metre.
pub const STD_FLOOR: f64 = garmatnet_model::MIN_STD;

/// Per-coordinate mean and std (f64, std floored at [`STD_FLOOR`]) over the rows of
/// `values` (`[S, dim]`, row-major).
///
/// # Errors
/// From [`OutputNormalizer::from_parts`] (non-finite values); [`Error::EmptyInput`] for no
/// rows.
pub(crate) fn fit_normalizer(values: &[f32], dim: usize) -> Result<OutputNormalizer> {
    let rows = values.len() / dim.max(1);
    if rows == 0 {
        return Err(Error::EmptyInput {
            what: "fitting an output normaliser",
            needs: "at least one training sample",
        });
    }
    let mut mean = vec![0.0f64; dim];
    for row in values.chunks_exact(dim) {
        mean.iter_mut()
            .zip(row)
            .for_each(|(m, &v)| *m += f64::from(v));
    }
    mean.iter_mut().for_each(|m| *m /= rows as f64);
    let mut var = vec![0.0f64; dim];
    for row in values.chunks_exact(dim) {
        for ((s, &v), m) in var.iter_mut().zip(row).zip(&mean) {
            let d = f64::from(v) - m;
            *s += d * d;
        }
    }
    let std = var
        .into_iter()
        .map(|v| (v / rows as f64).sqrt().max(STD_FLOOR))
        .collect();
    Ok(OutputNormalizer::from_parts(mean, std)?)
}

/// Which label a net learns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Part {
    Fitting,
    Local,
}

/// A net the loop can train: both GarMatNet nets and the baseline.
pub(crate) trait Trainable: Module + Clone {
    /// # Shapes
    /// `pose`: `[B, 72]`, `material`: `[B, 6]` → `[B, 3n]` (normalised).
    fn predict(&self, pose: Tensor<2>, material: Tensor<2>) -> Tensor<2>;
}

impl Trainable for GarMatNet {
    fn predict(&self, pose: Tensor<2>, material: Tensor<2>) -> Tensor<2> {
        self.forward(pose, material)
    }
}

impl Trainable for BaselineNet {
    fn predict(&self, pose: Tensor<2>, _material: Tensor<2>) -> Tensor<2> {
        self.forward(pose)
    }
}

/// Inputs and normalised targets of one set on one device.
pub(crate) struct DeviceSet {
    poses: Tensor<2>,
    materials: Tensor<2>,
    targets: Tensor<2>,
    len: usize,
}

impl DeviceSet {
    /// # Shapes
    /// `poses` `[S, 72]`, `materials` `[S, 6]`, `labels` `[S, 3n]` (metres).
    pub(crate) fn new(
        poses: &[f32],
        materials: &[f32],
        labels: &[f32],
        norm: &OutputNormalizer,
        device: &Device,
    ) -> Self {
        let len = poses.len() / POSE_DIM;
        let dim = norm.dim();
        let (mean, std) = (norm.mean(), norm.std());
        let targets: Vec<f32> = labels
            .iter()
            .enumerate()
            .map(|(i, &v)| ((f64::from(v) - mean[i % dim]) / std[i % dim]) as f32)
            .collect();
        let matrix = |v: Vec<f32>, cols| Tensor::from_data(TensorData::new(v, [len, cols]), device);
        Self {
            poses: matrix(poses.to_vec(), POSE_DIM),
            materials: matrix(materials.to_vec(), MATERIAL_DIM),
            targets: matrix(targets, dim),
            len,
        }
    }
}

/// The training set (on the autodiff device) and dev set (on the plain device) of one net.
pub(crate) struct NetSets {
    pub(crate) train: DeviceSet,
    pub(crate) dev: DeviceSet,
}

impl NetSets {
    pub(crate) fn new(
        train: &LoadedSamples,
        dev: &LoadedSamples,
        part: Part,
        norm: &OutputNormalizer,
        ad: &Device,
    ) -> Self {
        let labels = |s: &LoadedSamples| match part {
            Part::Fitting => s.d_fitting.clone(),
            Part::Local => s.d_local.clone(),
        };
        let inner = ad.clone().inner();
        Self {
            train: DeviceSet::new(&train.poses, &train.materials, &labels(train), norm, ad),
            dev: DeviceSet::new(&dev.poses, &dev.materials, &labels(dev), norm, &inner),
        }
    }
}

/// How the learning rate changes over the epochs of one net.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LearningRateSchedule {
    /// The same rate every epoch (the paper's Adam).
    #[default]
    Constant,
    /// Cosine annealing from the rate at epoch 0 to [`COSINE_FINAL_FRACTION`] of it at
    /// `max_epochs` (Loshchilov & Hutter 2017, without restarts): large steps while the net
    /// is far off, small ones to settle into a minimum the constant rate only circles.
    Cosine,
}

/// The fraction of the initial learning rate that [`LearningRateSchedule::Cosine`] ends at.
pub const COSINE_FINAL_FRACTION: f64 = 0.01;

impl LearningRateSchedule {
    /// Every schedule, for parsing and messages.
    pub const ALL: [Self; 2] = [Self::Constant, Self::Cosine];

    /// The schedule's name on the command line and in files.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Constant => "constant",
            Self::Cosine => "cosine",
        }
    }

    /// Whether this is [`LearningRateSchedule::Constant`] (the default).
    #[must_use]
    pub fn is_constant(&self) -> bool {
        *self == Self::Constant
    }

    /// The rate of the epoch that starts after `epoch` finished ones, out of `max_epochs`,
    /// for initial rate `rate`.
    #[must_use]
    pub fn rate(self, rate: f64, epoch: usize, max_epochs: usize) -> f64 {
        match self {
            Self::Constant => rate,
            Self::Cosine => {
                let t = (epoch as f64 / max_epochs.max(1) as f64).min(1.0);
                let f = COSINE_FINAL_FRACTION;
                rate * (f + (1.0 - f) * 0.5 * (1.0 + (std::f64::consts::PI * t).cos()))
            }
        }
    }
}

impl std::fmt::Display for LearningRateSchedule {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for LearningRateSchedule {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|k| k.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| {
                Error::InvalidConfig(format!(
                    "unknown learning-rate schedule `{s}`: use `constant` (the default) or \
                     `cosine`"
                ))
            })
    }
}

/// The loop's settings for one net.
pub(crate) struct LoopSettings {
    pub(crate) name: String,
    pub(crate) learning_rate: f64,
    pub(crate) schedule: LearningRateSchedule,
    pub(crate) batch_size: usize,
    pub(crate) max_epochs: usize,
    pub(crate) patience: usize,
    /// Decoupled weight decay: `0` is plain Adam, above it AdamW.
    pub(crate) weight_decay: f64,
    /// Passes over the training samples per epoch (the baseline's replication).
    pub(crate) replicate: usize,
    pub(crate) seed: u64,
    /// Whether the starting weights compete with the epochs' for the best dev loss (a
    /// fine-tuning run: no epoch worse than the model it started from is kept). Fresh nets
    /// do not: the first epoch's weights are kept at the least.
    pub(crate) keep_start: bool,
}

pub(crate) enum Outcome<M> {
    /// Early-stopped or at `max_epochs`: the best net (plain device) and its counters.
    Done(M, NetProgress),
    /// Stopped by the epoch budget; the checkpoint holds the state.
    Paused,
}

/// The mean loss of `net` over `set` (MSE of normalised outputs), in chunks.
pub(crate) fn mean_loss<M: Trainable>(net: &M, set: &DeviceSet) -> f64 {
    const CHUNK: usize = 256;
    let mut sum = 0.0;
    let mut start = 0;
    while start < set.len {
        let len = CHUNK.min(set.len - start);
        let pred = net.predict(
            set.poses.clone().narrow(0, start, len),
            set.materials.clone().narrow(0, start, len),
        );
        let loss = MseLoss::new().forward(
            pred,
            set.targets.clone().narrow(0, start, len),
            Reduction::Mean,
        );
        sum += f64::from(loss.into_scalar::<f32>()) * len as f64;
        start += len;
    }
    sum / set.len.max(1) as f64
}

/// A loss term added to every training step's supervised loss (the hybrid physics term).
pub(crate) trait ExtraLoss<M> {
    /// The term for `net` at one step (`[1]`, on the autodiff device), drawing any
    /// randomness from `rng` (seeded from the epoch's state, so a resumed run repeats it).
    fn loss(&mut self, net: &M, rng: &mut SplitMix64) -> Result<Tensor<1>>;
}

/// Trains `net` (on the autodiff device) with early stopping, resuming from `checkpoint`'s
/// state when its progress is past epoch 0.
pub(crate) fn fit_net<M: Trainable>(
    net: M,
    sets: &NetSets,
    settings: &LoopSettings,
    checkpoint: Option<(&CheckpointDir, &mut CheckpointState)>,
    budget: &mut Option<usize>,
    progress: &Progress,
) -> Result<Outcome<M>> {
    fit_net_with(net, sets, settings, checkpoint, budget, progress, None)
}

/// As [`fit_net`], with `extra`'s term added to each step's loss. The early stopping still
/// watches the supervised dev loss alone.
pub(crate) fn fit_net_with<M: Trainable>(
    net: M,
    sets: &NetSets,
    settings: &LoopSettings,
    mut checkpoint: Option<(&CheckpointDir, &mut CheckpointState)>,
    budget: &mut Option<usize>,
    progress: &Progress,
    mut extra: Option<&mut dyn ExtraLoss<M>>,
) -> Result<Outcome<M>> {
    // The configs are validated before training; a zero here would end the loop before its
    // first epoch and hand back an untrained net with an infinite "best" dev loss.
    if settings.patience == 0
        || settings.max_epochs == 0
        || settings.batch_size == 0
        || settings.replicate == 0
    {
        return Err(Error::InvalidConfig(format!(
            "the {} net needs a positive patience, epoch limit, batch size and replication \
             (got {}, {}, {}, {})",
            settings.name,
            settings.patience,
            settings.max_epochs,
            settings.batch_size,
            settings.replicate
        )));
    }
    let device = sets.train.poses.device();
    let mut optimizer: ModuleOptimizer = if settings.weight_decay > 0.0 {
        #[allow(clippy::cast_possible_truncation)]
        AdamWConfig::new()
            .with_weight_decay(settings.weight_decay as f32)
            .init()
    } else {
        AdamConfig::new().init()
    };
    let mut net = net;
    let mut best = net.clone();
    let mut state = match checkpoint.as_mut() {
        Some((dir, s)) if s.progress.epoch > 0 => {
            net = dir.load_module(&s.current_file, net)?;
            best = dir.load_module(&s.best_file, best)?;
            optimizer = dir.load_optimizer(&s.optimizer_file, optimizer)?;
            s.progress.clone()
        }
        _ => {
            let mut p = initial_progress(settings.seed);
            p.initial_dev = mean_loss(&net.valid(), &sets.dev);
            if settings.keep_start && p.initial_dev.is_finite() {
                p.best_dev = p.initial_dev;
            }
            p
        }
    };
    progress.set_prefix(&settings.name);
    progress.start_at(settings.max_epochs as u64, state.epoch as u64);
    let n = sets.train.len;
    while state.epoch < settings.max_epochs && state.since_best < settings.patience {
        if *budget == Some(0) {
            return Ok(Outcome::Paused);
        }
        let started = Instant::now();
        let mut rng = SplitMix64::new(state.rng_state);
        device.seed(rng.next_u64());
        let mut order: Vec<usize> = (0..n * settings.replicate).map(|i| i % n).collect();
        rng.shuffle(&mut order);
        let mut loss_sum = 0.0;
        let rate = settings
            .schedule
            .rate(settings.learning_rate, state.epoch, settings.max_epochs);
        for batch in order.chunks(settings.batch_size) {
            let index: Vec<i64> = batch.iter().map(|&i| i as i64).collect();
            let index = Tensor::<1, Int>::from_data(TensorData::new(index, [batch.len()]), &device);
            let pred = net.predict(
                sets.train.poses.clone().select(0, index.clone()),
                sets.train.materials.clone().select(0, index.clone()),
            );
            let target = sets.train.targets.clone().select(0, index);
            let mut loss = MseLoss::new().forward(pred, target, Reduction::Mean);
            if let Some(extra) = extra.as_mut() {
                loss = loss + extra.loss(&net, &mut rng)?;
            }
            let value = f64::from(loss.clone().into_scalar::<f32>());
            if !value.is_finite() || value > DIVERGENCE_LOSS {
                return Err(diverged(
                    settings,
                    state.epoch + 1,
                    value,
                    checkpoint.as_ref(),
                ));
            }
            loss_sum += value * batch.len() as f64;
            let grads = GradientsParams::from_grads(loss.backward(), &net);
            net = optimizer.step(rate, net, grads);
        }
        let train_loss = loss_sum / order.len().max(1) as f64;
        let dev_loss = mean_loss(&net.valid(), &sets.dev);
        state.epoch += 1;
        if !dev_loss.is_finite() {
            return Err(diverged(
                settings,
                state.epoch,
                dev_loss,
                checkpoint.as_ref(),
            ));
        }
        state.last_train = train_loss;
        state.rng_state = rng.next_u64();
        if dev_loss < state.best_dev {
            state.best_dev = dev_loss;
            state.best_epoch = state.epoch;
            state.since_best = 0;
            best = net.clone();
        } else {
            state.since_best += 1;
        }
        state.seconds += started.elapsed().as_secs_f64();
        if let Some((dir, s)) = checkpoint.as_mut() {
            s.progress = state.clone();
            dir.save(s, &net, &best, &optimizer)?;
        }
        if let Some(b) = budget.as_mut() {
            *b -= 1;
        }
        progress.set_message(&format!(
            "train {train_loss:.4}  dev {dev_loss:.4}  best {:.4} @{}",
            state.best_dev, state.best_epoch
        ));
        progress.set_position(state.epoch as u64);
    }
    // The net's last epoch (a log's interval may have skipped it), and no ETA for the epochs
    // an early stop leaves untrained.
    if state.epoch < settings.max_epochs {
        progress.set_message(&format!(
            "train {:.4}  best {:.4} @{}  stopped early: no better development loss in {} epochs",
            state.last_train, state.best_dev, state.best_epoch, settings.patience
        ));
    }
    progress.end_stage();
    Ok(Outcome::Done(best.valid(), state))
}

fn diverged(
    settings: &LoopSettings,
    epoch: usize,
    loss: f64,
    checkpoint: Option<&(&CheckpointDir, &mut CheckpointState)>,
) -> Error {
    let kept = match checkpoint {
        Some((dir, s)) if s.progress.epoch > 0 => format!(
            " and continue from the last good checkpoint (epoch {} of this net, kept in {}) \
             with `--resume --lr <lower rate>`",
            s.progress.epoch,
            dir.path().display()
        ),
        // The local net's first epoch: the finished fitting net is what is kept.
        Some((dir, s)) if s.fitting_done.is_some() => format!(
            " and continue with `--resume --lr <lower rate>`: the finished fitting net is \
             kept in {} (training again without `--resume` would discard it)",
            dir.path().display()
        ),
        _ => " and train again".into(),
    };
    Error::Diverged {
        net: settings.name.clone(),
        epoch,
        loss,
        learning_rate: settings.learning_rate,
        kept,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::training::train_config::TrainConfig;

    #[test]
    fn a_divergence_names_what_is_kept_and_how_to_go_on() {
        let settings = LoopSettings {
            keep_start: false,
            name: "local".into(),
            learning_rate: 1e4,
            schedule: LearningRateSchedule::Constant,
            batch_size: 4,
            max_epochs: 3,
            patience: 1,
            weight_decay: 0.0,
            replicate: 1,
            seed: 1,
        };
        let dir = CheckpointDir::for_model(std::path::Path::new("/tmp/m.safetensors"));
        let mut state = CheckpointState {
            version: crate::training::checkpoint::CHECKPOINT_VERSION,
            fingerprint: String::new(),
            learning_rate: Some(1e4),
            learning_rate_changes: Vec::new(),
            phase: crate::training::checkpoint::Phase::Local,
            fitting_done: Some(initial_progress(0)),
            progress: initial_progress(0),
            current_file: String::new(),
            best_file: String::new(),
            optimizer_file: String::new(),
        };
        // The local net diverging in its first epoch: the fitting net is what is kept, and
        // training again without --resume would throw it away.
        let first = diverged(&settings, 1, f64::NAN, Some(&(&dir, &mut state))).to_string();
        assert!(
            first.contains("--resume --lr <lower rate>`: the finished fitting net is kept"),
            "{first}"
        );
        state.progress.epoch = 4;
        let later = diverged(&settings, 5, 3e6, Some(&(&dir, &mut state))).to_string();
        assert!(
            later.contains("last good checkpoint (epoch 4 of this net"),
            "{later}"
        );
        assert!(later.contains("past 1e6: exploding"), "{later}");
        let none = diverged(&settings, 1, f64::INFINITY, None).to_string();
        assert!(none.ends_with("and train again"), "{none}");
    }

    #[test]
    fn the_cosine_schedule_falls_from_the_rate_to_its_final_fraction_and_stays() {
        let cosine = LearningRateSchedule::Cosine;
        approx::assert_relative_eq!(cosine.rate(2e-3, 0, 400), 2e-3);
        approx::assert_relative_eq!(
            cosine.rate(2e-3, 200, 400),
            2e-3 * (1.0 + COSINE_FINAL_FRACTION) / 2.0
        );
        approx::assert_relative_eq!(cosine.rate(2e-3, 400, 400), 2e-5);
        approx::assert_relative_eq!(cosine.rate(2e-3, 900, 400), 2e-5);
        let rates: Vec<f64> = (0..=400).map(|e| cosine.rate(1.0, e, 400)).collect();
        assert!(rates.windows(2).all(|w| w[1] < w[0]), "strictly falling");
        assert_eq!(LearningRateSchedule::Constant.rate(2e-3, 399, 400), 2e-3);
        for k in LearningRateSchedule::ALL {
            assert_eq!(k.to_string().parse::<LearningRateSchedule>().unwrap(), k);
        }
        assert_eq!(
            " Cosine".parse::<LearningRateSchedule>().unwrap(),
            LearningRateSchedule::Cosine
        );
        let err = "step".parse::<LearningRateSchedule>().unwrap_err();
        assert!(err.to_string().contains("`constant`"), "{err}");
    }

    #[test]
    fn normaliser_floors_constant_coordinates_instead_of_using_one_metre() {
        let values = [0.5f32, 0.1, 0.5, 0.3]; // rows [0.5, 0.1], [0.5, 0.3]
        let norm = fit_normalizer(&values, 2).unwrap();
        assert_eq!(norm.std()[0], STD_FLOOR);
        approx::assert_relative_eq!(norm.std()[1], 0.1, epsilon = 1e-7);
        approx::assert_relative_eq!(norm.mean()[1], 0.2, epsilon = 1e-7);
        assert!(matches!(
            fit_normalizer(&[], 2),
            Err(Error::EmptyInput { .. })
        ));
    }

    /// Per-step cost at a realistic size (n = 2,700 vertices, hidden 512, batch 32); run with
    /// `cargo test -p garmatnet-train --release -- --ignored --nocapture realistic`.
    #[test]
    #[ignore = "timing measurement, not a check"]
    fn realistic_train_step_time() {
        let ad = Device::flex().autodiff();
        ad.seed(1);
        let n = 2700;
        let net = TrainConfig::default().net_config(n).init(&ad);
        let rows = 256;
        let mut rng = SplitMix64::new(3);
        let mut fill = |len: usize| -> Vec<f32> { (0..len).map(|_| rng.normal() as f32).collect() };
        let norm = OutputNormalizer::identity(3 * n);
        let set = DeviceSet::new(
            &fill(rows * POSE_DIM),
            &fill(rows * MATERIAL_DIM),
            &fill(rows * 3 * n),
            &norm,
            &ad,
        );
        let sets = NetSets {
            dev: DeviceSet::new(
                &fill(32 * POSE_DIM),
                &fill(32 * MATERIAL_DIM),
                &fill(32 * 3 * n),
                &norm,
                &ad.clone().inner(),
            ),
            train: set,
        };
        let settings = LoopSettings {
            keep_start: false,
            name: "timing".into(),
            learning_rate: 1e-4,
            schedule: LearningRateSchedule::Constant,
            batch_size: 32,
            max_epochs: 3,
            patience: 100,
            weight_decay: 0.0,
            replicate: 1,
            seed: 1,
        };
        let t = Instant::now();
        let Outcome::Done(_, p) =
            fit_net(net, &sets, &settings, None, &mut None, &Progress::hidden()).unwrap()
        else {
            unreachable!()
        };
        let per_step = p.seconds / (3.0 * (rows / 32) as f64);
        println!(
            "realistic: {:.1} ms per batch-32 step; 4,500 training samples -> {:.1} s per epoch \
             (total {:.1} s)",
            per_step * 1e3,
            per_step * 4500.0 / 32.0,
            t.elapsed().as_secs_f64()
        );
    }
}
