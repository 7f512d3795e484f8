//! Training GarMatNet (paper §3.4–3.5, §4.1): Adam on the MSE of normalised outputs
//! (eqs. 6–7), mini-batches, early stopping on the dev loss with per-net patience, resumable
//! checkpoints and a model file in the model crate's format.
//!
//! The generally-fitting net is trained first, then the locally-detailed net; each keeps the
//! weights of its best dev epoch. Every epoch's shuffle and dropout seed derive from a state
//! saved in the checkpoint, so a resumed run repeats an uninterrupted one on the CPU. Burn's
//! random state is global to the process: two trainings running in parallel threads of one
//! process are not reproducible (separate processes are).

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

use burn::module::Module;
use burn::nn::loss::{MseLoss, Reduction};
use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer};
use burn::prelude::*;
use garmatnet_core::{DisplacementFrame, POSE_DIM, Resolution, SplitMix64};
use garmatnet_model::{
    BaselineNet, GarMatNet, GarMatNetConfig, GarMatNetModel, MATERIAL_DIM, ModelMeta,
    OutputNormalizer, TemplateInfo, TrainingProvenance, select_device,
};
use indicatif::{ProgressBar, ProgressStyle};
use serde::{Deserialize, Serialize};

use crate::checkpoint::{CHECKPOINT_VERSION, CheckpointDir, CheckpointState, NetProgress, Phase};
use crate::dataset_loader::{Fnv1a, TrainingDataset, sibling};
use crate::error::{Error, Result};
use crate::split::{Split, SplitConfig};

/// A training loss above this counts as divergence even while finite: targets are normalised
/// to unit variance, so a working net's loss is of order 1 and an exploding one passes 1e6
/// long before it overflows.
pub const DIVERGENCE_LOSS: f64 = 1e6;

/// Everything that defines a GarMatNet training run (CLI options map onto these fields).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct TrainConfig {
    /// Seed of the weights, the split's shuffle and the epoch shuffles.
    pub seed: u64,
    /// Adam's learning rate.
    pub learning_rate: f64,
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
    /// The weight controller α (paper §3.6).
    pub alpha: f64,
    /// The frame of the predicted displacements.
    pub displacement_frame: DisplacementFrame,
    /// The data split.
    pub split: SplitConfig,
    /// Accept a dataset with missing samples (train on what exists).
    pub allow_incomplete_dataset: bool,
    /// Compute device: `cpu`, `gpu` or `auto`.
    pub device: String,
    /// No progress bar.
    pub quiet: bool,
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self {
            seed: 42,
            learning_rate: 1e-3,
            batch_size: 32,
            max_epochs: 2000,
            patience_fitting: 50,
            patience_local: 200,
            pose_hidden: 512,
            material_hidden: 64,
            hidden: 512,
            dropout: 0.1,
            alpha: 0.5,
            displacement_frame: DisplacementFrame::World,
            split: SplitConfig::default(),
            allow_incomplete_dataset: false,
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
        if !(self.learning_rate.is_finite() && self.learning_rate > 0.0) {
            return Err(Error::InvalidConfig(format!(
                "learning_rate = {} must be a positive number",
                self.learning_rate
            )));
        }
        if self.batch_size == 0 || self.max_epochs == 0 {
            return Err(Error::InvalidConfig(
                "batch_size and max_epochs must be positive".into(),
            ));
        }
        self.net_config(1).validate()?;
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
        .with_alpha(self.alpha)
        .with_displacement_frame(self.displacement_frame)
    }

    /// A fingerprint of everything that changes the result (not `quiet`/`device`).
    fn fingerprint(&self, dataset_hash: &str) -> String {
        let mut c = self.clone();
        c.quiet = false;
        c.device = String::new();
        let mut h = Fnv1a::default();
        h.write(&serde_json::to_vec(&c).unwrap_or_default());
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
}

/// How one net's training went.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NetSummary {
    /// Epochs trained.
    pub epochs: usize,
    /// The epoch whose weights were kept.
    pub best_epoch: usize,
    /// The kept weights' dev loss (MSE of normalised outputs).
    pub best_dev_mse: f64,
    /// The untrained net's dev loss.
    pub initial_dev_mse: f64,
    /// The last epoch's training loss.
    pub last_train_mse: f64,
    /// Mean wall-clock seconds per epoch.
    pub seconds_per_epoch: f64,
}

impl From<&NetProgress> for NetSummary {
    fn from(p: &NetProgress) -> Self {
        Self {
            epochs: p.epoch,
            best_epoch: p.best_epoch,
            best_dev_mse: p.best_dev,
            initial_dev_mse: p.initial_dev,
            last_train_mse: p.last_train,
            seconds_per_epoch: p.seconds / p.epoch.max(1) as f64,
        }
    }
}

/// What [`train`] did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainSummary {
    /// Whether both nets finished and the model file was written.
    pub finished: bool,
    /// The model file (written only when `finished`).
    pub model_path: PathBuf,
    /// The split file.
    pub split_path: PathBuf,
    /// The checkpoint directory (removed when `finished`).
    pub checkpoint_dir: PathBuf,
    /// Where a resumed run started: the phase and the epochs it had completed.
    pub resumed_from: Option<(Phase, usize)>,
    /// The generally-fitting net, once finished.
    pub fitting: Option<NetSummary>,
    /// The locally-detailed net, once finished.
    pub local: Option<NetSummary>,
    /// Training, dev and test sample counts.
    pub samples: [usize; 3],
}

/// The split file of the model at `model_path`: `{stem}.split.json` next to it.
#[must_use]
pub fn split_path(model_path: &Path) -> PathBuf {
    sibling(model_path, "split.json")
}

/// Trains GarMatNet on the dataset in `data_dir` and writes the model to `model_path`, its
/// split to [`split_path`] and checkpoints to `{stem}.checkpoint/` (removed at the end).
///
/// # Errors
/// [`Error::InvalidConfig`] for bad settings; dataset errors naming the sample;
/// [`Error::UnknownMaterials`] for absent target materials; [`Error::Checkpoint`] for a
/// checkpoint of another configuration; [`Error::Diverged`] if the loss becomes NaN,
/// infinite or explodes (no model is written, the last good checkpoint is kept).
pub fn train(
    data_dir: &Path,
    model_path: &Path,
    config: &TrainConfig,
    options: &RunOptions,
) -> Result<TrainSummary> {
    config.validate()?;
    let data = TrainingDataset::open(data_dir, config.allow_incomplete_dataset)?;
    let split = Split::new(
        data.spec(),
        &data.keys(),
        data.dataset_hash(),
        &config.split,
    )?;
    let split_file = split_path(model_path);
    split.check_no_leak(&split_file)?;
    let device = select_device(&config.device)?;
    let n = data.vertex_count();
    let net_config = config.net_config(n);
    net_config.validate()?;
    let frame = config.displacement_frame;
    let train_set = data.load(&split.train, frame)?;
    let dev_set = data.load(&split.dev, frame)?;
    let fitting_norm = fit_normalizer(&train_set.d_fitting, 3 * n)?;
    let local_norm = fit_normalizer(&train_set.d_local, 3 * n)?;

    let checkpoint = CheckpointDir::for_model(model_path);
    let fingerprint = config.fingerprint(data.dataset_hash());
    let saved = if options.resume {
        checkpoint.read_state()?
    } else {
        checkpoint.remove();
        None
    };
    if let Some(s) = &saved
        && s.fingerprint != fingerprint
    {
        return Err(Error::Checkpoint {
            path: checkpoint.path().to_owned(),
            message: "it was written with another configuration or dataset; delete it or \
                      train with the original settings"
                .into(),
        });
    }
    if let Some(dir) = split_file.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    }
    split.write(&split_file)?;

    let progress = progress_bar(config.max_epochs, config.quiet);
    let ad = device.clone().autodiff();
    let mut budget = options.stop_after_epochs;
    let mut summary = TrainSummary {
        finished: false,
        model_path: model_path.to_owned(),
        split_path: split_file.clone(),
        checkpoint_dir: checkpoint.path().to_owned(),
        resumed_from: saved.as_ref().map(|s| (s.phase, s.progress.epoch)),
        fitting: None,
        local: None,
        samples: [split.train.len(), split.dev.len(), split.test.len()],
    };
    let settings = |phase: Phase, patience| LoopSettings {
        name: phase.name().to_owned(),
        learning_rate: config.learning_rate,
        batch_size: config.batch_size,
        max_epochs: config.max_epochs,
        patience,
        replicate: 1,
        seed: config.seed ^ (phase as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15),
    };

    // The fitting net: finished in an earlier run, resumed, or trained from scratch.
    let fitting_state = |state: Option<CheckpointState>| {
        CheckpointState {
            version: CHECKPOINT_VERSION,
            fingerprint: fingerprint.clone(),
            phase: Phase::Fitting,
            fitting_done: None,
            progress: initial_progress(0),
            current_file: String::new(),
            best_file: String::new(),
            optimizer_file: String::new(),
        }
        .merge(state)
    };
    ad.seed(config.seed);
    let fresh_fitting = net_config.init(&ad);
    let (fitting_net, fitting_progress) = match &saved {
        Some(s) if s.phase == Phase::Local => {
            let done = s.fitting_done.clone().ok_or_else(|| Error::Checkpoint {
                path: checkpoint.path().to_owned(),
                message: "local phase without the fitting net's record".into(),
            })?;
            (checkpoint.load_fitting_final(fresh_fitting)?, done)
        }
        _ => {
            let sets = NetSets::new(&train_set, &dev_set, Part::Fitting, &fitting_norm, &ad);
            let mut state = fitting_state(saved.clone().filter(|s| s.phase == Phase::Fitting));
            let outcome = fit_net(
                fresh_fitting,
                &sets,
                &settings(Phase::Fitting, config.patience_fitting),
                Some((&checkpoint, &mut state)),
                &mut budget,
                &progress,
            )?;
            match outcome {
                Outcome::Done(net, p) => {
                    checkpoint.save_fitting_final(&net)?;
                    (net, p)
                }
                Outcome::Paused => return Ok(summary),
            }
        }
    };
    summary.fitting = Some(NetSummary::from(&fitting_progress));

    ad.seed(config.seed ^ 1);
    let fresh_local = net_config.init(&ad);
    let mut local_state = CheckpointState {
        phase: Phase::Local,
        fitting_done: Some(fitting_progress.clone()),
        progress: initial_progress(0),
        ..fitting_state(None)
    }
    .merge(saved.filter(|s| s.phase == Phase::Local));
    let sets = NetSets::new(&train_set, &dev_set, Part::Local, &local_norm, &ad);
    let outcome = fit_net(
        fresh_local,
        &sets,
        &settings(Phase::Local, config.patience_local),
        Some((&checkpoint, &mut local_state)),
        &mut budget,
        &progress,
    )?;
    let Outcome::Done(local_net, local_progress) = outcome else {
        return Ok(summary);
    };
    progress.finish_and_clear();
    summary.local = Some(NetSummary::from(&local_progress));

    let provenance = TrainingProvenance {
        dataset_hash: data.dataset_hash().to_owned(),
        command: options.command.clone(),
        seed: config.seed,
        epochs: fitting_progress.epoch.max(local_progress.epoch),
        losses: [
            ("fitting_dev_mse".to_owned(), fitting_progress.best_dev),
            ("local_dev_mse".to_owned(), local_progress.best_dev),
            ("fitting_train_mse".to_owned(), fitting_progress.last_train),
            ("local_train_mse".to_owned(), local_progress.last_train),
        ]
        .into_iter()
        .collect(),
        extra: serde_json::json!({
            "dataset_path": data.dir(),
            "split_file": split_file,
            "train_config": config,
            "fitting": NetSummary::from(&fitting_progress),
            "local": NetSummary::from(&local_progress),
        }),
    };
    let resolution = data.garment().resolution;
    let model = GarMatNetModel {
        fitting: fitting_net.valid(),
        local: local_net.valid(),
        fitting_norm,
        local_norm,
        meta: ModelMeta {
            template: TemplateInfo {
                hash: data.template_hash().to_owned(),
                resolution: Resolution::grid_spacing(resolution),
                vertex_count: n,
            },
            provenance,
        },
    };
    model.save(model_path)?;
    checkpoint.remove();
    summary.finished = true;
    Ok(summary)
}

impl CheckpointState {
    /// `saved` when there is one (a resume), else `self` (a fresh start).
    fn merge(self, saved: Option<CheckpointState>) -> Self {
        saved.unwrap_or(self)
    }
}

fn initial_progress(seed: u64) -> NetProgress {
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

/// An epoch progress bar on stderr (epoch, losses, best, ETA); hidden when `quiet` or when
/// stderr is not a terminal.
pub(crate) fn progress_bar(max_epochs: usize, quiet: bool) -> ProgressBar {
    if quiet || !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(max_epochs as u64);
    if let Ok(style) =
        ProgressStyle::with_template("{prefix:>8} [{bar:30}] {pos}/{len} epochs  {msg}  ETA {eta}")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar
}

/// The smallest per-coordinate std (metres) the trainer stores. Coordinates that never move
/// (e.g. D_local at corners the smoother keeps fixed) would otherwise fall under the model
/// crate's [`garmatnet_model::MIN_STD`] rule, which replaces their std by 1 (metre): every
/// small net error there would become a metre-sized spike. With a 10 µm floor their
/// normalised target is 0 and a net error of 1 costs 10 µm.
pub const STD_FLOOR: f64 = 1e-5;

/// Per-coordinate mean and std (f64, std floored at [`STD_FLOOR`]) over the rows of
/// `values` (`[S, dim]`, row-major).
///
/// # Errors
/// From [`OutputNormalizer::from_parts`] (non-finite values); `InvalidArgument` for no rows.
pub(crate) fn fit_normalizer(values: &[f32], dim: usize) -> Result<OutputNormalizer> {
    let rows = values.len() / dim.max(1);
    if rows == 0 {
        return Err(garmatnet_core::Error::InvalidArgument(
            "cannot fit an output normaliser on zero training samples".into(),
        )
        .into());
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
    fn new(
        train: &crate::dataset_loader::LoadedSamples,
        dev: &crate::dataset_loader::LoadedSamples,
        part: Part,
        norm: &OutputNormalizer,
        ad: &Device,
    ) -> Self {
        let labels = |s: &crate::dataset_loader::LoadedSamples| match part {
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

/// The loop's settings for one net.
pub(crate) struct LoopSettings {
    pub(crate) name: String,
    pub(crate) learning_rate: f64,
    pub(crate) batch_size: usize,
    pub(crate) max_epochs: usize,
    pub(crate) patience: usize,
    /// Passes over the training samples per epoch (the baseline's replication).
    pub(crate) replicate: usize,
    pub(crate) seed: u64,
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

/// Trains `net` (on the autodiff device) with early stopping, resuming from `checkpoint`'s
/// state when its progress is past epoch 0.
pub(crate) fn fit_net<M: Trainable>(
    net: M,
    sets: &NetSets,
    settings: &LoopSettings,
    mut checkpoint: Option<(&CheckpointDir, &mut CheckpointState)>,
    budget: &mut Option<usize>,
    progress: &ProgressBar,
) -> Result<Outcome<M>> {
    let device = sets.train.poses.device();
    let mut optimizer: ModuleOptimizer = AdamConfig::new().init();
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
            p
        }
    };
    progress.set_prefix(settings.name.clone());
    progress.set_length(settings.max_epochs as u64);
    progress.set_position(state.epoch as u64);
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
        for batch in order.chunks(settings.batch_size) {
            let index: Vec<i64> = batch.iter().map(|&i| i as i64).collect();
            let index = Tensor::<1, Int>::from_data(TensorData::new(index, [batch.len()]), &device);
            let pred = net.predict(
                sets.train.poses.clone().select(0, index.clone()),
                sets.train.materials.clone().select(0, index.clone()),
            );
            let target = sets.train.targets.clone().select(0, index);
            let loss = MseLoss::new().forward(pred, target, Reduction::Mean);
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
            net = optimizer.step(settings.learning_rate, net, grads);
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
        progress.set_position(state.epoch as u64);
        progress.set_message(format!(
            "train {train_loss:.4}  dev {dev_loss:.4}  best {:.4} @{}",
            state.best_dev, state.best_epoch
        ));
    }
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
            "; the last good checkpoint (epoch {}) is kept in {}",
            s.progress.epoch,
            dir.path().display()
        ),
        _ => String::new(),
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
pub(crate) mod tests {
    use super::*;
    use crate::test_util::{TARGETS, synthetic_dataset, training_lock};

    /// A tiny, fast configuration for the synthetic datasets.
    pub(crate) fn tiny_config(max_epochs: usize) -> TrainConfig {
        TrainConfig {
            learning_rate: 3e-3,
            batch_size: 16,
            max_epochs,
            patience_fitting: 1000,
            patience_local: 1000,
            pose_hidden: 32,
            material_hidden: 16,
            hidden: 32,
            dropout: 0.0,
            split: SplitConfig {
                test_materials: TARGETS.iter().map(|s| (*s).to_owned()).collect(),
                ..SplitConfig::default()
            },
            quiet: true,
            ..TrainConfig::default()
        }
    }

    #[test]
    fn normaliser_floors_constant_coordinates_instead_of_using_one_metre() {
        let values = [0.5f32, 0.1, 0.5, 0.3]; // rows [0.5, 0.1], [0.5, 0.3]
        let norm = fit_normalizer(&values, 2).unwrap();
        assert_eq!(norm.std()[0], STD_FLOOR);
        approx::assert_relative_eq!(norm.std()[1], 0.1, epsilon = 1e-7);
        approx::assert_relative_eq!(norm.mean()[1], 0.2, epsilon = 1e-7);
    }

    #[test]
    fn training_lowers_the_dev_loss_and_writes_a_loadable_model() {
        let _serial = training_lock();
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 6, 20);
        let model_path = dir.path().join("out").join("model.safetensors");
        let options = RunOptions {
            command: "garmatnet train data --out model.safetensors".into(),
            ..RunOptions::default()
        };
        let s = train(&data, &model_path, &tiny_config(25), &options).unwrap();
        assert!(s.finished);
        eprintln!(
            "tiny: {:.1} ms per epoch (fitting), {} training samples",
            1e3 * s.fitting.as_ref().unwrap().seconds_per_epoch,
            s.samples[0]
        );
        for net in [s.fitting.as_ref().unwrap(), s.local.as_ref().unwrap()] {
            assert!(
                net.best_dev_mse < 0.5 * net.initial_dev_mse,
                "dev loss {} did not fall well below the untrained {}",
                net.best_dev_mse,
                net.initial_dev_mse
            );
        }
        let model = GarMatNetModel::load(&model_path, &Device::flex()).unwrap();
        assert_eq!(
            model.vertex_count(),
            TrainingDataset::open(&data, false).unwrap().vertex_count()
        );
        assert!(model.meta.provenance.losses["fitting_dev_mse"].is_finite());
        assert_eq!(model.meta.provenance.command, options.command);
        assert!(s.split_path.exists());
        assert!(
            !s.checkpoint_dir.exists(),
            "a finished run removes its checkpoint"
        );
        // 4 non-target materials x 18 non-held-out poses, split 90/10.
        assert_eq!(s.samples[0] + s.samples[1], 4 * 18);
        assert_eq!(s.samples[2], 6 * 20 - 4 * 18);
    }

    #[test]
    fn resume_continues_from_the_checkpoint_and_repeats_an_uninterrupted_run() {
        let _serial = training_lock();
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 6, 20);
        let config = TrainConfig {
            dropout: 0.1,
            ..tiny_config(4)
        };
        let full_path = dir.path().join("full.safetensors");
        let full = train(&data, &full_path, &config, &RunOptions::default()).unwrap();

        // "Killed" after 3 epochs of the fitting net, then again 2 epochs into the local net.
        let path = dir.path().join("resumed.safetensors");
        let stop = |n| RunOptions {
            resume: true,
            stop_after_epochs: Some(n),
            ..RunOptions::default()
        };
        let first = train(&data, &path, &config, &stop(3)).unwrap();
        assert!(!first.finished && !path.exists(), "no model before the end");
        let state = CheckpointDir::for_model(&path)
            .read_state()
            .unwrap()
            .unwrap();
        assert_eq!((state.phase, state.progress.epoch), (Phase::Fitting, 3));
        let second = train(&data, &path, &config, &stop(3)).unwrap();
        assert_eq!(second.resumed_from, Some((Phase::Fitting, 3)));
        assert!(!second.finished);
        let last = train(&data, &path, &config, &stop(100)).unwrap();
        assert_eq!(last.resumed_from, Some((Phase::Local, 2)));
        assert!(last.finished && path.exists());
        let (a, b) = (full.fitting.unwrap(), last.fitting.unwrap());
        assert_eq!(a.epochs, b.epochs);
        assert_eq!(
            a.best_dev_mse, b.best_dev_mse,
            "resumed fitting net differs"
        );
        let (a, b) = (full.local.unwrap(), last.local.unwrap());
        assert_eq!(a.best_dev_mse, b.best_dev_mse, "resumed local net differs");
        assert_eq!(a.last_train_mse, b.last_train_mse);
    }

    #[test]
    fn an_absurd_learning_rate_stops_with_a_divergence_error_and_no_model() {
        let _serial = training_lock();
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 6, 20);
        let path = dir.path().join("model.safetensors");
        let config = TrainConfig {
            learning_rate: 1e6,
            ..tiny_config(20)
        };
        let err = train(&data, &path, &config, &RunOptions::default()).unwrap_err();
        assert!(matches!(err, Error::Diverged { .. }), "{err}");
        assert!(err.to_string().contains("lower the learning rate"), "{err}");
        assert!(!path.exists(), "a diverged run must not write a model");
    }

    #[test]
    fn a_checkpoint_of_another_configuration_is_refused() {
        let _serial = training_lock();
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 6, 20);
        let path = dir.path().join("model.safetensors");
        let stop = RunOptions {
            resume: true,
            stop_after_epochs: Some(1),
            ..RunOptions::default()
        };
        train(&data, &path, &tiny_config(5), &stop).unwrap();
        let other = TrainConfig {
            alpha: 0.3,
            ..tiny_config(5)
        };
        let err = train(&data, &path, &other, &stop).unwrap_err();
        assert!(matches!(err, Error::Checkpoint { .. }), "{err}");
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
            name: "timing".into(),
            learning_rate: 1e-4,
            batch_size: 32,
            max_epochs: 3,
            patience: 100,
            replicate: 1,
            seed: 1,
        };
        let t = Instant::now();
        let Outcome::Done(_, p) = fit_net(
            net,
            &sets,
            &settings,
            None,
            &mut None,
            &ProgressBar::hidden(),
        )
        .unwrap() else {
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
