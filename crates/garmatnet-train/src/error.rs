//! The training crate's error type: every variant says what went wrong and what to fix.

use std::path::PathBuf;

/// A training loss above this counts as divergence even while finite: targets are normalised
/// to unit variance, so a working net's loss is of order 1 and an exploding one passes 1e6
/// long before it overflows.
pub const DIVERGENCE_LOSS: f64 = 1e6;

/// Everything that can go wrong while training or evaluating.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Bad input caught by `garmatnet-core` or the dataset reader (`garmatnet-sim`): a
    /// malformed manifest, a corrupt or missing sample (named in the message), NaN values.
    #[error(transparent)]
    Core(#[from] garmatnet_core::Error),

    /// A model-crate error: an invalid network configuration, a corrupt model file, a
    /// template mismatch.
    #[error(transparent)]
    Model(#[from] garmatnet_model::Error),

    /// The simulator failed (a material outside the physical range, a diverged drape). The
    /// message says what to change.
    #[error(transparent)]
    Sim(#[from] garmatnet_sim::Error),

    /// A file or directory could not be read or written. Check the path and permissions.
    #[error("cannot access `{path}`: {source}")]
    Io {
        /// The file involved.
        path: PathBuf,
        /// The operating system's reason.
        source: std::io::Error,
    },

    /// A training, split or evaluation setting is unusable. The message names the field.
    #[error("invalid configuration: {0}")]
    InvalidConfig(String),

    /// The dataset cannot be used as it is (incomplete, another template, inconsistent body
    /// points). The message names the sample or field; regenerate or complete the dataset.
    #[error("dataset `{dir}` cannot be used: {message}")]
    Dataset {
        /// The dataset directory.
        dir: PathBuf,
        /// What is wrong, naming the sample where there is one.
        message: String,
    },

    /// Target materials named for the test split are not in the dataset. Pick some of the
    /// available ones.
    #[error(
        "test material(s) {missing:?} are not in the dataset; available materials: {available:?}"
    )]
    UnknownMaterials {
        /// The requested names that were not found.
        missing: Vec<String>,
        /// Every material name of the dataset.
        available: Vec<String>,
    },

    /// Training diverged: the loss became NaN or infinite, or exploded past
    /// [`crate::DIVERGENCE_LOSS`]. No model file was written; the last good checkpoint (if
    /// any) is kept, and `train --resume` with a lower `--lr` continues from it (a
    /// checkpoint resumes with another learning rate; every other setting must match).
    #[error(
        "training of the {net} net diverged at epoch {epoch}: the loss is {loss} ({}). No \
         model was written; lower the learning rate (now {learning_rate}){kept}",
        divergence_cause(*.loss)
    )]
    Diverged {
        /// Which net (`fitting`, `local`, `baseline <material> fitting`, ...).
        net: String,
        /// The epoch (1-based) whose loss was not finite.
        epoch: usize,
        /// The offending loss.
        loss: f64,
        /// The learning rate used.
        learning_rate: f64,
        /// How to go on, as the end of a sentence: from the last good checkpoint with
        /// `--resume`, or training again when there is none.
        kept: String,
    },

    /// A split file does not belong to this dataset or model, or would leak test samples
    /// into training. Re-train so that the split is written by the trainer.
    #[error("split `{path}` is unusable: {message}")]
    Split {
        /// The split file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },

    /// A checkpoint cannot be resumed (corrupt, or written with another configuration or
    /// dataset). Delete the checkpoint directory to start over.
    #[error("checkpoint `{path}` cannot be resumed: {message}")]
    Checkpoint {
        /// The checkpoint directory.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },

    /// An output directory already holds the result of another run (other settings), which
    /// would otherwise be reported as this one's. Remove the directory, or choose another
    /// output directory, and run again.
    #[error("`{path}` holds another run's output: {message}")]
    StaleOutput {
        /// The file or directory left by the other run.
        path: PathBuf,
        /// What differs, and what to do.
        message: String,
    },

    /// A report, split, manifest or sweep could not be encoded as JSON. This is a bug in
    /// garmatnet: please report it with the command that failed.
    #[error("cannot encode {what} as JSON: {source}")]
    Serialize {
        /// What was being encoded, e.g. `"the report"`.
        what: &'static str,
        /// serde_json's reason.
        #[source]
        source: serde_json::Error,
    },

    /// An input that must hold something is empty (no training sample to fit an output
    /// normaliser on, no cloth model for an energy batch). Give it what the message says it
    /// needs.
    #[error("{what} needs {needs}")]
    EmptyInput {
        /// What was asked for, e.g. `"an energy batch"`.
        what: &'static str,
        /// What it needs, e.g. `"at least one cloth model"`.
        needs: &'static str,
    },

    /// A tensor's values could not be read back from its device (its storage does not hold
    /// the float type asked for, or the backend failed). Pass a float tensor; if it is one,
    /// this is a bug in garmatnet or the backend: please report it with the command that
    /// failed.
    #[error("cannot read {what} back from the device: {source}")]
    TensorRead {
        /// The tensor, e.g. `"garment positions of a body field"`.
        what: &'static str,
        /// The backend's reason.
        source: burn::tensor::DataError,
    },

    /// Drawing a chart failed (plotters).
    #[error("cannot draw the plot `{path}`: {message}")]
    Plot {
        /// The image being drawn.
        path: PathBuf,
        /// The plotting library's message.
        message: String,
    },
}

impl Error {
    /// An [`Error::Io`] for `path`.
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }
}

/// Shorthand for results in `garmatnet-train`.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Why a loss counts as diverged, for [`Error::Diverged`]'s message.
fn divergence_cause(loss: f64) -> String {
    if loss.is_finite() {
        format!("past {:e}: exploding", DIVERGENCE_LOSS)
    } else {
        "not finite".into()
    }
}
