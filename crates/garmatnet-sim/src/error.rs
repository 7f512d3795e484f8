//! The simulation crate's error type: every variant says what went wrong and what to fix.

use std::path::PathBuf;

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
    /// A dataset spec (the one a run asks for, or one read from a `manifest.json`) is not
    /// self-consistent: `field` says which part, `entry` which pose or material when it is one
    /// of them, and `problem` what is wrong. Build the spec with [`crate::dataset_spec`]; for a
    /// manifest, it was edited or written by other code (or another version of garmatnet):
    /// restore it, or regenerate the dataset.
    #[error("inconsistent dataset spec: {problem}")]
    InvalidSpec {
        /// The part of the spec that is wrong.
        field: SpecField,
        /// The index of the pose or material at fault, when there is one.
        entry: Option<usize>,
        /// What is wrong there, naming the value.
        problem: String,
    },
    /// A sample's (material, pose) index lies outside the dataset. Write only samples with
    /// `material < materials` and `pose < poses`, the counts of the dataset's spec.
    #[error(
        "sample (material {material}, pose {pose}) is outside the dataset's {materials} \
         materials x {poses} poses"
    )]
    SampleOutOfRange {
        /// The material index given.
        material: usize,
        /// The pose index given.
        pose: usize,
        /// The number of materials in the dataset.
        materials: usize,
        /// The number of poses in the dataset.
        poses: usize,
    },
    /// A sample the dataset's strided sample plan does not hold was to be written.
    #[error(
        "sample of material {material} at pose {pose} is not in the dataset's plan (every \
         material at the first {full_poses} poses, then pose p for the materials m with \
         m % {stride} == p % {stride}): drape the samples the plan holds, or make a dataset \
         with another plan"
    )]
    SampleOutsidePlan {
        /// The material index given.
        material: usize,
        /// The pose index given.
        pose: usize,
        /// The plan's stride.
        stride: usize,
        /// How many of the first poses every material drapes under the plan.
        full_poses: usize,
    },
    /// A shard is not `i/k` with `i < k`. Write it as two integers, e.g. `0/4` for the first
    /// of four; the shards of `k` are `0/k` to `(k-1)/k`.
    #[error("shard `{text}` is not of the form i/k with i below k, e.g. 0/4{}", shard_range(*count))]
    InvalidShard {
        /// The shard as written (or as `index/count`).
        text: String,
        /// The shard count `k`, when it was read.
        count: Option<usize>,
    },
    /// A merge names its destination among its sources: merging a dataset into itself would
    /// delete each sample's marker before copying it. Merge the shards into a new or another
    /// directory.
    #[error(
        "{} is both a source and the destination of the merge: merge the shards into a new \
         or another directory",
        path.display()
    )]
    MergeIntoSource {
        /// The source that is the destination.
        path: PathBuf,
    },
    /// A dataset to reuse lists none of this dataset's materials (same name and ω), so it has
    /// nothing to give. Reuse a dataset made with at least one of the same fabrics, or drop it.
    #[error(
        "the dataset to reuse, {}, has none of this dataset's materials (same name and ω): \
         nothing to reuse",
        dataset.display()
    )]
    NothingToReuse {
        /// The dataset to reuse.
        dataset: PathBuf,
    },
    /// A step size of the walk between poses is out of range (see [`StepParameter`] for each
    /// one's range). Give a value in range; [`crate::SequenceSettings::default`] has working
    /// ones.
    #[error("{parameter} must be {}, got {value}", parameter.requirement(*min))]
    StepOutOfRange {
        /// Which step size.
        parameter: StepParameter,
        /// The value given.
        value: f64,
        /// The smallest value allowed.
        min: f64,
    },
    /// A walk was asked to resume at a pose it does not have, or from positions that do not
    /// fit the garment. Resume at a pose from 1 to the number of poses, with the settled
    /// garment of the pose before it (one position per garment vertex).
    #[error(
        "cannot resume at pose {next} of {poses} with {positions} positions for a \
         {vertices}-vertex garment: resume at a pose from 1 to {poses} with one position per \
         vertex"
    )]
    InvalidResume {
        /// The pose to resume at ([`crate::SequenceResume::next`]).
        next: usize,
        /// The number of poses in the walk.
        poses: usize,
        /// The number of positions given.
        positions: usize,
        /// The garment's vertex count.
        vertices: usize,
    },
    /// A spring joins a vertex to itself: it has no direction and pulls on nothing. Remove it.
    #[error("spring {spring} joins vertex {vertex} to itself; remove it")]
    DegenerateSpring {
        /// The spring's index.
        spring: usize,
        /// The vertex at both its ends.
        vertex: usize,
    },
    /// No everyday pose has this name. Use one of the suite's
    /// ([`crate::everyday_pose_names`]; case is ignored).
    #[error("no everyday pose is called `{name}`; the suite has {}", known.join(", "))]
    UnknownEverydayPose {
        /// The name asked for.
        name: String,
        /// The suite's pose names, in order.
        known: Vec<&'static str>,
    },
    /// The solver settings could not be written as JSON for the dataset's spec. This is a bug
    /// in garmatnet: please report it with the command that failed.
    #[error("could not serialise the solver settings: {source}")]
    SettingsJson {
        /// serde_json's reason.
        #[source]
        source: serde_json::Error,
    },
    /// The worker threads could not be started. Ask for fewer threads (`--threads`), or free
    /// system resources (memory, the process limit).
    #[error("cannot start a pool of {threads} worker threads: {source}; ask for fewer threads")]
    ThreadPool {
        /// The number of threads asked for (0: one per core).
        threads: usize,
        /// rayon's reason.
        #[source]
        source: rayon::ThreadPoolBuildError,
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
    /// The sample plan (which materials drape which poses).
    Plan,
}

impl std::fmt::Display for SpecField {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            SpecField::GroundTruthRevision => "ground-truth revision",
            SpecField::Protocol => "drape protocol",
            SpecField::Template => "template",
            SpecField::Body => "body",
            SpecField::Materials => "materials",
            SpecField::Poses => "poses",
            SpecField::Solver => "solver settings",
            SpecField::Smoothing => "smoothing settings",
            SpecField::Plan => "sample plan",
        })
    }
}

/// A step size of the walk between poses ([`crate::SequenceSettings`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum StepParameter {
    /// `max_step_rad`: the largest turn of any joint between intermediate poses (radians),
    /// finite and at least [`crate::MIN_STEP_RAD`] (a smaller step would cut a turn into
    /// millions of poses).
    JointTurn,
    /// `max_surface_step`: the largest distance the skin carries a cloth vertex per
    /// intermediate step (metres), finite and non-negative (0 turns the bound off).
    SurfaceTravel,
}

impl StepParameter {
    /// What a valid value is, for messages, given the smallest one allowed.
    fn requirement(self, min: f64) -> String {
        match self {
            StepParameter::JointTurn => format!("a finite number of radians of at least {min}"),
            StepParameter::SurfaceTravel => {
                "a non-negative number of metres (0 turns it off)".to_owned()
            }
        }
    }
}

impl std::fmt::Display for StepParameter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            StepParameter::JointTurn => "the interpolation step max_step_rad",
            StepParameter::SurfaceTravel => "max_surface_step",
        })
    }
}

/// The shards of `count`, for [`Error::InvalidShard`]'s message.
fn shard_range(count: Option<usize>) -> String {
    match count {
        Some(0) => "; k must be at least 1".to_owned(),
        Some(k) => format!("; the shards of {k} are 0/{k} .. {}/{k}", k - 1),
        None => String::new(),
    }
}

/// Shorthand for results in `garmatnet-sim`.
pub type Result<T, E = Error> = std::result::Result<T, E>;
