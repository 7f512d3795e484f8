//! The model crate's error type: every variant says what went wrong and what to fix.

use std::path::PathBuf;

/// Everything that can go wrong in `garmatnet-model`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Bad input caught by `garmatnet-core` (NaN pose or material, wrong lengths,
    /// out-of-range values, file access). Its message says what to fix.
    #[error(transparent)]
    Core(#[from] garmatnet_core::Error),

    /// A model file could not be read or written. Check that the path exists and that its
    /// directory is writable.
    #[error("cannot access model file `{path}`: {source}")]
    Io {
        /// The file involved.
        path: PathBuf,
        /// The operating system's reason.
        source: std::io::Error,
    },

    /// A model file is damaged or is not a garmatnet model (truncated, bytes changed, a
    /// tensor missing or of the wrong shape, a checksum mismatch). Copy the file again or
    /// re-export it from training; do not edit model files by hand.
    #[error("model file `{path}` is corrupt or not a garmatnet model: {message}")]
    Corrupt {
        /// The file that failed to load.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },

    /// There is no model file where one was expected (the shipped model is missing from a
    /// partial checkout, or a path is wrong). Point `GARMATNET_MODEL` at a model file, or
    /// train one with `garmatnet train`.
    #[error(
        "no model file at `{}`; set the GARMATNET_MODEL environment variable to a model file \
         (or pass --model), or train one with `garmatnet train`",
        path.display()
    )]
    MissingModel {
        /// Where the model was looked for.
        path: PathBuf,
    },

    /// A model file was written by an incompatible version of garmatnet. Re-train or
    /// re-export the model with this version.
    #[error(
        "model file `{path}` has format version {found}, this build reads version {supported}; \
         re-export the model with this version of garmatnet"
    )]
    UnsupportedVersion {
        /// The file involved.
        path: PathBuf,
        /// The version stored in the file.
        found: u32,
        /// The version this build reads and writes.
        supported: u32,
    },

    /// The model was trained for a different garment template than the one it is used with.
    /// Use the model trained for this garment, or re-train on this template.
    #[error(
        "the model was trained for garment template {model_hash} ({model_vertices} vertices), \
         but the garment given has template {garment_hash} ({garment_vertices} vertices); \
         use a model trained on this garment or re-train it"
    )]
    TemplateMismatch {
        /// The template hash stored in the model.
        model_hash: String,
        /// The vertex count stored in the model.
        model_vertices: usize,
        /// The template hash of the garment it was used with.
        garment_hash: String,
        /// The garment's vertex count.
        garment_vertices: usize,
    },

    /// A network configuration is unusable (zero sizes, α outside [0, 1], dropout outside
    /// [0, 1), a rank larger than the output). The message names the field to change.
    #[error("invalid network configuration: {0}")]
    InvalidConfig(String),

    /// A tensor handed to the model has the wrong shape (e.g. a PCA basis whose size does not
    /// match the output). Pass a tensor of the expected shape.
    #[error("{what} has shape {got:?}, expected {expected:?}")]
    Shape {
        /// The tensor involved.
        what: String,
        /// The expected shape.
        expected: Vec<usize>,
        /// The shape given.
        got: Vec<usize>,
    },

    /// The networks produced NaN or infinity. The model is broken (diverged training) or the
    /// input is far outside the training range; re-train or check the input.
    #[error(
        "the prediction for {what} is not finite (first at vertex {vertex}); the model may be broken or the input far outside its training range"
    )]
    NonFiniteOutput {
        /// Which prediction (e.g. `"batch item 3"`).
        what: String,
        /// The first vertex with a non-finite coordinate.
        vertex: usize,
    },

    /// The requested compute device is not available in this build or on this machine.
    /// The message says how to get it (e.g. rebuild with `--features wgpu`).
    #[error("device unavailable: {0}")]
    DeviceUnavailable(String),

    /// A fabric calibration cannot be fitted or does not belong to the model it is used
    /// with (another template or other training fabrics, a version this build does not
    /// read, weights that are not finite or do not sum to one). The message says what to
    /// do; usually: calibrate the fabric again with this model.
    #[error("fabric calibration: {0}")]
    Calibration(String),

    /// A scene operation named a character that is not in the scene. Insert it first.
    #[error("no character with id {0} in the scene; insert it with Scene::insert first")]
    UnknownCharacter(u64),

    /// A name is not one of its kind's options (a device other than `cpu`, `gpu` or `auto`,
    /// a detail level other than `full` or `smooth`). Use one of those listed.
    #[error("unknown {kind} `{name}`; use {options}")]
    UnknownName {
        /// The kind of name, e.g. `"device"`.
        kind: &'static str,
        /// The name that was given.
        name: String,
        /// The names accepted, e.g. `` "`cpu`, `gpu` or `auto`" ``.
        options: &'static str,
    },

    /// An input that must hold something is empty (no samples to fit a normaliser on, no
    /// reference drape or a blank name for a calibration). Give it what the message says it
    /// needs.
    #[error("{what} needs {needs}")]
    EmptyInput {
        /// What was asked for, e.g. `"a calibration"`.
        what: &'static str,
        /// What it needs, e.g. `"at least one reference drape"`.
        needs: &'static str,
    },

    /// A garment vertex's body anchor has no skinning weights, a joint outside the skeleton,
    /// or a non-finite rest point or weight. Take the anchors from the garment template
    /// (`Garment::anchors`) rather than building them by hand.
    #[error(
        "body anchor {anchor} is unusable: it needs a finite rest point and at least one \
         (joint < {joints}, finite weight) pair"
    )]
    InvalidAnchor {
        /// The garment vertex whose anchor is unusable.
        anchor: usize,
        /// The skeleton's joint count, which every joint index must stay below.
        joints: usize,
    },

    /// Mirror averaging was asked of a predictor that knows no mirror twins
    /// ([`crate::Predictor::with_mirror_averaging`] on one built with
    /// [`crate::Predictor::new`]).
    #[error(
        "mirror averaging needs the garment template's mirror twins: build the predictor with \
         Predictor::for_garment, or give them with Predictor::with_mirror_twins \
         (Garment::mirror_twins)"
    )]
    NoMirrorTwins,

    /// Mirror twins that are not a left-right pairing of the template's vertices: each
    /// vertex needs one twin below the vertex count, and the twin's twin must be the vertex.
    /// Take them from the template (`Garment::mirror_twins`).
    #[error(
        "mirror twin of vertex {vertex} is {twin}, which {problem}; give one twin per \
         template vertex ({vertices}), each the twin of its own twin (Garment::mirror_twins)"
    )]
    InvalidMirrorTwins {
        /// The first vertex whose twin is wrong.
        vertex: usize,
        /// The twin given for it.
        twin: usize,
        /// The template's vertex count.
        vertices: usize,
        /// What is wrong: past the vertices, or not paired back.
        problem: &'static str,
    },

    /// One pose of a sequence is unusable (NaN, infinity, a rotation too large); the
    /// sequence was refused before any prediction. Fix or drop that pose.
    #[error("pose {index} of the sequence: {source}")]
    InvalidPose {
        /// The pose's 0-based index in the sequence given.
        index: usize,
        /// What is wrong with it.
        source: garmatnet_core::Error,
    },

    /// A value could not be written as JSON. This is a bug in garmatnet: please report it
    /// with the command that failed.
    #[error("could not serialise {what} as JSON: {source}")]
    Serialize {
        /// What was being written, e.g. `"a fabric calibration"`.
        what: &'static str,
        /// serde_json's reason.
        source: serde_json::Error,
    },
}

/// Shorthand for results in `garmatnet-model`.
pub type Result<T, E = Error> = std::result::Result<T, E>;
