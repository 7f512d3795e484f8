//! The evaluation report: `report.json` (machine-readable) and `report.md` (tables, drawn
//! in `report_markdown`), all errors in millimetres.

use std::path::Path;

use garmatnet_model::OutsideComponent;
use serde::{Deserialize, Serialize};

use crate::data::files::make_readable;
use crate::error::{Error, Result};

/// Mean per-vertex Euclidean errors of one part of the pipeline (millimetres).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PartErrors {
    /// |predicted smooth garment − true smooth garment| (generally-fitting net).
    pub fitting_mm: f64,
    /// |predicted D_local − true D_local| (locally-detailed net).
    pub local_mm: f64,
    /// |predicted garment − simulated garment| (whole pipeline).
    pub whole_mm: f64,
}

/// Errors over a set of test samples (the paper's Table 2 plus spread).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ErrorStats {
    /// Mean per-vertex error of the generally-fitting net (mm).
    pub fitting_mm: f64,
    /// Mean per-vertex error of the locally-detailed net (mm).
    pub local_mm: f64,
    /// Mean per-vertex error of the whole pipeline (mm).
    pub whole_mm: f64,
    /// Largest per-vertex whole error (mm).
    pub whole_max_mm: f64,
    /// 95th percentile of per-vertex whole errors (mm).
    pub whole_p95_mm: f64,
    /// Samples evaluated.
    pub samples: usize,
}

/// One test sample's errors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SampleErrors {
    /// The material's name.
    pub material: String,
    /// The pose index.
    pub pose: usize,
    /// The pose's frame in its source sequence.
    pub frame: usize,
    /// The pose's name in a held-out set of named poses, e.g. `arms-crossed`: from the
    /// set's `pose_names.json` ([`garmatnet_sim::POSE_NAMES_FILE`]), else when the pose is
    /// one of today's everyday poses bit for bit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pose_name: Option<String>,
    /// GarMatNet's errors.
    pub garmatnet: PartErrors,
    /// The baseline's errors, when a baseline for this material was given.
    pub baseline: Option<PartErrors>,
}

/// Body penetration of GarMatNet's predictions before and after the push-out post-process.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PenetrationStats {
    /// The push-out clearance ε (mm).
    pub epsilon_mm: f64,
    /// Mean fraction of garment vertices inside the body before push-out.
    pub inside_fraction_before: f64,
    /// The same after push-out.
    pub inside_fraction_after: f64,
    /// Deepest penetration before push-out (mm).
    pub max_depth_before_mm: f64,
    /// Deepest penetration after push-out (mm).
    pub max_depth_after_mm: f64,
    /// Mean per-vertex whole error after push-out (mm).
    pub whole_mm_after: f64,
}

/// How physical GarMatNet's raw predictions are (before the push-out), measured with the solver's
/// own energy and springs.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct PhysicalQuality {
    /// Samples measured.
    pub samples: usize,
    /// The sound stretch `dataset check` flags past (strain, dimensionless).
    pub sound_stretch: f64,
    /// Mean over samples of the largest spring stretch (strain).
    pub mean_max_stretch: f64,
    /// The largest spring stretch of any sample (strain).
    pub worst_stretch: f64,
    /// Samples whose largest stretch is past the sound stretch.
    pub past_sound_stretch: usize,
    /// The ground truth's mean over samples of the largest spring stretch, for reference.
    pub truth_mean_max_stretch: f64,
    /// Mean over samples of the drape energy (springs, gravity, contact; no friction) above
    /// the ground truth's, over the garment's weight (mm: the height the garment would have
    /// to fall to release it). Friction holds the ground truth a little above its
    /// frictionless minimum, so a prediction can come out slightly below it.
    pub mean_energy_above_truth_mm: f64,
    /// The median of the same.
    pub median_energy_above_truth_mm: f64,
    /// Median over samples of the force residual, the solver's stopping measure: RMS over
    /// vertices of the net force (springs, gravity, contact) over the vertex's weight. The
    /// solver stops below its tolerance (RMS 0.001, largest 0.05 by default), friction
    /// included. A median, because a few vertices deep in the contact margin dominate a
    /// sample's RMS.
    #[serde(default)]
    pub median_residual: f64,
    /// The ground truth's median of the same, for reference: above the solver's tolerance by
    /// what friction holds (friction is not part of the energy), by the final projection
    /// out of the body and by rounding the stored drape to f32 against the stiff springs
    /// and contact, so compare predictions with this row, not with the tolerance.
    #[serde(default)]
    pub truth_median_residual: f64,
    /// Mean over samples of the deepest point inside the body (mm).
    #[serde(default)]
    pub mean_depth_mm: f64,
    /// The deepest point inside the body of any sample (mm).
    #[serde(default)]
    pub worst_depth_mm: f64,
    /// The ground truth's deepest point inside the body of any sample (mm), for reference.
    #[serde(default)]
    pub truth_worst_depth_mm: f64,
    /// The solver converging from the prediction, on the samples `eval --newton-samples`
    /// chose; `None` when none was asked for.
    #[serde(default)]
    pub newton: Option<NewtonFromPrediction>,
}

/// The solver run from predictions to its residual criterion: how far from an equilibrium a
/// prediction lies, counted in Newton iterations, beside what the canonical protocol needed.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct NewtonFromPrediction {
    /// Samples polished (spread evenly over the set).
    pub samples: usize,
    /// Mean Newton iterations from the prediction (pushed out of the body) to convergence
    /// or the iteration cap.
    pub mean_iterations: f64,
    /// Samples that met the residual criterion.
    pub converged: usize,
    /// The ground truth's mean iterations on the same samples: those of the canonical
    /// protocol's final converge at the target pose (after its walk from the rest pose).
    pub truth_mean_iterations: f64,
    /// Mean per-vertex distance of the polished drape to the ground truth (mm). Friction
    /// resists slip from where the solver starts, so the polish settles at an equilibrium
    /// near the prediction: this is how far that one lies from the protocol's.
    pub mean_distance_to_truth_mm: f64,
}

/// Inference speed of GarMatNet (both nets, garment assembly included).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Timing {
    /// The device.
    pub device: String,
    /// Milliseconds per frame at batch size 1 (median of the repeats).
    pub batch1_ms_per_frame: f64,
    /// Milliseconds per frame in one batched call.
    pub batched_ms_per_frame: f64,
    /// The batch size of the batched timing.
    pub batch_size: usize,
}

/// Model sizes on disk (MB = 10^6 bytes).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ModelSizes {
    /// The GarMatNet model file.
    pub garmatnet_mb: f64,
    /// The baseline directory (all materials), when given.
    pub baseline_mb: Option<f64>,
}

/// Which displacement frame did better when two models were evaluated on the same split.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameComparison {
    /// `(frame, whole error in mm)` of the primary model.
    pub primary: (String, f64),
    /// `(frame, whole error in mm)` of the other model.
    pub other: (String, f64),
    /// The frame with the smaller whole error.
    pub winner: String,
}

/// GarMatNet's error on each part of the data; `None` for an empty part.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TestParts {
    /// Target (unseen) materials at the training poses: fabric generalisation alone.
    pub unseen_material: Option<ErrorStats>,
    /// Training materials at the held-out poses: pose generalisation alone.
    pub unseen_pose: Option<ErrorStats>,
    /// The development set: with the paper's random split, samples of training fabrics at
    /// training poses that were not trained on; with `dev_materials`, those fabrics' samples.
    pub development: Option<ErrorStats>,
    /// The fabrics held out as the development set (`train --dev-materials`); empty for the
    /// paper's random development fraction.
    #[serde(default)]
    pub dev_materials: Vec<String>,
    /// The development set's frames when it holds out poses (`train --dev-frames`): their
    /// offset and the held-out period, e.g. `(5, 10)`; `None` otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dev_frames: Option<(usize, usize)>,
}

/// GarMatNet's error on a whole held-out dataset of its own (`eval --held-out NAME=DIR`):
/// poses the model never came near, such as the everyday suite or a motion of another seed,
/// draped by the canonical protocol.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeldOutSet {
    /// The set's name, e.g. `everyday` or `held-out motion`.
    pub name: String,
    /// The dataset's directory, as given.
    pub dir: String,
    /// Every sample of the set.
    pub all: ErrorStats,
    /// How many of its true drapes did not meet the solver's residual tolerance (stopped at
    /// its iteration cap; `converged: false` in their stats). They count in
    /// [`HeldOutSet::all`], as unsettled samples count in the test set: they are the solver's
    /// drape all the same.
    #[serde(default)]
    pub unconverged: usize,
    /// Its samples whose true drape met the solver's tolerance, when some did not (`None`
    /// when all did, or none).
    #[serde(default)]
    pub converged_only: Option<ErrorStats>,
    /// Its samples of fabrics the model trained on; `None` if it has none.
    pub training_fabrics: Option<ErrorStats>,
    /// Its samples of fabrics the model never saw; `None` if it has none.
    pub unseen_fabrics: Option<ErrorStats>,
    /// How physical the predictions on it are.
    #[serde(default)]
    pub physical_quality: Option<PhysicalQuality>,
    /// The error per fabric of the set, in the set's order; a fabric the model never trained
    /// on names its nearest training fabric and that distance in normalised ω (empty in
    /// reports written before it was recorded).
    #[serde(default)]
    pub per_material: Vec<MaterialErrors>,
    /// How far predictions and truths are from their own mirror image at the set's
    /// left-right symmetric poses (those equal to their [`garmatnet_core::Pose::mirrored`]);
    /// `None` when it has none (and in reports written before it was measured).
    #[serde(default)]
    pub symmetry: Option<MirrorSymmetry>,
    /// Every sample's errors, material first, then pose (empty in reports written before
    /// they were recorded): which poses of the set the model errs most at.
    #[serde(default)]
    pub per_sample: Vec<SampleErrors>,
}

/// Mirror asymmetry at left-right symmetric poses: per sample, the mean over vertices of
/// `|x_i - mirror(x_twin(i))|` (mm), of the prediction before push-out and of the true
/// drape. A symmetric pose should give a symmetric drape: the library's body is
/// mirror-symmetric, so a mirror-averaged prediction reads float rounding, and the truth
/// what the solver's convergence, f32 storage and drapes that buckle one way leave (0.56 mm
/// on average at the everyday suite's 360 symmetric samples, at most 9.39).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MirrorSymmetry {
    /// Samples at symmetric poses.
    pub samples: usize,
    /// The predictions' asymmetry, mean over those samples (mm).
    pub prediction_mean_mm: f64,
    /// The predictions' asymmetry, largest sample (mm).
    pub prediction_max_mm: f64,
    /// The truths' asymmetry, mean over those samples (mm).
    pub truth_mean_mm: f64,
    /// The truths' asymmetry, largest sample (mm).
    pub truth_max_mm: f64,
}

/// Everything [`crate::evaluate_held_out`] measured: a model on held-out datasets alone,
/// without the dataset it was trained on (the shipped model's case).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HeldOutReport {
    /// The model file, as given.
    pub model: String,
    /// Whether predictions were mirror-averaged ([`crate::EvalConfig::mirror_averaging`]).
    pub mirror_averaging: bool,
    /// The training fabrics the model file records (a held-out fabric counts as seen when
    /// its name and ω match one).
    pub training_fabrics: Vec<String>,
    /// The error on each held-out dataset, in the order given.
    pub held_out_sets: Vec<HeldOutSet>,
}

impl HeldOutReport {
    /// Writes `report.json` and `report.md` into `out_dir`, atomically.
    ///
    /// # Errors
    /// [`Error::Core`] (I/O) if a file cannot be written.
    pub fn write(&self, out_dir: &Path) -> Result<()> {
        write_report(
            out_dir,
            ("the held-out report", self),
            &self.to_markdown(),
            &[],
        )
    }
}

/// A non-learned reference on the Table 2 samples: the true drape, at the same test pose, of
/// a fabric the model trained on. It knows each held-out pose's drapes (no model does), so it
/// is a yardstick of how much fabric alone changes the drape, not a competitor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FabricLookup {
    /// The training fabric nearest in the model's normalised material input ω.
    pub nearest_material: ErrorStats,
    /// Per target material, the training fabric nearest to it.
    pub nearest_to: Vec<(String, String)>,
    /// Per sample, the training fabric whose drape is closest to the truth (an oracle: the
    /// best any method that picks one training fabric's drape can do).
    pub best_material: ErrorStats,
}

/// GarMatNet's error over one material's test samples: every pose of a test material (a
/// fabric the model never trained on), the held-out poses of a training material.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MaterialErrors {
    /// The material's name.
    pub material: String,
    /// Whether it is a test material, i.e. the model never trained on it.
    pub unseen: bool,
    /// The error over its test samples.
    pub garmatnet: ErrorStats,
    /// For a test material, the training fabric nearest to it in normalised ω (absent for
    /// training materials, and in reports written before it was recorded): the model's error
    /// on a fabric it never saw grows with that distance.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nearest_training: Option<NearestTraining>,
}

/// The training fabric nearest to a test material.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NearestTraining {
    /// The training fabric's name.
    pub material: String,
    /// Its Euclidean distance to the test material in normalised ω.
    pub distance: f64,
}

/// Where a test material lies relative to the materials the model trained on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MaterialSupport {
    /// The test material.
    pub material: String,
    /// Its components outside the training materials' per-component range (normalised ω),
    /// empty when it lies inside: there the model interpolates, elsewhere it extrapolates.
    pub outside: Vec<OutsideComponent>,
}

/// Everything [`crate::evaluate`] measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// The dataset fingerprint.
    pub dataset_hash: String,
    /// The model's displacement frame.
    pub displacement_frame: String,
    /// The target (unseen) materials.
    pub test_materials: Vec<String>,
    /// The number of held-out poses.
    pub held_out_poses: usize,
    /// Which frames were held out (e.g. "every 10th frame").
    #[serde(default)]
    pub held_out_rule: String,
    /// GarMatNet on the comparison set: target materials × held-out poses (Table 2).
    pub garmatnet: ErrorStats,
    /// The baseline on the same samples (Table 2), when given.
    pub baseline: Option<ErrorStats>,
    /// GarMatNet on the whole test set (also every material at the held-out poses).
    pub garmatnet_all_test: ErrorStats,
    /// GarMatNet on the parts of the data, to tell pose from fabric generalisation (absent
    /// from reports written before it existed).
    #[serde(default)]
    pub garmatnet_by_part: Option<TestParts>,
    /// The training fabrics' own drapes as a reference on the Table 2 samples (absent from
    /// reports written before it existed, and when no training fabric has the held-out
    /// poses).
    #[serde(default)]
    pub fabric_lookup: Option<FabricLookup>,
    /// Each test material against the training materials' range (absent from reports
    /// written before it existed).
    #[serde(default)]
    pub material_support: Vec<MaterialSupport>,
    /// Per (material, pose) errors on the comparison set (Figs. 7–8).
    pub per_sample: Vec<SampleErrors>,
    /// GarMatNet per material over the whole test set, in the dataset's material order
    /// (absent from reports written before it existed).
    #[serde(default)]
    pub per_material: Vec<MaterialErrors>,
    /// Push-out statistics over the whole test set.
    pub penetration: PenetrationStats,
    /// The physical quality of the raw predictions (before push-out) over the whole test set
    /// (absent from reports written before it existed).
    #[serde(default)]
    pub physical_quality: Option<PhysicalQuality>,
    /// Inference speed.
    pub timing: Timing,
    /// Sizes on disk.
    pub sizes: ModelSizes,
    /// World vs canonical frame, when a second model was given.
    pub frame_comparison: Option<FrameComparison>,
    /// The error on each held-out dataset given to `eval --held-out`, in the order given.
    #[serde(default)]
    pub held_out_sets: Vec<HeldOutSet>,
    /// Whether predictions were mirror-averaged ([`crate::EvalConfig::mirror_averaging`];
    /// `false` in reports written before it existed, which were not).
    #[serde(default)]
    pub mirror_averaging: bool,
    /// Files written next to the report (plots, heat maps, PLY), relative to it.
    pub files: Vec<String>,
}

impl Report {
    /// Writes `report.json` and `report.md` into `out_dir`, atomically.
    ///
    /// # Errors
    /// [`Error::Core`] (I/O) if a file cannot be written.
    pub fn write(&self, out_dir: &Path) -> Result<()> {
        write_report(
            out_dir,
            ("the report", self),
            &self.to_markdown(),
            &self.files,
        )
    }
}

/// Writes `report` as `report.json` and `markdown` as `report.md` into `out_dir`,
/// atomically, and makes them and the `files` written beside them readable to all.
fn write_report(
    out_dir: &Path,
    (what, report): (&'static str, &impl Serialize),
    markdown: &str,
    files: &[String],
) -> Result<()> {
    let json =
        serde_json::to_vec_pretty(report).map_err(|source| Error::Serialize { what, source })?;
    garmatnet_core::write_bytes_atomic(out_dir.join("report.json"), &json)?;
    garmatnet_core::write_bytes_atomic(out_dir.join("report.md"), markdown.as_bytes())?;
    for f in files
        .iter()
        .map(String::as_str)
        .chain(["report.json", "report.md"])
    {
        make_readable(&out_dir.join(f));
    }
    Ok(())
}

/// Mean, max and 95th percentile of per-vertex errors (metres in, millimetres out).
pub(crate) fn spread_mm(errors: &mut [f64]) -> (f64, f64, f64) {
    if errors.is_empty() {
        return (0.0, 0.0, 0.0);
    }
    let mean = errors.iter().sum::<f64>() / errors.len() as f64;
    errors.sort_by(f64::total_cmp);
    let p95 = errors[((errors.len() - 1) as f64 * 0.95).round() as usize];
    let max = errors[errors.len() - 1];
    (mean * 1e3, p95 * 1e3, max * 1e3)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_of_known_values() {
        let mut v: Vec<f64> = (1..=100).map(|i| f64::from(i) * 1e-3).collect();
        let (mean, p95, max) = spread_mm(&mut v);
        approx::assert_relative_eq!(mean, 50.5, epsilon = 1e-9);
        approx::assert_relative_eq!(max, 100.0, epsilon = 1e-9);
        assert!((94.0..=96.0).contains(&p95), "{p95}");
    }
}
