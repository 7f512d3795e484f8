//! Training GarMatNet (paper §3.4–3.5, §4.1): Adam on the MSE of normalised outputs
//! (eqs. 6–7), mini-batches, early stopping on the dev loss with per-net patience, resumable
//! checkpoints and a model file in the model crate's format.
//!
//! The generally-fitting net is trained first, then the locally-detailed net; each keeps the
//! weights of its best dev epoch; the loop itself is [`crate::training::training_loop`]. A resumed run
//! repeats an uninterrupted one on the CPU. Burn's
//! random state is global to the process: two trainings running in parallel threads of one
//! process are not reproducible (separate processes are).

use std::path::{Path, PathBuf};

use burn::prelude::*;
use garmatnet_core::TemplateInfo;
use garmatnet_model::{
    GarMatNet, GarMatNetConfig, GarMatNetModel, ModelMeta, OutputNormalizer, TrainingProvenance,
    select_device,
};
use garmatnet_sim::SequenceSettings;
use serde::{Deserialize, Serialize};

use crate::data::files::split_path;
use crate::data::loader::TrainingDataset;
use crate::error::{Error, Result};
use crate::physics::{LocalPhysics, NormalizerTensors};
use crate::training::checkpoint::LearningRateChange;
use crate::training::checkpoint::{
    CHECKPOINT_VERSION, CheckpointDir, CheckpointState, NetProgress, Phase,
};
use crate::training::starting_model::StartingModel;
use crate::training::train_config::{RunOptions, TrainConfig, check_model_path};
use crate::training::training_loop::{
    ExtraLoss, LoopSettings, NetSets, Outcome, Part, epoch_progress, fit_net, fit_net_with,
    fit_normalizer, initial_progress,
};

/// How one net's training went.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NetSummary {
    /// Epochs trained.
    pub epochs: usize,
    /// The epoch whose weights were kept (0: a fine-tuning run's starting weights).
    pub best_epoch: usize,
    /// The kept weights' dev loss (MSE of normalised outputs).
    pub best_dev_mse: f64,
    /// The dev loss before the first epoch: of the untrained net, or of the model a
    /// fine-tuning run starts from.
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
    /// The split file (written together with the model, only when `finished`).
    pub split_path: PathBuf,
    /// The checkpoint directory (removed when `finished`).
    pub checkpoint_dir: PathBuf,
    /// Where a resumed run started: the phase and the epochs it had completed.
    pub resumed_from: Option<(Phase, usize)>,
    /// Where resumes changed the learning rate, in order (also recorded in the model's
    /// provenance, `extra.learning_rate_changes`); empty for a run at one rate.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub learning_rate_changes: Vec<LearningRateChange>,
    /// The generally-fitting net, once finished.
    pub fitting: Option<NetSummary>,
    /// The locally-detailed net, once finished.
    pub local: Option<NetSummary>,
    /// Training, dev and test sample counts.
    pub samples: [usize; 3],
    /// Samples no net trained on because their drape did not settle (see
    /// [`SplitConfig::max_train_residual`](crate::SplitConfig::max_train_residual)) or is
    /// caught in the body ([`Split::unsettled`](crate::Split::unsettled)); those in the test
    /// set are still tested.
    #[serde(default)]
    pub unsettled: usize,
}

/// Rows of the training labels the PCA of a low-rank head uses at most.
const PCA_MAX_ROWS: usize = 4096;

/// Initialises `net`'s low-rank output basis with the principal components of `labels`.
fn set_pca_basis(
    net: &mut GarMatNet,
    labels: &[f32],
    norm: &OutputNormalizer,
    k: usize,
    device: &Device,
) -> Result<()> {
    let dim = norm.dim();
    let (basis, mean) = crate::data::pca::pca_basis(labels, dim, norm, k, PCA_MAX_ROWS)?;
    net.set_output_basis(
        Tensor::from_data(TensorData::new(basis, [k, dim]), device),
        Tensor::from_data(TensorData::new(mean, [dim]), device),
    )?;
    Ok(())
}

/// The net a phase starts from: the starting model's (a fine-tuning run), or a fresh one
/// from `net_config` on `device` (seed it first) whose low-rank basis, if it has one, is
/// initialised with the principal components of `labels`.
fn initial_net(
    start: Option<&GarMatNet>,
    net_config: &GarMatNetConfig,
    labels: &[f32],
    norm: &OutputNormalizer,
    device: &Device,
) -> Result<GarMatNet> {
    if let Some(net) = start {
        return Ok(net.clone());
    }
    let mut net = net_config.init(device);
    if let Some(k) = net_config.output_rank {
        set_pca_basis(&mut net, labels, norm, k, device)?;
    }
    Ok(net)
}

/// Trains GarMatNet on the dataset in `data_dir` and writes the model to `model_path`, its
/// split to [`split_path`] and checkpoints to `{stem}.checkpoint/` (removed at the end).
///
/// # The model and its split
/// The split is written only once the model is, never when a run stops early, fails or is
/// killed, so an earlier model at `model_path` keeps its own split. The model records the
/// split's [`Split::fingerprint`](crate::Split::fingerprint) in its provenance, and readers
/// of the pair ([`crate::Split::read_for_model`]) refuse a split file that is not the one
/// the model was trained with. A resumed run needs no split file: it recomputes the split
/// from the dataset and the configuration, which the checkpoint's fingerprint pins (on a
/// dataset with a drape caught in the body, with the split's own fingerprint: from version
/// 0.13 on such drapes are left out, so a checkpoint written before is refused).
///
/// # Errors
/// [`Error::InvalidConfig`] for bad settings, or a `model_path` that is a directory or named
/// like a file derived from a model path (`{stem}.checkpoint`, `{stem}.lock`,
/// `{stem}.split.json`);
/// dataset errors naming the sample;
/// [`Error::UnknownMaterials`] for absent target materials; with
/// [`TrainConfig::init_from`], the starting model's errors ([`Error::Io`], [`Error::Model`],
/// another template among them) and [`Error::InvalidConfig`] for another architecture, a
/// target material it trained on or a fabric named as one of its with another ω;
/// [`Error::Checkpoint`] for a
/// checkpoint of another configuration; [`Error::Diverged`] if the loss becomes NaN,
/// infinite or explodes (no model is written, the last good checkpoint is kept).
pub fn train(
    data_dir: &Path,
    model_path: &Path,
    config: &TrainConfig,
    options: &RunOptions,
) -> Result<TrainSummary> {
    config.validate()?;
    check_model_path(model_path)?;
    let data = TrainingDataset::open(data_dir, config.allow_incomplete_dataset)?;
    let split = data.split(&config.split)?;
    let split_file = split_path(model_path);
    split.check_no_leak(&split_file)?;
    let device = select_device(&config.device)?;
    let n = data.vertex_count();
    let net_config = config.net_config(n);
    net_config.validate()?;
    let ad = device.clone().autodiff();
    // A fine-tuning run starts from a model's nets and keeps its normalisers (the nets'
    // outputs are in their units); any other run fits them to its training labels. What the
    // model will record is settled here, before any training.
    let start = match &config.init_from {
        Some(path) => {
            let s = StartingModel::load(path, &TemplateInfo::of(data.garment()), &net_config, &ad)?;
            s.check_unseen(&config.split.test_materials)?;
            Some(s)
        }
        None => None,
    };
    let (material_range, training_fabrics, run_key) = match &start {
        Some(s) => (
            s.merged_range(split.material_range(data.spec())),
            s.merged_fabrics(split.training_fabrics(data.spec()))?,
            format!("{}+{}", data.dataset_hash(), s.fingerprint),
        ),
        None => (
            split.material_range(data.spec()),
            split.training_fabrics(data.spec()),
            data.dataset_hash().to_owned(),
        ),
    };
    // From version 0.13 on, drapes caught in the body are left out of training; a
    // checkpoint written before, on a dataset with such a drape, was made on another split.
    // Such runs are keyed by their split too, so those checkpoints are refused instead of
    // resumed on a split they were not made with.
    let run_key = if data.records().iter().any(|r| r.stats.is_caught_in_body()) {
        format!("{run_key}/{}", split.fingerprint())
    } else {
        run_key
    };
    let frame = config.displacement_frame;
    let mut train_set = data.load(&split.train, frame)?;
    if config.mirrored_samples {
        train_set.append(data.load_mirrored(&split.train, frame)?)?;
    }
    let dev_set = data.load(&split.dev, frame)?;
    let (fitting_norm, local_norm) = match &start {
        Some(s) => (s.model.fitting_norm.clone(), s.model.local_norm.clone()),
        None => (
            fit_normalizer(&train_set.d_fitting, 3 * n)?,
            fit_normalizer(&train_set.d_local, 3 * n)?,
        ),
    };

    let (_lock, checkpoint, saved) = CheckpointDir::open_for_run(model_path, options.resume)?;
    // A fine-tuning run's key is its dataset and the starting model's weights.
    let fingerprint = config.resume_fingerprint(&run_key);
    // Checkpoints written before the learning rate could change on resume carry the
    // fingerprint with it, and resume with that same rate.
    if let Some(s) = &saved
        && s.fingerprint != fingerprint
        && s.fingerprint != config.fingerprint(&run_key)
    {
        return Err(Error::Checkpoint {
            path: checkpoint.path().to_owned(),
            message: "it was written with another configuration or dataset (only the \
                      learning rate may change on resume); delete it or train with the \
                      original settings"
                .into(),
        });
    }
    if let Some(before) = saved.as_ref().and_then(|s| s.learning_rate)
        && before != config.learning_rate
        && !(options.learning_rate_may_fall && config.learning_rate < before)
    {
        return Err(Error::Checkpoint {
            path: checkpoint.path().to_owned(),
            message: format!(
                "it was written at learning rate {before}, and this run asks for {}; resume \
                 at that rate{}",
                config.learning_rate,
                if options.learning_rate_may_fall {
                    " or a lower one"
                } else {
                    ""
                }
            ),
        });
    }
    // Every change of the learning rate over the run's resumes, this one's last.
    let mut learning_rate_changes = saved
        .as_ref()
        .map(|s| s.learning_rate_changes.clone())
        .unwrap_or_default();
    learning_rate_changes.extend(saved.as_ref().and_then(|s| {
        s.learning_rate
            .filter(|&before| before != config.learning_rate)
            .map(|before| LearningRateChange {
                net: s.phase.name().to_owned(),
                epoch: s.progress.epoch,
                from: before,
                to: config.learning_rate,
            })
    }));

    let progress = epoch_progress(config.max_epochs, config.quiet);
    let mut budget = options.stop_after_epochs;
    let mut summary = TrainSummary {
        finished: false,
        model_path: model_path.to_owned(),
        split_path: split_file.clone(),
        checkpoint_dir: checkpoint.path().to_owned(),
        resumed_from: saved.as_ref().map(|s| (s.phase, s.progress.epoch)),
        learning_rate_changes: learning_rate_changes.clone(),
        fitting: None,
        local: None,
        samples: [split.train.len(), split.dev.len(), split.test.len()],
        unsettled: split.unsettled.len(),
    };
    let settings = |phase: Phase, patience| LoopSettings {
        name: phase.name().to_owned(),
        learning_rate: config.learning_rate,
        schedule: config.learning_rate_schedule,
        batch_size: config.batch_size,
        max_epochs: config.max_epochs,
        patience,
        weight_decay: config.weight_decay,
        replicate: 1,
        seed: config.seed ^ (phase as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15),
        keep_start: start.is_some(),
    };

    // The fitting net: finished in an earlier run, resumed, or trained from scratch.
    let fitting_state = |state: Option<CheckpointState>| {
        CheckpointState {
            version: CHECKPOINT_VERSION,
            fingerprint: fingerprint.clone(),
            learning_rate: Some(config.learning_rate),
            learning_rate_changes: learning_rate_changes.clone(),
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
    let initial_fitting = initial_net(
        start.as_ref().map(|s| &s.model.fitting),
        &net_config,
        &train_set.d_fitting,
        &fitting_norm,
        &ad,
    )?;
    let (fitting_net, fitting_progress) = match &saved {
        Some(s) if s.phase == Phase::Local => {
            let done = s.fitting_done.clone().ok_or_else(|| Error::Checkpoint {
                path: checkpoint.path().to_owned(),
                message: "local phase without the fitting net's record".into(),
            })?;
            (checkpoint.load_fitting_final(initial_fitting)?, done)
        }
        _ => {
            let sets = NetSets::new(&train_set, &dev_set, Part::Fitting, &fitting_norm, &ad);
            let mut state = fitting_state(saved.clone().filter(|s| s.phase == Phase::Fitting));
            let outcome = fit_net(
                initial_fitting,
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
    let initial_local = initial_net(
        start.as_ref().map(|s| &s.model.local),
        &net_config,
        &train_set.d_local,
        &local_norm,
        &ad,
    )?;
    let mut local_state = CheckpointState {
        phase: Phase::Local,
        fitting_done: Some(fitting_progress.clone()),
        progress: initial_progress(0),
        ..fitting_state(None)
    }
    .merge(saved.filter(|s| s.phase == Phase::Local));
    let sets = NetSets::new(&train_set, &dev_set, Part::Local, &local_norm, &ad);
    let mut physics = if config.physics.is_off() {
        None
    } else {
        let solver = SequenceSettings::from_manifest(&data.spec().solver).map_err(|e| {
            Error::InvalidConfig(format!(
                "the physics term needs the dataset's solver settings, unreadable: {e}"
            ))
        })?;
        Some(LocalPhysics {
            config: config.physics.clone(),
            poses: config.physics.poses.source()?,
            fitting: fitting_net.clone().valid(),
            fitting_norm: fitting_norm.clone(),
            local_norm: NormalizerTensors::new(&local_norm, &ad),
            garment: data.garment().clone(),
            body: data.body().clone(),
            settings: solver.drape,
            frame,
            device: ad.clone(),
        })
    };
    let outcome = fit_net_with(
        initial_local,
        &sets,
        &settings(Phase::Local, config.patience_local),
        Some((&checkpoint, &mut local_state)),
        &mut budget,
        &progress,
        physics.as_mut().map(|p| p as &mut dyn ExtraLoss<GarMatNet>),
    )?;
    let Outcome::Done(local_net, local_progress) = outcome else {
        return Ok(summary);
    };
    progress.finish();
    summary.local = Some(NetSummary::from(&local_progress));

    let mut provenance = TrainingProvenance {
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
        // A fine-tuned model has learned its starting model's fabrics too.
        material_range,
        training_fabrics,
        extra: serde_json::json!({
            "dataset_path": data.dir(),
            "split_file": split_file,
            (TrainingProvenance::SPLIT_FINGERPRINT_KEY): split.fingerprint(),
            "train_config": config,
            "fitting": NetSummary::from(&fitting_progress),
            "local": NetSummary::from(&local_progress),
            "learning_rate_changes": learning_rate_changes,
        }),
    };
    if let (Some(s), Some(extra)) = (&start, provenance.extra.as_object_mut()) {
        extra.insert("init_from".to_owned(), s.provenance_note());
    }
    let model = GarMatNetModel {
        fitting: fitting_net.valid(),
        local: local_net.valid(),
        fitting_norm,
        local_norm,
        meta: ModelMeta {
            template: TemplateInfo::of(data.garment()),
            provenance,
        },
    };
    // The model first, then its split: a run killed in between leaves the new model next to
    // the previous split (or none), which the split fingerprint recorded above exposes; the
    // other order could leave an older model, which may record no fingerprint, next to a
    // split it was not trained with.
    model.save(model_path)?;
    split.write(&split_file)?;
    checkpoint.remove();
    summary.finished = true;
    Ok(summary)
}

impl CheckpointState {
    /// `saved` when there is one (a resume), else `self` (a fresh start); a resume's
    /// checkpoints record this run's fingerprint and learning rate from then on.
    fn merge(self, saved: Option<CheckpointState>) -> Self {
        match saved {
            Some(saved) => CheckpointState {
                fingerprint: self.fingerprint,
                learning_rate: self.learning_rate,
                learning_rate_changes: self.learning_rate_changes,
                ..saved
            },
            None => self,
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::data::split_config::SplitConfig;
    use crate::physics::PhysicsConfig;
    use crate::test_util::{TARGETS, synthetic_dataset, training_lock};
    use garmatnet_core::DisplacementFrame;
    use garmatnet_model::MaterialRange;

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
            displacement_frame: DisplacementFrame::World,
            split: SplitConfig {
                test_materials: TARGETS.iter().map(|s| (*s).to_owned()).collect(),
                ..SplitConfig::default()
            },
            quiet: true,
            ..TrainConfig::default()
        }
    }

    /// Both nets' best dev loss fell well below the untrained one.
    fn assert_both_nets_learned(s: &TrainSummary) {
        for net in [s.fitting.as_ref().unwrap(), s.local.as_ref().unwrap()] {
            assert!(
                net.best_dev_mse < 0.5 * net.initial_dev_mse,
                "dev loss {} did not fall well below the untrained {}",
                net.best_dev_mse,
                net.initial_dev_mse
            );
        }
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
        assert_both_nets_learned(&s);
        let model = GarMatNetModel::load(&model_path, &Device::flex()).unwrap();
        assert_eq!(
            model.vertex_count(),
            TrainingDataset::open(&data, false).unwrap().vertex_count()
        );
        assert!(model.meta.provenance.losses["fitting_dev_mse"].is_finite());
        assert_eq!(model.meta.provenance.command, options.command);
        // The model records the box of its training materials: every training fabric lies
        // inside, and its bounds are theirs.
        let dataset = TrainingDataset::open(&data, false).unwrap();
        let materials = &dataset.spec().materials;
        let training: Vec<[f64; 6]> = materials
            .iter()
            .filter(|m| !TARGETS.contains(&m.name.as_str()))
            .map(|m| m.omega_normalized)
            .collect();
        let range = model.meta.provenance.material_range.unwrap();
        assert_eq!(Some(range), MaterialRange::of(training.iter().copied()));
        assert!(training.iter().all(|m| range.outside(m).is_empty()));
        // It also records the training fabrics themselves, by name, in the dataset's order.
        let recorded = &model.meta.provenance.training_fabrics;
        let expected: Vec<(&str, [f64; 6])> = materials
            .iter()
            .filter(|m| !TARGETS.contains(&m.name.as_str()))
            .map(|m| (m.name.as_str(), m.omega_normalized))
            .collect();
        assert_eq!(
            recorded
                .iter()
                .map(|f| (f.name.as_str(), f.omega))
                .collect::<Vec<_>>(),
            expected
        );
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
    fn mirrored_samples_train_and_are_recorded() {
        let _serial = training_lock();
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 6, 20);
        let model_path = dir.path().join("mirrored.safetensors");
        let config = TrainConfig {
            mirrored_samples: true,
            ..tiny_config(25)
        };
        let s = train(&data, &model_path, &config, &RunOptions::default()).unwrap();
        assert!(s.finished);
        assert_both_nets_learned(&s);
        // The split counts samples; the mirror images are extra training rows.
        assert_eq!(s.samples[0] + s.samples[1], 4 * 18);
        let model = GarMatNetModel::load(&model_path, &Device::flex()).unwrap();
        let recorded = &model.meta.provenance.extra["train_config"];
        assert_eq!(recorded["mirrored_samples"], serde_json::json!(true));
        let back: TrainConfig = serde_json::from_value(recorded.clone()).unwrap();
        assert!(back.same_run(&config));
    }

    /// The sum of the squares of every float parameter of `module`.
    fn squared_norm<M: burn::module::Module>(module: &M) -> f64 {
        struct Sum(f64);
        impl burn::module::ModuleVisitor for Sum {
            fn visit_float<const D: usize>(&mut self, param: &burn::module::Param<Tensor<D>>) {
                let sq = param.val().powf_scalar(2.0).sum().into_scalar::<f32>();
                self.0 += f64::from(sq);
            }
        }
        let mut sum = Sum(0.0);
        module.visit(&mut sum);
        sum.0
    }

    #[test]
    fn weight_decay_shrinks_the_weights_and_still_learns() {
        let _serial = training_lock();
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 6, 20);
        let norm = |weight_decay: f64| {
            let path = dir.path().join(format!("wd{weight_decay}.safetensors"));
            // 40 epochs: on the fitted shirt's toy data, 25 left the decayed run's dev loss
            // at 0.51 of the untrained one, a hair above the bar.
            let config = TrainConfig {
                weight_decay,
                ..tiny_config(40)
            };
            let s = train(&data, &path, &config, &RunOptions::default()).unwrap();
            eprintln!(
                "weight decay {weight_decay}: dev MSE {:?} / {:?}",
                s.fitting.as_ref().map(|n| n.best_dev_mse),
                s.local.as_ref().map(|n| n.best_dev_mse)
            );
            assert_both_nets_learned(&s);
            let model = GarMatNetModel::load(&path, &Device::flex()).unwrap();
            squared_norm(&model.fitting) + squared_norm(&model.local)
        };
        let (plain, decayed) = (norm(0.0), norm(0.5));
        assert!(
            decayed < 0.95 * plain,
            "weight decay 0.5 left the squared weight norm at {decayed}, plain Adam {plain}"
        );
        for bad in [-0.1, 1.0, f64::NAN] {
            let config = TrainConfig {
                weight_decay: bad,
                ..tiny_config(1)
            };
            let err = config.validate().unwrap_err();
            assert!(err.to_string().contains("weight_decay"), "{err}");
        }
    }

    #[test]
    fn a_model_is_evaluated_only_with_the_split_it_was_trained_with() {
        use crate::data::split::Split;
        use crate::evaluation::evaluate::{EvalConfig, EvalInputs, evaluate};
        let _serial = training_lock();
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 6, 20);
        let model_path = dir.path().join("model.safetensors");
        train(&data, &model_path, &tiny_config(1), &RunOptions::default()).unwrap();
        let split_file = split_path(&model_path);
        let own = std::fs::read(&split_file).unwrap();
        let dataset = TrainingDataset::open(&data, false).unwrap();
        let model = GarMatNetModel::load(&model_path, &Device::flex()).unwrap();
        let split = Split::read(&split_file, dataset.dataset_hash()).unwrap();
        assert_eq!(
            model.meta.provenance.split_fingerprint(),
            Some(split.fingerprint().as_str())
        );

        // A new run with another split, stopped before its end, leaves the pair alone.
        let mut reshuffled = tiny_config(3);
        reshuffled.split.seed = 7;
        let stop = RunOptions {
            stop_after_epochs: Some(1),
            ..RunOptions::default()
        };
        assert!(
            !train(&data, &model_path, &reshuffled, &stop)
                .unwrap()
                .finished
        );
        assert_eq!(std::fs::read(&split_file).unwrap(), own);

        // Another run's split next to the model (as an older trainer left it) is refused.
        let other = dataset.split(&reshuffled.split).unwrap();
        assert_ne!(other.fingerprint(), split.fingerprint());
        other.write(&split_file).unwrap();
        let inputs = EvalInputs {
            held_out: Vec::new(),
            data_dir: data.clone(),
            model: model_path.clone(),
            baseline: None,
            compare_model: None,
            out_dir: dir.path().join("eval"),
        };
        let eval = EvalConfig {
            figures: false,
            timing_repeats: 1,
            timing_batch: 2,
            ..EvalConfig::default()
        };
        let err = evaluate(&inputs, &eval).unwrap_err();
        assert!(
            matches!(err, Error::Split { .. }) && err.to_string().contains("not the split"),
            "{err}"
        );

        // A model written before the fingerprint was recorded evaluates as before.
        let mut legacy = model;
        legacy
            .meta
            .provenance
            .extra
            .as_object_mut()
            .unwrap()
            .remove(TrainingProvenance::SPLIT_FINGERPRINT_KEY);
        legacy.save(&model_path).unwrap();
        evaluate(&inputs, &eval).unwrap();
    }

    #[test]
    fn a_low_rank_head_starts_from_pca_and_trains() {
        let _serial = training_lock();
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 6, 20);
        let model_path = dir.path().join("rank.safetensors");
        let config = TrainConfig {
            output_rank: Some(8),
            ..tiny_config(25)
        };
        let s = train(&data, &model_path, &config, &RunOptions::default()).unwrap();
        assert_both_nets_learned(&s);
        let model = GarMatNetModel::load(&model_path, &Device::flex()).unwrap();
        assert_eq!(model.fitting.output_rank(), Some(8));
        assert_eq!(model.local.output_rank(), Some(8));
        let too_big = TrainConfig {
            output_rank: Some(100_000),
            ..tiny_config(1)
        };
        let err = train(
            &data,
            &dir.path().join("big.safetensors"),
            &too_big,
            &RunOptions::default(),
        )
        .unwrap_err();
        assert!(err.to_string().contains("rank"), "{err}");
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
        assert!(
            !split_path(&path).exists(),
            "the split comes with the model"
        );
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

    /// Hybrid training (`--physics-weight`): a toy run trains, its local net's train loss
    /// carries the energy term, and a run killed in the local phase resumes to the
    /// uninterrupted run's numbers (the pairs are drawn from the checkpointed RNG).
    #[test]
    fn a_hybrid_run_trains_with_the_energy_term_and_resumes_exactly() {
        let _serial = training_lock();
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 6, 20);
        let config = TrainConfig {
            physics: PhysicsConfig {
                weight: 0.05,
                batch_size: 2,
                ..PhysicsConfig::default()
            },
            ..tiny_config(3)
        };
        assert_ne!(
            config.fingerprint("d"),
            tiny_config(3).fingerprint("d"),
            "the physics term changes the run"
        );
        let supervised = train(
            &data,
            &dir.path().join("supervised.safetensors"),
            &tiny_config(3),
            &RunOptions::default(),
        )
        .unwrap();
        let full_path = dir.path().join("full.safetensors");
        let full = train(&data, &full_path, &config, &RunOptions::default()).unwrap();
        assert!(full.finished && full_path.exists());
        let (plain, hybrid) = (supervised.local.unwrap(), full.local.clone().unwrap());
        assert_eq!(
            supervised.fitting.unwrap().best_dev_mse,
            full.fitting.clone().unwrap().best_dev_mse,
            "the fitting net is trained as before"
        );
        // The energy per unit weight includes the garment's mean height (about a metre), so
        // the hybrid's train loss carries λ times about that on top of the MSE.
        assert!(
            hybrid.last_train_mse.is_finite()
                && hybrid.last_train_mse > plain.last_train_mse + 0.02,
            "{} vs {}",
            hybrid.last_train_mse,
            plain.last_train_mse
        );
        let path = dir.path().join("resumed.safetensors");
        let stop = |n| RunOptions {
            resume: true,
            stop_after_epochs: Some(n),
            ..RunOptions::default()
        };
        let first = train(&data, &path, &config, &stop(4)).unwrap();
        assert!(!first.finished);
        let last = train(&data, &path, &config, &stop(100)).unwrap();
        assert_eq!(last.resumed_from, Some((Phase::Local, 1)));
        let (a, b) = (full.local.unwrap(), last.local.unwrap());
        assert_eq!(a.best_dev_mse, b.best_dev_mse, "resumed local net differs");
        assert_eq!(a.last_train_mse, b.last_train_mse);
        let bad = TrainConfig {
            physics: PhysicsConfig {
                weight: -1.0,
                ..PhysicsConfig::default()
            },
            ..tiny_config(3)
        };
        assert!(matches!(bad.validate(), Err(Error::InvalidConfig(_))));
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
    fn a_checkpoint_made_before_caught_drapes_were_left_out_is_refused() {
        let _serial = training_lock();
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 6, 20);
        // One training drape sank 5 mm into the body.
        let stats = data
            .join("samples")
            .join(garmatnet_sim::sample_stem(0, 3))
            .join("stats.json");
        let mut json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
        json["stats"]["max_penetration_m"] = serde_json::json!(5e-3);
        std::fs::write(&stats, serde_json::to_vec(&json).unwrap()).unwrap();
        let path = dir.path().join("model.safetensors");
        let stop = RunOptions {
            resume: true,
            stop_after_epochs: Some(1),
            ..RunOptions::default()
        };
        let config = tiny_config(5);
        assert_eq!(train(&data, &path, &config, &stop).unwrap().unsettled, 1);
        // This version's checkpoint resumes.
        train(&data, &path, &config, &stop).unwrap();
        // One keyed as version 0.12 keyed it (configuration and dataset only), which split
        // the drape into training, is refused.
        let hash = TrainingDataset::open(&data, false)
            .unwrap()
            .dataset_hash()
            .to_owned();
        let state = path.with_extension("checkpoint").join("state.json");
        let mut saved: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&state).unwrap()).unwrap();
        saved["fingerprint"] = serde_json::json!(config.resume_fingerprint(&hash));
        std::fs::write(&state, serde_json::to_vec(&saved).unwrap()).unwrap();
        let err = train(&data, &path, &config, &stop).unwrap_err();
        assert!(matches!(err, Error::Checkpoint { .. }), "{err}");
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
        assert!(err.to_string().contains("only the learning rate"), "{err}");
    }

    #[test]
    fn a_run_resumes_with_a_lower_learning_rate_and_records_where() {
        // Error::Diverged's advice: the last good checkpoint goes on at a lower rate.
        let _serial = training_lock();
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 6, 20);
        let path = dir.path().join("model.safetensors");
        let stop_after = |epochs| RunOptions {
            resume: true,
            stop_after_epochs: Some(epochs),
            learning_rate_may_fall: true,
            ..RunOptions::default()
        };
        let first = train(&data, &path, &tiny_config(5), &stop_after(2)).unwrap();
        assert!(first.learning_rate_changes.is_empty());
        let lower = TrainConfig {
            learning_rate: 1e-3,
            ..tiny_config(5)
        };
        // Only when asked for (sweep-alpha, say, resumes on its own), and only lower.
        let unasked = RunOptions {
            learning_rate_may_fall: false,
            ..stop_after(1)
        };
        let err = train(&data, &path, &lower, &unasked).unwrap_err();
        assert!(err.to_string().ends_with("resume at that rate"), "{err}");
        let higher = TrainConfig {
            learning_rate: 1e-2,
            ..tiny_config(5)
        };
        let err = train(&data, &path, &higher, &stop_after(1)).unwrap_err();
        assert!(err.to_string().contains("or a lower one"), "{err}");
        // Killed again after the change, then finished at the lower rate: the change made
        // by the first resume is still recorded, once.
        let second = train(&data, &path, &lower, &stop_after(1)).unwrap();
        let change = LearningRateChange {
            net: "fitting".into(),
            epoch: 2,
            from: 3e-3,
            to: 1e-3,
        };
        assert_eq!(second.learning_rate_changes, vec![change.clone()]);
        let done = train(&data, &path, &lower, &stop_after(100)).unwrap();
        assert!(done.finished);
        assert_eq!(done.learning_rate_changes, vec![change]);
        let model = GarMatNetModel::load(&path, &Device::flex()).unwrap();
        let recorded = &model.meta.provenance.extra["learning_rate_changes"];
        assert_eq!(recorded[0]["from"], 3e-3, "{recorded}");
        assert_eq!(recorded[0]["to"], 1e-3, "{recorded}");
        assert_eq!(recorded.as_array().map(Vec::len), Some(1), "{recorded}");

        // A checkpoint written before the rate could change (its fingerprint covers the
        // rate, it records none) resumes at its own rate and no other.
        let old = dir.path().join("old.safetensors");
        train(&data, &old, &tiny_config(5), &stop_after(1)).unwrap();
        let state_file = CheckpointDir::for_model(&old).path().join("state.json");
        let mut state: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&state_file).unwrap()).unwrap();
        let hash = crate::data::loader::TrainingDataset::open(&data, false)
            .unwrap()
            .dataset_hash()
            .to_owned();
        state["fingerprint"] = tiny_config(5).fingerprint(&hash).into();
        let state = state.as_object_mut().unwrap();
        state.remove("learning_rate");
        state.remove("learning_rate_changes");
        std::fs::write(&state_file, serde_json::to_vec(&state).unwrap()).unwrap();
        let err = train(&data, &old, &lower, &stop_after(1)).unwrap_err();
        assert!(matches!(err, Error::Checkpoint { .. }), "{err}");
        let resumed = train(&data, &old, &tiny_config(5), &stop_after(1)).unwrap();
        assert_eq!(resumed.resumed_from, Some((Phase::Fitting, 1)));
    }

    #[test]
    fn a_divergence_says_why_and_how_to_go_on() {
        let diverged = |loss: f64, kept: &str| {
            Error::Diverged {
                net: "fitting".into(),
                epoch: 3,
                loss,
                learning_rate: 0.01,
                kept: kept.into(),
            }
            .to_string()
        };
        assert!(diverged(f64::NAN, " and train again").contains("(not finite)"));
        let exploding = diverged(2e8, " and train again");
        assert!(exploding.contains("past 1e6: exploding"), "{exploding}");
        assert!(
            exploding.ends_with("(now 0.01) and train again"),
            "{exploding}"
        );
    }

    #[test]
    fn a_second_run_on_the_same_model_path_is_refused_while_the_first_holds_it() {
        let _serial = training_lock();
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 6, 20);
        let path = dir.path().join("model.safetensors");
        let held = garmatnet_core::OutputLock::acquire(
            crate::data::files::sibling(&path, "lock"),
            "model (held by this test)",
        )
        .unwrap();
        let err = train(&data, &path, &tiny_config(2), &RunOptions::default()).unwrap_err();
        assert!(
            err.to_string().contains("another garmatnet process"),
            "{err}"
        );
        assert!(
            !path.exists() && !split_path(&path).exists(),
            "nothing written"
        );
        drop(held);
        train(&data, &path, &tiny_config(2), &RunOptions::default()).unwrap();
        assert!(path.exists());
    }

    #[test]
    fn a_model_path_that_is_its_own_checkpoint_or_lock_is_refused_before_training() {
        let dir = tempfile::tempdir().unwrap();
        // No dataset: the path is refused before the dataset is even opened.
        let data = dir.path().join("no-data");
        for (name, what) in [
            ("m.checkpoint", "checkpoint directory"),
            ("m.lock", "lock file"),
            ("m.LOCK", "lock file"),
            // Not its own split (that is `m.split.split.json`) but model `m`'s.
            ("m.split.json", "split file"),
        ] {
            let path = dir.path().join(name);
            let err = train(&data, &path, &tiny_config(2), &RunOptions::default()).unwrap_err();
            assert!(matches!(err, Error::InvalidConfig(_)), "{name}: {err:?}");
            let message = err.to_string();
            assert!(message.contains(what), "{name}: {message}");
            assert!(message.contains("m.safetensors"), "{name}: {message}");
            assert!(!path.exists(), "{name}: something was written");
        }
        // An existing directory is no model file either.
        let err = train(&data, dir.path(), &tiny_config(2), &RunOptions::default()).unwrap_err();
        assert!(err.to_string().contains("is a directory"), "{err}");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        check_model_path(&dir.path().join("m.safetensors")).unwrap();
        check_model_path(Path::new("model")).unwrap();
    }
}
