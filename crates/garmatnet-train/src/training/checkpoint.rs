//! Resumable training checkpoints: the nets being trained, the best weights so far, the
//! optimiser's state and the loop's counters, written after every epoch.
//!
//! # Layout
//! `{model stem}.checkpoint/` next to the model file:
//! - `state.json`: [`CheckpointState`], written atomically *last*; it names the weight files
//!   that belong to it, so a crash at any point leaves the previous complete checkpoint;
//! - `{phase}-e{epoch}-current.bpk`, `{phase}-e{epoch}-best.bpk`,
//!   `{phase}-e{epoch}-optimizer.bpk`: Burn burnpack records (parameter ids preserved, so
//!   the Adam moments match their parameters after a resume);
//! - `fitting-final.bpk`: the finished generally-fitting net while the local net trains.
//!
//! Files that the current `state.json` does not name are removed after each save.

use std::path::{Path, PathBuf};

use burn::module::Module;
use burn::optim::ModuleOptimizer;
use burn::store::ModuleRecord;
use burn::tensor::Bytes;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// The checkpoint format version.
pub const CHECKPOINT_VERSION: u32 = 1;

/// Which net a checkpoint is training.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Phase {
    /// The generally-fitting net (trained first).
    Fitting,
    /// The locally-detailed net.
    Local,
    /// Both nets together, from the drape energy alone ([`crate::train_physics_only`]).
    Physics,
}

impl Phase {
    /// `"fitting"` or `"local"`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Phase::Fitting => "fitting",
            Phase::Local => "local",
            Phase::Physics => "physics",
        }
    }
}

/// The counters of one net's training loop.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NetProgress {
    /// Epochs completed.
    pub epoch: usize,
    /// The best dev loss so far (MSE of normalised outputs).
    pub best_dev: f64,
    /// The epoch (1-based) of the best dev loss; 0 when a fine-tuning run's starting
    /// weights are still the best.
    pub best_epoch: usize,
    /// Epochs since the best dev loss.
    pub since_best: usize,
    /// The dev loss of the net before its first epoch (untrained, or the model a
    /// fine-tuning run starts from).
    pub initial_dev: f64,
    /// The last epoch's training loss.
    pub last_train: f64,
    /// Wall-clock seconds spent training so far.
    pub seconds: f64,
    /// The state of the shuffle RNG at the start of the next epoch (each epoch's shuffle and
    /// dropout seed are derived from it, so a resumed run repeats an uninterrupted one).
    pub rng_state: u64,
}

/// `state.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CheckpointState {
    /// [`CHECKPOINT_VERSION`].
    pub version: u32,
    /// A fingerprint of the training configuration (but its learning rate) and dataset; a
    /// resume with another one is refused.
    pub fingerprint: String,
    /// The learning rate the checkpoint was written with (a resume may lower it after a
    /// divergence); absent from checkpoints written before it was recorded.
    #[serde(default)]
    pub learning_rate: Option<f64>,
    /// Where earlier resumes of this run changed the learning rate.
    #[serde(default)]
    pub learning_rate_changes: Vec<LearningRateChange>,
    /// The net being trained.
    pub phase: Phase,
    /// The finished fitting net's counters, once it is done.
    pub fitting_done: Option<NetProgress>,
    /// The current net's counters.
    pub progress: NetProgress,
    /// Weight file of the current net.
    pub current_file: String,
    /// Weight file of the best net so far.
    pub best_file: String,
    /// Optimiser state file.
    pub optimizer_file: String,
}

/// The checkpoint directory of one training run.
#[derive(Debug, Clone)]
pub struct CheckpointDir {
    dir: PathBuf,
}

/// The file holding the finished fitting net while the local net trains.
const FITTING_FINAL: &str = "fitting-final.bpk";

impl CheckpointDir {
    /// The checkpoint directory of the model at `model_path`: `{stem}.checkpoint/`.
    #[must_use]
    pub fn for_model(model_path: &Path) -> Self {
        Self {
            dir: crate::data::files::sibling(model_path, "checkpoint"),
        }
    }

    /// The start of a training run on `model_path`: creates its directory, takes the
    /// model's lock (one run per model path: its split, checkpoints and model file are
    /// written under it), and returns the lock, the checkpoint directory and, when `resume`,
    /// the saved state (without it, any old checkpoint is removed).
    ///
    /// # Errors
    /// [`Error::Io`] if the directory cannot be made; the lock's error if another run holds
    /// it; as [`Self::read_state`].
    pub(crate) fn open_for_run(
        model_path: &Path,
        resume: bool,
    ) -> Result<(garmatnet_core::OutputLock, Self, Option<CheckpointState>)> {
        if let Some(dir) = model_path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        }
        let lock = garmatnet_core::OutputLock::acquire(
            crate::data::files::sibling(model_path, "lock"),
            &format!("model {}", model_path.display()),
        )?;
        let checkpoint = Self::for_model(model_path);
        let saved = if resume {
            checkpoint.read_state()?
        } else {
            checkpoint.remove();
            None
        };
        Ok((lock, checkpoint, saved))
    }

    /// The directory.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.dir
    }

    /// The saved state, if a checkpoint exists.
    ///
    /// # Errors
    /// [`Error::Checkpoint`] for an unreadable or foreign `state.json`.
    pub fn read_state(&self) -> Result<Option<CheckpointState>> {
        let path = self.dir.join("state.json");
        let bytes = match std::fs::read(&path) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(Error::io(&path, e)),
        };
        let state: CheckpointState = serde_json::from_slice(&bytes)
            .map_err(|e| self.error(format!("bad state.json: {e}")))?;
        if state.version != CHECKPOINT_VERSION {
            return Err(self.error(format!(
                "version {} (this build writes {CHECKPOINT_VERSION})",
                state.version
            )));
        }
        Ok(Some(state))
    }

    /// Saves a checkpoint: weight files first, `state.json` last, then removes stale files.
    ///
    /// # Errors
    /// [`Error::Core`] (I/O) if a file cannot be written; [`Error::Checkpoint`] if Burn
    /// cannot encode a record.
    pub fn save<M: Module>(
        &self,
        state: &mut CheckpointState,
        current: &M,
        best: &M,
        optimizer: &ModuleOptimizer,
    ) -> Result<()> {
        std::fs::create_dir_all(&self.dir).map_err(|e| Error::io(&self.dir, e))?;
        let stem = format!("{}-e{:05}", state.phase.name(), state.progress.epoch);
        state.current_file = format!("{stem}-current.bpk");
        state.best_file = format!("{stem}-best.bpk");
        state.optimizer_file = format!("{stem}-optimizer.bpk");
        self.write_module(&state.current_file, current)?;
        self.write_module(&state.best_file, best)?;
        let bytes = optimizer
            .into_bytes()
            .map_err(|e| self.error(format!("cannot encode the optimiser state: {e}")))?;
        garmatnet_core::write_bytes_atomic(self.dir.join(&state.optimizer_file), &bytes)?;
        let json = serde_json::to_vec_pretty(state)
            .map_err(|e| self.error(format!("cannot encode state.json: {e}")))?;
        garmatnet_core::write_bytes_atomic(self.dir.join("state.json"), &json)?;
        let keep = [
            "state.json",
            FITTING_FINAL,
            &state.current_file,
            &state.best_file,
            &state.optimizer_file,
        ];
        if let Ok(entries) = std::fs::read_dir(&self.dir) {
            for entry in entries.flatten() {
                let name = entry.file_name().to_string_lossy().into_owned();
                if !keep.contains(&name.as_str()) && name.ends_with(".bpk") {
                    let _ = std::fs::remove_file(entry.path());
                }
            }
        }
        Ok(())
    }

    /// Saves the finished fitting net (before the first local-net checkpoint names it).
    ///
    /// # Errors
    /// As [`CheckpointDir::save`].
    pub fn save_fitting_final<M: Module>(&self, net: &M) -> Result<()> {
        std::fs::create_dir_all(&self.dir).map_err(|e| Error::io(&self.dir, e))?;
        self.write_module(FITTING_FINAL, net)
    }

    /// Loads the finished fitting net into `init` (a net of the same configuration).
    ///
    /// # Errors
    /// [`Error::Checkpoint`] if the file is missing or does not fit.
    pub fn load_fitting_final<M: Module>(&self, init: M) -> Result<M> {
        self.load_module(FITTING_FINAL, init)
    }

    /// Loads weight file `name` into `init` (a net of the same configuration).
    ///
    /// # Errors
    /// [`Error::Checkpoint`] if the file is missing, corrupt or does not fit the net.
    pub fn load_module<M: Module>(&self, name: &str, init: M) -> Result<M> {
        let bytes = std::fs::read(self.dir.join(name))
            .map_err(|e| self.error(format!("cannot read {name}: {e}")))?;
        let record = ModuleRecord::from_bytes(Bytes::from_bytes_vec(bytes))
            .map_err(|e| self.error(format!("{name} is corrupt: {e}")))?;
        init.try_load_record(record)
            .map_err(|e| self.error(format!("{name} does not fit the configured net: {e}")))
    }

    /// Loads optimiser state file `name` into `optimizer`.
    ///
    /// # Errors
    /// [`Error::Checkpoint`] if the file is missing or corrupt.
    pub fn load_optimizer(
        &self,
        name: &str,
        optimizer: ModuleOptimizer,
    ) -> Result<ModuleOptimizer> {
        let bytes = std::fs::read(self.dir.join(name))
            .map_err(|e| self.error(format!("cannot read {name}: {e}")))?;
        optimizer
            .from_bytes(Bytes::from_bytes_vec(bytes))
            .map_err(|e| self.error(format!("{name} is corrupt: {e}")))
    }

    /// Deletes the checkpoint (after the final model was written).
    pub fn remove(&self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }

    fn write_module<M: Module>(&self, name: &str, net: &M) -> Result<()> {
        let bytes = net
            .clone()
            .into_record()
            .into_bytes()
            .map_err(|e| self.error(format!("cannot encode {name}: {e}")))?;
        Ok(garmatnet_core::write_bytes_atomic(
            self.dir.join(name),
            &bytes,
        )?)
    }

    fn error(&self, message: String) -> Error {
        Error::Checkpoint {
            path: self.dir.clone(),
            message,
        }
    }
}
/// A resume that went on with another learning rate than its checkpoint was written with
/// (after a divergence, [`Error::Diverged`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LearningRateChange {
    /// The net that was training (`fitting` or `local`; `fitting` at its last epoch when
    /// the change came at the hand-over to the local net).
    pub net: String,
    /// The epochs of that net done at the old rate.
    pub epoch: usize,
    /// The rate the checkpoint was written with.
    pub from: f64,
    /// The rate training went on with.
    pub to: f64,
}
