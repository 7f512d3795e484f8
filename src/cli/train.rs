//! `garmatnet train`, `train-baseline` and `sweep-alpha`: training from a dataset directory.

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use garmatnet::core::{DisplacementFrame, Resolution};
use garmatnet::model::{GarMatNetModel, PoseEncoding, select_device};
use garmatnet::train::{
    BASELINE_MANIFEST, BaselineConfig, EvalConfig, LearningRateSchedule, PAPER_ALPHAS,
    PhysicsOnlyConfig, RunOptions, TrainConfig, TrainSummary, sweep_alpha, train, train_baseline,
    train_physics_only,
};

/// Options shared by every training command (defaults: the paper's protocol).
#[derive(Debug, Args)]
pub struct TrainOptions {
    /// The dataset directory (from `garmatnet simulate`); required except by
    /// `train --physics-only`.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// A JSON `TrainConfig` to start from (missing fields take defaults; flags override it).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Compute device: cpu, gpu (build with --features wgpu) or auto.
    #[arg(long)]
    pub device: Option<String>,
    /// Seed of the weights, dropout and the batch shuffles. The train/development split has
    /// its own seed (`split.seed` in `--config`, default 42), so models trained with
    /// different `--seed` share one split and can be averaged (`garmatnet ensemble`).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Adam's learning rate (at the first epoch).
    #[arg(long)]
    pub lr: Option<f64>,
    /// How the learning rate changes over each net's epochs: `constant` (default) or
    /// `cosine` (annealed to 1 % of `--lr` at `--max-epochs`).
    #[arg(long)]
    pub lr_schedule: Option<LearningRateSchedule>,
    /// Mini-batch size.
    #[arg(long)]
    pub batch_size: Option<usize>,
    /// The most epochs per net.
    #[arg(long)]
    pub max_epochs: Option<usize>,
    /// Early-stopping patience of the fitting net (paper: 50).
    #[arg(long)]
    pub patience_fitting: Option<usize>,
    /// Early-stopping patience of the local net (paper: 200).
    #[arg(long)]
    pub patience_local: Option<usize>,
    /// Hidden sizes: pose branch, material branch, merged layer (e.g. 512,64,512).
    #[arg(long, value_delimiter = ',')]
    pub hidden: Option<Vec<usize>>,
    /// Dropout probability.
    #[arg(long)]
    pub dropout: Option<f64>,
    /// Decoupled weight decay (AdamW) per step, relative to the learning rate (e.g. 0.01);
    /// default 0: plain Adam, as the paper trains.
    #[arg(long)]
    pub weight_decay: Option<f64>,
    /// Low-rank output head with this many principal components (smaller, faster model).
    #[arg(long)]
    pub rank: Option<usize>,
    /// Hybrid physics-informed training: the local net's loss adds λ times the drape
    /// energy per unit weight (metres) of the full prediction at (pose, fabric) pairs drawn
    /// every step (fabrics uniform in normalised ω, poses from `--physics-poses`).
    /// Default 0: off.
    #[arg(long, value_name = "λ")]
    pub physics_weight: Option<f64>,
    /// (pose, fabric) pairs per step of the physics term (default 8).
    #[arg(long)]
    pub physics_batch: Option<usize>,
    /// The poses of the physics term and of `--physics-only`: `sampler[:SEED[:H,R]]`
    /// (default, seed 1: the independent-pose sampler of `simulate --poses N`; `H,R` its
    /// fractions of arms hanging and raised, as `simulate --arm-bands`) or
    /// `joint-limits[:AMPLITUDE]` (each joint uniform within that fraction of its range).
    #[arg(long, value_name = "KIND[:VALUE]")]
    pub physics_poses: Option<String>,
    /// The weight controller α ∈ [0, 1] (paper §3.6).
    #[arg(long)]
    pub alpha: Option<f64>,
    /// Displacement frame: world or canonical.
    #[arg(long)]
    pub frame: Option<String>,
    /// Make the nets blind to scaling every stiffness and the density by one factor (a
    /// static drape does not change under it): they see stiffness-to-weight ratios.
    #[arg(long)]
    pub scale_free_material: bool,
    /// How the nets read the pose: `axis-angle` (the paper's 72 numbers, default) or
    /// `rotation-matrix` (each joint's R − I, 216 numbers).
    #[arg(long)]
    pub pose_encoding: Option<PoseEncoding>,
    /// The unseen target materials (default: the paper's four), comma-separated; `none`
    /// trains on every fabric and tests on the held-out poses alone (a model to ship).
    #[arg(long, value_delimiter = ',')]
    pub test_materials: Option<Vec<String>>,
    /// Held-out poses: `EVERY` (frames divisible by it; paper: 10) or `EVERY,BLOCK` (runs of
    /// BLOCK consecutive frames starting at each multiple of EVERY, e.g. 100,10).
    #[arg(long, value_delimiter = ',')]
    pub held_out: Option<Vec<usize>>,
    /// Training fabrics to hold out as the development set (comma-separated) instead of a
    /// random 10 %: early stopping then rewards generalising to unseen fabrics.
    #[arg(long, value_delimiter = ',')]
    pub dev_materials: Option<Vec<String>>,
    /// Hold out, as the development set, every training fabric at the frames f with
    /// f % EVERY == OFFSET (EVERY from --held-out; e.g. 5 with every 10th frame held out for
    /// test) instead of a random 10 %: early stopping then rewards generalising to unseen
    /// poses.
    #[arg(long, value_name = "OFFSET")]
    pub dev_frames: Option<usize>,
    /// Leave samples whose drape did not settle (final residual above this, in vertex
    /// weights, e.g. 0.1) out of training and development; default: no residual limit.
    /// Drapes caught in the body (recorded penetration past 1 mm: torn or snagged cloth,
    /// listed by `dataset check`) are always left out. Test sets keep them.
    #[arg(long)]
    pub max_train_residual: Option<f64>,
    /// Train on an incomplete dataset (missing samples are skipped).
    #[arg(long)]
    pub allow_incomplete: bool,
    /// Train on each training sample's mirror image too (the mirrored drape at the mirrored
    /// pose): twice the training rows at no solver cost, and nets that learn the left-right
    /// symmetry that mirror averaging otherwise imposes after the fact.
    #[arg(long)]
    pub mirrored_samples: bool,
    /// No progress: neither the bar on a terminal nor, elsewhere, the progress lines (one a
    /// minute; `GARMATNET_PROGRESS_SECS` sets the interval).
    #[arg(long)]
    pub quiet: bool,
}

impl TrainOptions {
    /// The dataset directory.
    ///
    /// # Errors
    /// When `--data` was not given.
    pub fn data(&self) -> Result<&PathBuf> {
        self.data
            .as_ref()
            .ok_or_else(|| anyhow::anyhow!("--data <DIR> is required (the dataset to train on)"))
    }

    /// The training configuration these options describe.
    pub fn config(&self) -> Result<TrainConfig> {
        let mut c = match &self.config {
            Some(p) => super::read_settings_file(p)?,
            None => TrainConfig::default(),
        };
        if let Some(v) = &self.device {
            c.device = v.clone();
        }
        if let Some(v) = self.seed {
            c.seed = v;
        }
        if let Some(v) = self.lr {
            c.learning_rate = v;
        }
        if let Some(v) = self.lr_schedule {
            c.learning_rate_schedule = v;
        }
        if let Some(v) = self.batch_size {
            c.batch_size = v;
        }
        if let Some(v) = self.max_epochs {
            c.max_epochs = v;
        }
        if let Some(v) = self.patience_fitting {
            c.patience_fitting = v;
        }
        if let Some(v) = self.patience_local {
            c.patience_local = v;
        }
        if let Some(h) = &self.hidden {
            let [pose, material, merged] = h[..] else {
                anyhow::bail!(
                    "--hidden takes three sizes (pose, material, merged), e.g. 512,64,512"
                );
            };
            (c.pose_hidden, c.material_hidden, c.hidden) = (pose, material, merged);
        }
        if let Some(v) = self.dropout {
            c.dropout = v;
        }
        if let Some(v) = self.weight_decay {
            c.weight_decay = v;
        }
        if self.rank.is_some() {
            c.output_rank = self.rank;
        }
        if let Some(v) = self.physics_weight {
            c.physics.weight = v;
        }
        if let Some(v) = &self.physics_poses {
            c.physics.poses = v.parse()?;
        }
        if let Some(v) = self.physics_batch {
            c.physics.batch_size = v;
        }
        if let Some(v) = self.alpha {
            c.alpha = v;
        }
        if self.scale_free_material {
            c.scale_free_material = true;
        }
        if let Some(e) = self.pose_encoding {
            c.pose_encoding = e;
        }
        if let Some(f) = &self.frame {
            c.displacement_frame = match f.to_ascii_lowercase().as_str() {
                "world" => DisplacementFrame::World,
                "canonical" => DisplacementFrame::Canonical,
                other => anyhow::bail!("--frame {other}: use world or canonical"),
            };
        }
        if let Some(names) = &self.test_materials {
            c.split.test_materials = match &names[..] {
                [only] if only.trim().eq_ignore_ascii_case("none") => Vec::new(),
                _ => names.iter().map(|n| n.trim().to_owned()).collect(),
            };
        }
        if let Some(names) = &self.dev_materials {
            c.split.dev_materials = names.iter().map(|n| n.trim().to_owned()).collect();
        }
        if let Some(offset) = self.dev_frames {
            c.split.dev_frame_offset = Some(offset);
        }
        if let Some(h) = &self.held_out {
            (c.split.held_out_frame_every, c.split.held_out_block) = match h[..] {
                [every] => (every, 1),
                [every, block] => (every, block),
                _ => anyhow::bail!("--held-out takes EVERY or EVERY,BLOCK, e.g. 10 or 100,10"),
            };
        }
        if let Some(r) = self.max_train_residual {
            c.split.max_train_residual = Some(r);
        }
        c.allow_incomplete_dataset |= self.allow_incomplete;
        c.mirrored_samples |= self.mirrored_samples;
        c.quiet |= self.quiet;
        Ok(c)
    }
}

/// Train a GarMatNet model (both nets) with early stopping; resumable.
#[derive(Debug, Args)]
pub struct TrainArgs {
    #[command(flatten)]
    pub options: TrainOptions,
    /// The model file to write (`.safetensors`); its split file is written next to it.
    #[arg(long)]
    pub out: PathBuf,
    /// Continue from the checkpoint next to `--out` after an interrupted run, with the same
    /// settings; after a divergence, with a lower `--lr` (the change is recorded).
    #[arg(long)]
    pub resume: bool,
    /// Fine-tune: start both nets from this trained model (`.safetensors`, e.g. the shipped
    /// one) and keep its normalisers, instead of fresh nets; the dataset must be of the
    /// model's garment, and `--test-materials` must not name a fabric it trained on (the
    /// shipped model: `none`). The architecture (`--hidden`, `--rank`, `--alpha`, `--frame`,
    /// `--pose-encoding`, `--scale-free-material`) is the model's unless a flag sets it, also
    /// over a `--config` file's. A lower `--lr` than a fresh run's keeps more of what the
    /// model learned.
    #[arg(long)]
    pub init_from: Option<PathBuf>,
    /// Train from the solver's drape energy alone, with no dataset (`--data` is not read):
    /// both nets together, on (pose, fabric) pairs drawn every step, for the T-shirt at
    /// `--resolution` on the neutral body. `--batch-size` is the pairs per step,
    /// `--patience-local` the early-stopping patience on a fixed held-out batch.
    #[arg(long)]
    pub physics_only: bool,
    /// The T-shirt's resolution for `--physics-only`: coarse, default or paper.
    #[arg(long, default_value = "default")]
    pub resolution: String,
    /// Steps (fresh pairs each) per epoch of `--physics-only`.
    #[arg(long, default_value_t = 50)]
    pub steps_per_epoch: usize,
}

/// Train the TailorNet-style baseline: one pose-only net per target material.
#[derive(Debug, Args)]
pub struct TrainBaselineArgs {
    #[command(flatten)]
    pub options: TrainOptions,
    /// The baseline directory to write.
    #[arg(long)]
    pub out: PathBuf,
}

/// Reproduce the paper's Table 3: train and evaluate one model per α.
#[derive(Debug, Args)]
pub struct SweepAlphaArgs {
    #[command(flatten)]
    pub options: TrainOptions,
    /// The output directory (one model and report per α, plus the table).
    #[arg(long)]
    pub out: PathBuf,
    /// The α values (default: 0.1, 0.3, 0.5, 0.7, 0.9).
    #[arg(long, value_delimiter = ',')]
    pub alphas: Option<Vec<f64>>,
}

/// `config` with the architecture of the model at `path` wherever no flag of `options` set
/// one, and that model to start from.
fn fine_tune_config(
    mut config: TrainConfig,
    options: &TrainOptions,
    path: &std::path::Path,
) -> Result<TrainConfig> {
    let model = GarMatNetModel::load(path, &select_device("cpu")?)
        .with_context(|| format!("--init-from {}", path.display()))?;
    let net = model.fitting.config();
    if options.hidden.is_none() {
        (config.pose_hidden, config.material_hidden, config.hidden) =
            (net.pose_hidden, net.material_hidden, net.hidden);
    }
    if options.rank.is_none() {
        config.output_rank = net.output_rank;
    }
    if options.alpha.is_none() {
        config.alpha = net.alpha;
    }
    if options.frame.is_none() {
        config.displacement_frame = net.displacement_frame;
    }
    if options.pose_encoding.is_none() {
        config.pose_encoding = net.pose_encoding;
    }
    if !options.scale_free_material {
        config.scale_free_material = net.scale_free_material;
    }
    config.init_from = Some(path.to_owned());
    Ok(config)
}

/// Runs `train`.
pub fn run_train(args: &TrainArgs) -> Result<()> {
    let mut config = args.options.config()?;
    // From the flag or from a `--config` file.
    if let Some(path) = args.init_from.clone().or_else(|| config.init_from.clone()) {
        anyhow::ensure!(
            !args.physics_only,
            "--init-from fine-tunes on a dataset; --physics-only trains without one"
        );
        config = fine_tune_config(config, &args.options, &path)?;
    }
    let options = RunOptions {
        command: std::env::args().collect::<Vec<_>>().join(" "),
        resume: args.resume,
        stop_after_epochs: None,
        // The way on after a divergence: `--resume` with a lower `--lr`.
        learning_rate_may_fall: args.resume,
    };
    if args.physics_only {
        let resolution = Resolution::ALL
            .into_iter()
            .find(|r| r.name().eq_ignore_ascii_case(args.resolution.trim()))
            .ok_or_else(|| {
                anyhow::anyhow!(
                    "--resolution {}: use coarse, default or paper",
                    args.resolution
                )
            })?;
        // Unset flags take physics-only training's defaults, not supervised training's.
        let (o, d) = (&args.options, PhysicsOnlyConfig::default().train);
        let poses = config.physics.poses.clone();
        let physics = PhysicsOnlyConfig {
            train: TrainConfig {
                batch_size: o.batch_size.unwrap_or(d.batch_size),
                max_epochs: o.max_epochs.unwrap_or(d.max_epochs),
                patience_local: o.patience_local.unwrap_or(d.patience_local),
                dropout: o.dropout.unwrap_or(d.dropout),
                ..config
            },
            resolution,
            steps_per_epoch: args.steps_per_epoch,
            poses,
            ..PhysicsOnlyConfig::default()
        };
        let s = train_physics_only(&args.out, &physics, &options)?;
        outln!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "finished": s.finished,
                "model_path": s.model_path,
                "checkpoint_dir": s.checkpoint_dir,
                "resumed_from_epoch": s.resumed_from,
                "progress": s.progress,
            }))?
        )?;
        return Ok(());
    }
    let summary = train(args.options.data()?, &args.out, &config, &options)?;
    outln!("{}", serde_json::to_string_pretty(&summary)?)?;
    if config.init_from.is_some() {
        for warning in kept_start_warnings(&summary) {
            warnln!("{warning}");
        }
    }
    Ok(())
}

/// A fine-tuning run's nets that kept the starting model's weights (`best_epoch` 0: no epoch
/// beat its development loss), each with what that usually means and what to do.
fn kept_start_warnings(summary: &TrainSummary) -> Vec<String> {
    [
        ("generally-fitting", &summary.fitting),
        ("locally-detailed", &summary.local),
    ]
    .into_iter()
    .filter_map(|(name, net)| {
        let net = net.as_ref().filter(|n| n.epochs > 0 && n.best_epoch == 0)?;
        Some(format!(
            "warning: the {name} net kept the starting model's weights: none of its {} epochs beat \
             the start's development loss ({:.4}). The development set is drawn from this \
             dataset's samples; if the starting model trained on many of them (a fine-tuned model \
             fine-tuned again on a superset of its data), it already fits them. Start from a model \
             this data is new to.",
            net.epochs, net.initial_dev_mse
        ))
    })
    .collect()
}

/// Refuses a `--config` file's `init_from` where training starts from fresh nets only.
fn no_init_from(config: &TrainConfig, command: &str) -> Result<()> {
    anyhow::ensure!(
        config.init_from.is_none(),
        "`{command}` trains fresh nets: remove `init_from` from the --config file \
         (`train --init-from` fine-tunes a model)"
    );
    Ok(())
}

/// Runs `train-baseline`.
pub fn run_train_baseline(args: &TrainBaselineArgs) -> Result<()> {
    let config = args.options.config()?;
    no_init_from(&config, "train-baseline")?;
    let config = BaselineConfig::from_train_config(&config);
    let manifest = train_baseline(args.options.data()?, &args.out, &config)?;
    // How each material's nets trained; the normalisers and the rest of the manifest stay in
    // `baseline.json` (printed whole they ran to 130,000 lines for a 30 x 200 dataset).
    let materials: Vec<_> = manifest
        .materials
        .iter()
        .map(|m| {
            serde_json::json!({
                "material": m.name,
                "samples_train_dev_test": m.samples,
                "replicate": m.replicate,
                "fitting": m.fitting,
                "local": m.local,
            })
        })
        .collect();
    outln!("{}", serde_json::to_string_pretty(&materials)?)?;
    outln!(
        "baseline written to {}",
        args.out.join(BASELINE_MANIFEST).display()
    )?;
    Ok(())
}

/// Runs `sweep-alpha`.
pub fn run_sweep_alpha(args: &SweepAlphaArgs) -> Result<()> {
    let config = args.options.config()?;
    no_init_from(&config, "sweep-alpha")?;
    let alphas = args.alphas.clone().unwrap_or_else(|| PAPER_ALPHAS.to_vec());
    let eval = EvalConfig {
        device: config.device.clone(),
        ..EvalConfig::default()
    };
    let rows = sweep_alpha(args.options.data()?, &args.out, &alphas, &config, &eval)?;
    outln!("{}", serde_json::to_string_pretty(&rows)?)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: TrainArgs,
    }

    #[test]
    fn a_fine_tune_that_kept_its_start_is_warned_about_net_by_net() {
        let net = |epochs, best_epoch| garmatnet::train::NetSummary {
            epochs,
            best_epoch,
            best_dev_mse: 0.05,
            initial_dev_mse: 0.05,
            last_train_mse: 0.06,
            seconds_per_epoch: 1.0,
        };
        let summary = |fitting, local| TrainSummary {
            finished: true,
            model_path: "m.safetensors".into(),
            split_path: "m.split.json".into(),
            checkpoint_dir: "m.checkpoint".into(),
            resumed_from: None,
            learning_rate_changes: Vec::new(),
            fitting,
            local,
            samples: [90, 10, 10],
            unsettled: 0,
        };
        let warnings = kept_start_warnings(&summary(Some(net(50, 0)), Some(net(150, 12))));
        assert_eq!(warnings.len(), 1, "{warnings:?}");
        assert!(
            warnings[0].contains("generally-fitting net kept"),
            "{}",
            warnings[0]
        );
        assert!(
            warnings[0].contains("none of its 50 epochs"),
            "{}",
            warnings[0]
        );
        assert!(warnings[0].contains("(0.0500)"), "{}", warnings[0]);
        let both = kept_start_warnings(&summary(Some(net(50, 0)), Some(net(200, 0))));
        assert_eq!(both.len(), 2);
        assert!(both[1].contains("locally-detailed"), "{}", both[1]);
        // Nets that improved, or that have not trained yet, draw no warning.
        assert!(kept_start_warnings(&summary(Some(net(100, 99)), None)).is_empty());
        assert!(kept_start_warnings(&summary(Some(net(0, 0)), None)).is_empty());
    }

    fn config(extra: &[&str]) -> TrainConfig {
        let mut argv = vec!["garmatnet", "--data", "d", "--out", "m.safetensors"];
        argv.extend_from_slice(extra);
        Cli::try_parse_from(argv)
            .unwrap()
            .args
            .options
            .config()
            .unwrap()
    }

    #[test]
    fn test_materials_none_trains_on_every_fabric() {
        assert!(
            config(&["--test-materials", "none"])
                .split
                .test_materials
                .is_empty()
        );
        assert_eq!(
            config(&["--test-materials", "Felt, Tulle"])
                .split
                .test_materials,
            vec!["Felt", "Tulle"]
        );
        assert_eq!(config(&[]).split.test_materials.len(), 4);
    }

    #[test]
    fn init_from_takes_the_models_architecture_unless_a_flag_sets_it() {
        let shipped = garmatnet::model::SHIPPED_MODEL;
        let fine_tune = |extra: &[&str]| {
            let mut argv = vec!["garmatnet", "--data", "d", "--out", "m.safetensors"];
            argv.extend_from_slice(extra);
            let args = Cli::try_parse_from(argv).unwrap().args;
            let path = args.init_from.clone().unwrap();
            fine_tune_config(args.options.config().unwrap(), &args.options, &path)
        };
        let c = fine_tune(&["--init-from", shipped]).unwrap();
        let model = GarMatNetModel::load(shipped, &select_device("cpu").unwrap()).unwrap();
        let net = model.fitting.config();
        assert_eq!(c.output_rank, net.output_rank);
        assert!(
            c.output_rank.is_some(),
            "the shipped model has a low-rank head"
        );
        assert_eq!(
            (c.pose_hidden, c.material_hidden, c.hidden),
            (net.pose_hidden, net.material_hidden, net.hidden)
        );
        assert_eq!(c.init_from.as_deref(), Some(std::path::Path::new(shipped)));
        // A flag wins (and the trainer then refuses the mismatch, naming it).
        let c = fine_tune(&["--init-from", shipped, "--rank", "7"]).unwrap();
        assert_eq!(c.output_rank, Some(7));
        assert!(fine_tune(&["--init-from", "no-such-model.safetensors"]).is_err());
    }
}
