//! The simulation crate's error type: every variant says what went wrong and what to fix.

use garmatnet_core::Real;

/// Everything that can go wrong in `garmatnet-sim`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// Invalid input caught by the core checks (non-finite values, out-of-range indices,
    /// wrong lengths, mismatched topologies). The wrapped message names the input to fix.
    #[error(transparent)]
    Core(#[from] garmatnet_core::Error),
    /// The sparse Cholesky factorisation failed: the system matrix is not positive definite
    /// or memory ran out. Check that masses, stiffnesses and the pseudo time step are
    /// positive and finite; a time step so large that `mass / h^2` underflows also breaks it.
    #[error(
        "sparse Cholesky factorisation failed: {0}; check masses, stiffnesses and the time step"
    )]
    Factorization(String),
    /// The iteration produced NaN or infinite positions. Reduce the pseudo time step or the
    /// stiffness range, and check that the collider's distance field is finite near the cloth.
    #[error(
        "drape diverged at iteration {iteration}: positions became non-finite; reduce the time step or check the collider"
    )]
    Diverged {
        /// The iteration at which non-finite positions appeared.
        iteration: usize,
    },
    /// A pose puts two parts of the body closer than allowed: an arm through (or within the
    /// cloth's gap of) the torso, a forearm through a thigh, the legs through each other. See
    /// [`crate::SelfIntersection`]. Lift or turn the limb away, or pick another pose.
    #[error(
        "the body passes through itself: the `{joint_a}` and `{joint_b}` capsules are \
         {gap_m:.4} m apart (negative: overlapping), at least {required_m:.4} m required; move \
         the limb away"
    )]
    SelfIntersecting {
        /// The joint carrying one of the two capsules (SMPL name).
        joint_a: &'static str,
        /// The joint carrying the other capsule (SMPL name).
        joint_b: &'static str,
        /// The gap between their surfaces (metres; negative where they overlap).
        gap_m: f64,
        /// The smallest gap allowed between them (metres).
        required_m: f64,
    },
    /// The pose sampler drew `attempts` poses for index `index` and none was within the
    /// joint limits and free of self-intersection. Loosen the sampler's settings (a smaller
    /// arm gap, wider limits) or raise its `max_attempts`.
    #[error(
        "no admissible pose for index {index} in {attempts} draws; loosen the pose sampler's \
         arm gap or limits, or raise max_attempts"
    )]
    PoseSamplingExhausted {
        /// The index of the pose that could not be drawn.
        index: u64,
        /// How many poses were drawn and refused.
        attempts: usize,
    },
    /// A template has no left-right mirror map: the mirror image (x negated) of `vertex`'s
    /// rest position has no vertex of its own within [`crate::MIRROR_TOLERANCE`] (or shares
    /// its twin with another vertex, `nearest_twin_m` then 0). Mirror asymmetry is defined
    /// only for templates built mirror-symmetric about the body's sagittal plane `x = 0`.
    #[error(
        "the template is not mirror-symmetric about x = 0: vertex {vertex}'s mirror image is \
         {nearest_twin_m} m from the nearest vertex (or shares its twin)"
    )]
    NotMirrorSymmetric {
        /// The first vertex without a twin.
        vertex: usize,
        /// How far (metres) the nearest vertex lies from its mirror image.
        nearest_twin_m: Real,
    },
    /// An existing dataset (resumed, or built on with `--reuse`) was made with other
    /// settings than the new run asks for: `field` says which. Use a new directory, or the
    /// settings the dataset was made with (its `manifest.json` records them).
    #[error("{what}: expected {expected}, got {got}")]
    SpecMismatch {
        /// Which part of the dataset's spec differs.
        field: SpecField,
        /// What differs, and what to do about it.
        what: String,
        /// The existing dataset's value.
        expected: String,
        /// The new run's value.
        got: String,
    },
    /// A `--frame` was given with no pose file to pick from. Give `--pose FILE --frame N`,
    /// or `--pose N` alone for frame N of the built-in motion.
    #[error(
        "--frame picks a pose from a pose file, but {reason}: give `--pose FILE --frame N`, \
         or `--pose N` alone for frame N of the built-in motion"
    )]
    FrameWithoutPoseFile {
        /// Why there is no file to pick from, e.g. `"no --pose was given"`.
        reason: String,
    },
    /// A frame range is not written in a form garmatnet reads. Write `START..END` (END
    /// excluded), `START..=END`, `START..` or `all`.
    #[error(
        "cannot read the frames `{text}`: write START..END (END excluded), START..=END, \
         START.. or all, e.g. 0..120"
    )]
    MalformedFrames {
        /// The range as written.
        text: String,
    },
    /// A frame range names no frame. END must lie past START.
    #[error("the frames `{text}` name no pose: END must lie past START")]
    EmptyFrames {
        /// The range as written.
        text: String,
    },
    /// Dataset generation was asked to stop (e.g. Ctrl-C or a test's simulated kill).
    /// Finished samples are on disk; run the same command again to resume.
    #[error("interrupted; finished samples are saved, run the same command again to resume")]
    Interrupted,
}

/// The part of a dataset's spec ([`crate::DatasetSpec`]) in which two datasets differ.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum SpecField {
    /// The ground-truth revision (which solver's drapes).
    GroundTruthRevision,
    /// The drape protocol (canonical or walk).
    Protocol,
    /// The garment template.
    Template,
    /// The body.
    Body,
    /// The materials, by name and ω.
    Materials,
    /// The poses (and their frame numbers).
    Poses,
    /// The solver settings.
    Solver,
    /// The Laplacian smoothing settings.
    Smoothing,
}

/// Shorthand for results in `garmatnet-sim`.
pub type Result<T, E = Error> = std::result::Result<T, E>;
