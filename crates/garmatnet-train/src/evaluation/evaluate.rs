//! Evaluation on the test split the model was trained with (paper §4.2, Table 2, Figs. 7–8
//! and 11–12): errors in millimetres, per-pose plots, heat maps, push-out statistics,
//! timing and model sizes.

use std::path::{Path, PathBuf};
use std::time::Instant;

use burn::prelude::*;
use garmatnet_core::{DisplacementFrame, Pose};
use garmatnet_model::material_range::TrainingFabric;
use garmatnet_model::{Detail, GarMatNetModel, push_out, select_device};
use garmatnet_sim::{MirrorMap, POSE_NAMES_FILE, everyday_poses};
use serde::{Deserialize, Serialize};

use crate::data::loader::{SampleKey, TrainingDataset};
use crate::data::split::Split;
use crate::error::Result;
use crate::evaluation::fabric_reference::{fabric_lookup, material_support};
use crate::evaluation::physical_quality::QualityAccumulator;
use crate::evaluation::prediction_errors::{
    Mirror, VertexErrors, error_stats, load_model, load_with_same_test, mirror_of,
    predict_baseline, predict_garmatnet, predictor_for, vertex_errors,
};
use crate::evaluation::report::{
    ErrorStats, FrameComparison, HeldOutReport, HeldOutSet, ModelSizes, Report, SampleErrors,
    TestParts, Timing,
};
use crate::evaluation::sample_measures::{
    PenetrationAccumulator, SymmetryAccumulator, assemble, material_errors, polish_stride,
    sample_errors, truth_iterations,
};
use crate::training::baseline::Baseline;

/// Evaluation settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct EvalConfig {
    /// Compute device: `cpu`, `gpu` or `auto`.
    pub device: String,
    /// The push-out clearance ε (metres).
    pub push_out_epsilon: f64,
    /// Repeats of the batch-1 timing (the median is reported).
    pub timing_repeats: usize,
    /// The batch size of the batched timing.
    pub timing_batch: usize,
    /// Write the per-pose plots, heat maps and PLY files.
    pub figures: bool,
    /// Samples of each set (the test set and every held-out set), spread evenly over it, on
    /// which the solver is run from the prediction to convergence: the physical-quality
    /// row of Newton iterations. 0 (default) skips it; each costs a solve (seconds).
    #[serde(default)]
    pub newton_samples: usize,
    /// Mirror-average every prediction, GarMatNet's and the baseline's, as
    /// [`garmatnet_model::Predictor::with_mirror_averaging`] does (on by default, as in the predictor; the
    /// report records it).
    pub mirror_averaging: bool,
}

impl Default for EvalConfig {
    fn default() -> Self {
        Self {
            device: "cpu".into(),
            push_out_epsilon: 0.002,
            timing_repeats: 20,
            timing_batch: 64,
            figures: true,
            newton_samples: 0,
            mirror_averaging: true,
        }
    }
}

/// What to evaluate.
#[derive(Debug, Clone, PartialEq)]
pub struct EvalInputs {
    /// The dataset the model was trained on.
    pub data_dir: PathBuf,
    /// The GarMatNet model file (its split file must lie next to it).
    pub model: PathBuf,
    /// A baseline directory from [`crate::train_baseline`], if any.
    pub baseline: Option<PathBuf>,
    /// A second GarMatNet model trained on the same split (e.g. the other displacement
    /// frame) for the frame comparison, if any.
    pub compare_model: Option<PathBuf>,
    /// Where `report.json`, `report.md` and the figures go (created if needed).
    pub out_dir: PathBuf,
    /// Named held-out datasets evaluated whole beside the test split (e.g. `everyday`, the
    /// everyday pose suite, and `held-out motion`, a walk of another seed), each of the
    /// model's template.
    pub held_out: Vec<(String, PathBuf)>,
}

/// Evaluates `inputs.model` (and the baseline / second model) on the model's test split and
/// writes the report and figures into `inputs.out_dir`.
///
/// # Errors
/// [`Error::Split`](crate::Error::Split) if the split file is missing, malformed, leaks, names samples outside the
/// dataset, belongs to another dataset or is not the split the model was trained with;
/// model errors for a corrupt model or another template; dataset errors naming the sample.
pub fn evaluate(inputs: &EvalInputs, config: &EvalConfig) -> Result<Report> {
    let device = select_device(&config.device)?;
    let data = TrainingDataset::open(&inputs.data_dir, true)?;
    let model = load_model(&inputs.model, &data, &device)?;
    let split = Split::read_for_model(
        &inputs.model,
        &model.meta.provenance,
        data.spec(),
        data.dataset_hash(),
    )?;
    // The baseline is checked before anything is computed or written.
    let baseline = match &inputs.baseline {
        Some(dir) => Some(Baseline::load_for(dir, &device, &data, &split)?),
        None => None,
    };
    let _lock = crate::data::loader::create_locked_dir(&inputs.out_dir, "report")?;
    let spec = data.spec();
    let comparison = split.comparison_test();
    let mirror = mirror_of(&data, config.mirror_averaging);

    // GarMatNet on the whole test set, keeping per-vertex errors for the heat maps.
    let mut all_errors = Vec::with_capacity(split.test.len());
    let mut penetration = PenetrationAccumulator::default();
    let mut quality = QualityAccumulator::new(data.garment(), spec)?;
    let polish_every = polish_stride(split.test.len(), config.newton_samples);
    for (chunk, keys) in split.test.chunks(64).enumerate() {
        let preds = predict_garmatnet(&model, &data, keys, &device, mirror)?;
        for (i, (&key, pred)) in keys.iter().zip(preds).enumerate() {
            let truth = data.truth(key)?;
            let errors = vertex_errors(&truth, &pred);
            let posed = data.body().pose(&spec.poses[key.pose]);
            let mut garment = assemble(&truth.body_points, &pred);
            quality.add(key.material, &posed, &garment, &truth.simulated)?;
            penetration.add(
                &mut garment,
                &truth.simulated,
                &posed,
                config.push_out_epsilon,
            );
            if polish_every.is_some_and(|every| (chunk * 64 + i) % every == 0) {
                let iterations = truth_iterations(&data, key);
                quality.polish(key.material, &posed, &garment, &truth.simulated, iterations)?;
            }
            all_errors.push((key, errors));
        }
    }
    let stats_of = |filter: &dyn Fn(&SampleKey) -> bool| {
        let chosen: Vec<&(SampleKey, VertexErrors)> =
            all_errors.iter().filter(|(k, _)| filter(k)).collect();
        error_stats(chosen.iter().map(|(_, e)| e))
    };
    let garmatnet_all_test = stats_of(&|_| true);
    let garmatnet = stats_of(&|k| comparison.binary_search(k).is_ok());
    // Where the error comes from: an unseen fabric at training poses, a training fabric at an
    // unseen pose, and neither unseen (the development set: seen fabric and pose, unseen drape).
    let unseen_material = |k: &SampleKey| split.test_materials.contains(&k.material);
    let held_out = |k: &SampleKey| split.held_out_poses.contains(&k.pose);
    let non_empty = |e: ErrorStats| (e.samples > 0).then_some(e);
    let by_part = TestParts {
        unseen_material: non_empty(stats_of(&|k| unseen_material(k) && !held_out(k))),
        unseen_pose: non_empty(stats_of(&|k| !unseen_material(k) && held_out(k))),
        development: {
            let mut errors = Vec::with_capacity(split.dev.len());
            for keys in split.dev.chunks(64) {
                let preds = predict_garmatnet(&model, &data, keys, &device, mirror)?;
                for (&key, pred) in keys.iter().zip(preds) {
                    errors.push(vertex_errors(&data.truth(key)?, &pred));
                }
            }
            non_empty(error_stats(errors.iter()))
        },
        dev_materials: split
            .dev_materials
            .iter()
            .map(|&m| spec.materials[m].name.clone())
            .collect(),
        dev_frames: split
            .config
            .dev_frame_offset
            .map(|offset| (offset, split.config.held_out_frame_every)),
    };

    // `split.test` is sorted, material first, so each material's errors are one run.
    let training_fabrics = split.training_fabrics(spec);
    let per_material = all_errors
        .chunk_by(|(a, _), (b, _)| a.material == b.material)
        .map(|run| {
            let m = run[0].0.material;
            material_errors(
                &spec.materials[m],
                split.test_materials.contains(&m),
                &training_fabrics,
                run.iter().map(|(_, e)| e),
            )
        })
        .collect();

    let fabric_lookup = fabric_lookup(&data, &split, &comparison)?;

    // The baseline on the comparison set.
    let mut baseline_errors: Vec<(SampleKey, VertexErrors)> = Vec::new();
    if let Some(b) = &baseline {
        for m in &b.materials {
            let keys: Vec<SampleKey> = comparison
                .iter()
                .copied()
                .filter(|k| k.material == m.material)
                .collect();
            for chunk in keys.chunks(64) {
                let preds = predict_baseline(m, &data, chunk, &device, mirror)?;
                for (&key, pred) in chunk.iter().zip(preds) {
                    let truth = data.truth(key)?;
                    baseline_errors.push((key, vertex_errors(&truth, &pred)));
                }
            }
        }
        baseline_errors.sort_by_key(|(k, _)| *k);
    }
    let baseline_stats = baseline
        .as_ref()
        .map(|_| error_stats(baseline_errors.iter().map(|(_, e)| e)));

    let per_sample: Vec<SampleErrors> = all_errors
        .iter()
        .filter(|(k, _)| comparison.binary_search(k).is_ok())
        .map(|(k, e)| SampleErrors {
            baseline: baseline_errors
                .binary_search_by_key(k, |(bk, _)| *bk)
                .ok()
                .map(|i| baseline_errors[i].1.means_mm()),
            ..sample_errors(spec, *k, e, None)
        })
        .collect();

    let frame_comparison = match &inputs.compare_model {
        Some(path) => Some(compare_frames(
            path,
            &split,
            &data,
            (&device, mirror),
            &model,
            garmatnet_all_test.whole_mm,
        )?),
        None => None,
    };

    let mut files = Vec::new();
    if config.figures {
        files.extend(crate::evaluation::figures::per_pose_plots(
            &inputs.out_dir,
            &split,
            &data,
            &per_sample,
        )?);
        files.extend(crate::evaluation::figures::heat_maps(
            &inputs.out_dir,
            &split,
            &data,
            &all_errors,
            (&baseline_errors, baseline.as_ref()),
            (&model, mirror),
            &device,
        )?);
    }

    let sizes = ModelSizes {
        garmatnet_mb: file_size(&inputs.model) as f64 / 1e6,
        baseline_mb: inputs.baseline.as_ref().map(|d| dir_size(d) as f64 / 1e6),
    };
    let held_out_sets = inputs
        .held_out
        .iter()
        .map(|(name, dir)| held_out_set((name, dir), &model, &training_fabrics, &device, config))
        .collect::<Result<Vec<_>>>()?;
    let timing = time_inference(&model, &data, &split.test, &device, config)?;
    let report = Report {
        dataset_hash: data.dataset_hash().to_owned(),
        displacement_frame: frame_name(model.displacement_frame()).into(),
        test_materials: split
            .test_materials
            .iter()
            .map(|&m| spec.materials[m].name.clone())
            .collect(),
        held_out_poses: split.held_out_poses.len(),
        held_out_rule: split.config.held_out_rule(),
        garmatnet,
        baseline: baseline_stats,
        garmatnet_all_test,
        garmatnet_by_part: Some(by_part),
        fabric_lookup,
        material_support: material_support(&data, &split),
        per_sample,
        per_material,
        penetration: penetration.finish(config.push_out_epsilon),
        physical_quality: quality.finish(),
        timing,
        sizes,
        frame_comparison,
        held_out_sets,
        mirror_averaging: config.mirror_averaging,
        files,
    };
    report.write(&inputs.out_dir)?;
    Ok(report)
}

/// What [`evaluate_held_out`] evaluates.
#[derive(Debug, Clone, PartialEq)]
pub struct HeldOutInputs {
    /// The GarMatNet model file (no split file needed).
    pub model: PathBuf,
    /// Where `report.json` and `report.md` go (created if needed).
    pub out_dir: PathBuf,
    /// Named held-out datasets of the model's template, evaluated whole, as in
    /// [`EvalInputs::held_out`]; at least one.
    pub held_out: Vec<(String, PathBuf)>,
}

/// Evaluates `inputs.model` on held-out datasets alone, without the dataset it was trained
/// on: for a model whose training data is not at hand, such as the shipped one. Each set is
/// measured as [`evaluate`] measures its held-out sets; a fabric counts as seen when the
/// model file records a training fabric of the same name and ω (none, in files written
/// before they were recorded). Writes the report into `inputs.out_dir`.
///
/// # Errors
/// [`Error::InvalidConfig`](crate::Error::InvalidConfig) without a held-out set; model errors
/// for a missing or corrupt model, or a set of another template; dataset errors naming the
/// sample.
pub fn evaluate_held_out(inputs: &HeldOutInputs, config: &EvalConfig) -> Result<HeldOutReport> {
    if inputs.held_out.is_empty() {
        return Err(crate::Error::InvalidConfig(
            "evaluating without the training data needs at least one held-out set \
             (NAME=DIR, e.g. everyday=ds/everyday)"
                .into(),
        ));
    }
    let device = select_device(&config.device)?;
    let model = GarMatNetModel::load(&inputs.model, &device)?;
    let training = model.meta.provenance.training_fabrics.clone();
    let _lock = crate::data::loader::create_locked_dir(&inputs.out_dir, "report")?;
    let held_out_sets = inputs
        .held_out
        .iter()
        .map(|(name, dir)| held_out_set((name, dir), &model, &training, &device, config))
        .collect::<Result<Vec<_>>>()?;
    let report = HeldOutReport {
        model: inputs.model.display().to_string(),
        mirror_averaging: config.mirror_averaging,
        training_fabrics: training.iter().map(|f| f.name.clone()).collect(),
        held_out_sets,
    };
    report.write(&inputs.out_dir)?;
    Ok(report)
}

/// The model's error on every sample of the held-out dataset in `dir`, split by whether the
/// fabric is one of the model's `training` fabrics (same name and ω).
fn held_out_set(
    (name, dir): (&str, &Path),
    model: &GarMatNetModel,
    training: &[TrainingFabric],
    device: &Device,
    config: &EvalConfig,
) -> Result<HeldOutSet> {
    let set = TrainingDataset::open(dir, true)?;
    model.ensure_template(set.template_hash(), set.vertex_count())?;
    let mirror = mirror_of(&set, config.mirror_averaging);
    let mirror_map = MirrorMap::from_twins(set.garment().mirror_twins()).ok();
    let mut symmetry = SymmetryAccumulator::default();
    let seen: Vec<bool> = set
        .spec()
        .materials
        .iter()
        .map(|m| {
            training
                .iter()
                .any(|t| t.name == m.name && t.omega == m.omega_normalized)
        })
        .collect();
    let names = pose_names(dir, &set.spec().poses);
    let mut errors = Vec::new();
    let mut per_sample = Vec::new();
    let mut quality = QualityAccumulator::new(set.garment(), set.spec())?;
    let keys = set.keys();
    // `records()` is in `keys()`'s order: whether each truth met the solver's tolerance.
    let converged: Vec<bool> = set.records().iter().map(|r| r.stats.converged).collect();
    let polish_every = polish_stride(keys.len(), config.newton_samples);
    for (chunk, keys) in keys.chunks(64).enumerate() {
        let preds = predict_garmatnet(model, &set, keys, device, mirror)?;
        for (i, (&key, pred)) in keys.iter().zip(preds).enumerate() {
            let truth = set.truth(key)?;
            let e = vertex_errors(&truth, &pred);
            per_sample.push(sample_errors(set.spec(), key, &e, names[key.pose].clone()));
            errors.push((key.material, e));
            let pose = &set.spec().poses[key.pose];
            let posed = set.body().pose(pose);
            let mut garment = assemble(&truth.body_points, &pred);
            if let Some(map) = mirror_map.as_ref().filter(|_| pose.mirrored() == *pose) {
                symmetry.add(map, &garment, &truth.simulated);
            }
            quality.add(key.material, &posed, &garment, &truth.simulated)?;
            if polish_every.is_some_and(|every| (chunk * 64 + i) % every == 0) {
                let _ = push_out(&mut garment, &posed, config.push_out_epsilon);
                let iterations = truth_iterations(&set, key);
                quality.polish(key.material, &posed, &garment, &truth.simulated, iterations)?;
            }
        }
    }
    let part = |want: bool| {
        let chosen: Vec<&VertexErrors> = errors
            .iter()
            .filter(|(m, _)| seen[*m] == want)
            .map(|(_, e)| e)
            .collect();
        (!chosen.is_empty()).then(|| error_stats(chosen.into_iter()))
    };
    // `keys()` is sorted, material first, so each material's errors are one run.
    let per_material = errors
        .chunk_by(|(a, _), (b, _)| a == b)
        .map(|run| {
            let m = run[0].0;
            material_errors(
                &set.spec().materials[m],
                !seen[m],
                training,
                run.iter().map(|(_, e)| e),
            )
        })
        .collect();
    let unconverged = converged.iter().filter(|&&c| !c).count();
    let converged_only = (unconverged > 0 && unconverged < converged.len()).then(|| {
        error_stats(
            errors
                .iter()
                .zip(&converged)
                .filter(|(_, c)| **c)
                .map(|((_, e), _)| e),
        )
    });
    Ok(HeldOutSet {
        name: name.to_owned(),
        dir: dir.display().to_string(),
        all: error_stats(errors.iter().map(|(_, e)| e)),
        unconverged,
        converged_only,
        training_fabrics: part(true),
        unseen_fabrics: part(false),
        physical_quality: quality.finish(),
        per_material,
        symmetry: symmetry.finish(),
        per_sample,
    })
}

/// The names of a held-out set's poses, so its per-pose rows say which pose they are: the
/// names the dataset was made with (`simulate --poses everyday` writes them to `dir`), else
/// those of today's everyday poses it holds bit for bit.
fn pose_names(dir: &Path, poses: &[Pose]) -> Vec<Option<String>> {
    let written = std::fs::read(dir.join(POSE_NAMES_FILE))
        .ok()
        .and_then(|bytes| serde_json::from_slice::<Vec<String>>(&bytes).ok())
        .filter(|names| names.len() == poses.len());
    match written {
        Some(names) => names.into_iter().map(Some).collect(),
        None => {
            let suite = everyday_poses();
            poses
                .iter()
                .map(|p| {
                    suite
                        .iter()
                        .find(|e| e.pose == *p)
                        .map(|e| e.name.to_owned())
                })
                .collect()
        }
    }
}

fn frame_name(frame: DisplacementFrame) -> &'static str {
    match frame {
        DisplacementFrame::World => "world",
        DisplacementFrame::Canonical => "canonical",
    }
}

fn compare_frames(
    path: &Path,
    split: &Split,
    data: &TrainingDataset,
    (device, mirror): (&Device, Mirror<'_>),
    primary: &GarMatNetModel,
    primary_whole_mm: f64,
) -> Result<FrameComparison> {
    let other = load_with_same_test(path, "the second model", split, data, device)?;
    let mut errors = Vec::new();
    for keys in split.test.chunks(64) {
        for (&key, pred) in keys
            .iter()
            .zip(predict_garmatnet(&other, data, keys, device, mirror)?)
        {
            errors.push(vertex_errors(&data.truth(key)?, &pred));
        }
    }
    let other_whole = error_stats(errors.iter()).whole_mm;
    let primary = (
        frame_name(primary.displacement_frame()).to_owned(),
        primary_whole_mm,
    );
    let other = (
        frame_name(other.displacement_frame()).to_owned(),
        other_whole,
    );
    let winner = if primary.1 <= other.1 {
        primary.0.clone()
    } else {
        other.0.clone()
    };
    Ok(FrameComparison {
        primary,
        other,
        winner,
    })
}

fn time_inference(
    model: &GarMatNetModel,
    data: &TrainingDataset,
    test: &[SampleKey],
    device: &Device,
    config: &EvalConfig,
) -> Result<Timing> {
    // Timed as the predictor runs by default: with mirror averaging, twice the poses.
    let mirror = mirror_of(data, config.mirror_averaging);
    let predictor = predictor_for(model, data, device, mirror)?;
    let items: Vec<_> = test
        .iter()
        .take(config.timing_batch.max(1))
        .map(|&k| {
            let omega = data.spec().materials[k.material].omega_normalized;
            (data.spec().poses[k.pose].clone(), omega)
        })
        .collect();
    let Some((pose, omega)) = items.first().cloned() else {
        return Ok(Timing::default());
    };
    let _ = predictor.predict_normalized(&pose, &omega, Detail::Full)?;
    let mut times = Vec::new();
    for _ in 0..config.timing_repeats.max(1) {
        let t = Instant::now();
        let _ = predictor.predict_normalized(&pose, &omega, Detail::Full)?;
        times.push(t.elapsed().as_secs_f64() * 1e3);
    }
    times.sort_by(f64::total_cmp);
    let t = Instant::now();
    let _ = predictor.predict_batch(&items, Detail::Full)?;
    let batched = t.elapsed().as_secs_f64() * 1e3 / items.len() as f64;
    Ok(Timing {
        device: config.device.clone(),
        batch1_ms_per_frame: times[times.len() / 2],
        batched_ms_per_frame: batched,
        batch_size: items.len(),
    })
}

fn file_size(path: &Path) -> u64 {
    std::fs::metadata(path).map_or(0, |m| m.len())
}

fn dir_size(dir: &Path) -> u64 {
    std::fs::read_dir(dir).map_or(0, |entries| {
        entries
            .flatten()
            .map(|e| {
                e.metadata()
                    .map_or(0, |m| if m.is_file() { m.len() } else { 0 })
            })
            .sum()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::files::split_path;
    use crate::test_util::{synthetic_dataset, training_lock};
    use crate::training::baseline::{BaselineConfig, train_baseline};
    use crate::training::train_config::{RunOptions, TrainConfig};
    use crate::training::trainer::tests::tiny_config;
    use crate::training::trainer::train;
    use garmatnet_model::MaterialRange;

    #[test]
    fn evaluation_with_baseline_and_frame_comparison_is_finite_and_consistent() {
        let _serial = training_lock();
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 6, 20);
        let world = dir.path().join("world.safetensors");
        let canonical = dir.path().join("canonical.safetensors");
        train(&data, &world, &tiny_config(15), &RunOptions::default()).unwrap();
        let canonical_config = TrainConfig {
            displacement_frame: DisplacementFrame::Canonical,
            ..tiny_config(15)
        };
        train(&data, &canonical, &canonical_config, &RunOptions::default()).unwrap();
        let baseline_dir = dir.path().join("baseline");
        let baseline_config = BaselineConfig {
            max_epochs: 3,
            ..BaselineConfig::from_train_config(&tiny_config(3))
        };
        let manifest = train_baseline(&data, &baseline_dir, &baseline_config).unwrap();
        assert_eq!(manifest.materials.len(), 2);
        // 18 own poses -> 16 train, 2 dev; GarMatNet trains on 65, so 65 / 16 -> 4 passes.
        assert!(
            manifest.materials.iter().all(|m| m.replicate == 4),
            "{manifest:?}"
        );

        let out = dir.path().join("eval");
        let config = EvalConfig {
            timing_repeats: 2,
            timing_batch: 4,
            newton_samples: 2,
            ..EvalConfig::default()
        };
        let inputs = EvalInputs {
            // The training set itself, read whole as a held-out set (the code path only).
            held_out: vec![("whole".to_owned(), data.clone())],
            data_dir: data.clone(),
            model: world.clone(),
            baseline: Some(baseline_dir),
            compare_model: Some(canonical),
            out_dir: out.clone(),
        };
        let report = evaluate(&inputs, &config).unwrap();
        let b = report.baseline.unwrap();
        for e in [report.garmatnet, b, report.garmatnet_all_test] {
            for v in [
                e.fitting_mm,
                e.local_mm,
                e.whole_mm,
                e.whole_p95_mm,
                e.whole_max_mm,
            ] {
                assert!(v.is_finite() && v > 0.0, "{e:?}");
            }
            // The triangle inequality holds per vertex, hence for the means.
            assert!(e.whole_mm <= e.fitting_mm + e.local_mm + 1e-9, "{e:?}");
            assert!(e.whole_mm <= e.whole_p95_mm.max(e.whole_max_mm));
            // Regression: coordinates that never move (D_local at fixed smoother corners) got
            // std 1 m (the old zero-variance rule), and half-metre spikes.
            assert!(e.whole_max_mm < 100.0, "spiky prediction: {e:?}");
        }
        // 2 target materials x held-out frames 0 and 10.
        assert_eq!(report.garmatnet.samples, 4);
        assert_eq!(b.samples, 4);
        assert_eq!(report.per_sample.len(), 4);
        for r in &report.per_sample {
            let g = r.garmatnet;
            assert!(g.whole_mm <= g.fitting_mm + g.local_mm + 1e-9);
            assert!(r.baseline.is_some());
        }
        assert!(report.garmatnet_all_test.samples > report.garmatnet.samples);
        // Physical quality on every test sample, finite.
        let q = report.physical_quality.unwrap();
        assert_eq!(q.samples, report.garmatnet_all_test.samples);
        for v in [
            q.mean_max_stretch,
            q.worst_stretch,
            q.truth_mean_max_stretch,
            q.mean_energy_above_truth_mm,
            q.median_energy_above_truth_mm,
        ] {
            assert!(v.is_finite(), "{q:?}");
        }
        assert!(q.worst_stretch >= q.mean_max_stretch, "{q:?}");
        assert!(q.median_residual.is_finite() && q.truth_median_residual.is_finite());
        assert!(
            q.worst_depth_mm >= q.mean_depth_mm && q.mean_depth_mm >= 0.0,
            "{q:?}"
        );
        let n = q.newton.unwrap();
        assert_eq!(n.samples, 2, "{n:?}");
        assert!(
            n.mean_iterations >= 1.0 && n.truth_mean_iterations >= 1.0,
            "{n:?}"
        );
        assert!(n.mean_distance_to_truth_mm.is_finite(), "{n:?}");
        // The held-out set: every sample of the dataset, with its own physical quality.
        let whole = &report.held_out_sets[0];
        let wq = whole.physical_quality.unwrap();
        assert_eq!(wq.samples, whole.all.samples);
        assert_eq!(wq.newton.unwrap().samples, 2);
        // Its unconverged truths are counted; the converged-only row, when there is one,
        // holds the rest.
        let records = TrainingDataset::open(&data, true).unwrap();
        let unconverged = records
            .records()
            .iter()
            .filter(|r| !r.stats.converged)
            .count();
        assert_eq!(whole.unconverged, unconverged);
        match &whole.converged_only {
            Some(c) => assert_eq!(c.samples + unconverged, whole.all.samples),
            None => assert!(unconverged == 0 || unconverged == whole.all.samples),
        }
        // Its rows per fabric partition it; an unseen fabric names the nearest training
        // fabric at the same distance as in the test set's rows, a training fabric none.
        // (Every fabric of this dataset has a test sample, so both list every fabric.)
        assert_eq!(whole.per_material.len(), report.per_material.len());
        assert_eq!(
            whole
                .per_material
                .iter()
                .map(|r| r.garmatnet.samples)
                .sum::<usize>(),
            whole.all.samples
        );
        for r in &whole.per_material {
            assert_eq!(r.unseen, r.nearest_training.is_some(), "{r:?}");
            assert_eq!(r.unseen, report.test_materials.contains(&r.material));
            if let Some(n) = &r.nearest_training {
                let test_row = report
                    .per_material
                    .iter()
                    .find(|t| t.material == r.material)
                    .unwrap();
                assert_eq!(test_row.nearest_training.as_ref(), Some(n));
            }
        }
        let seen_weighted: f64 = whole
            .per_material
            .iter()
            .filter(|r| !r.unseen)
            .map(|r| r.garmatnet.whole_mm * r.garmatnet.samples as f64)
            .sum();
        let seen = whole.training_fabrics.unwrap();
        assert!((seen_weighted / seen.samples as f64 - seen.whole_mm).abs() < 1e-9 * seen.whole_mm);
        // The parts partition the test set (plus the comparison set) and the dev set is its own.
        let parts = report.garmatnet_by_part.clone().unwrap();
        let (fabric, pose, dev) = (
            parts.unseen_material.unwrap(),
            parts.unseen_pose.unwrap(),
            parts.development.unwrap(),
        );
        assert_eq!(
            fabric.samples + pose.samples + report.garmatnet.samples,
            report.garmatnet_all_test.samples
        );
        let split = Split::read(&split_path(&world), report.dataset_hash.as_str()).unwrap();
        assert_eq!(dev.samples, split.dev.len());
        // One row per material with a test sample; together they are the whole test set.
        let mut tested: Vec<usize> = split.test.iter().map(|k| k.material).collect();
        tested.sort_unstable();
        tested.dedup();
        assert_eq!(report.per_material.len(), tested.len());
        let all = report.garmatnet_all_test;
        let rows = &report.per_material;
        assert_eq!(
            rows.iter().map(|r| r.garmatnet.samples).sum::<usize>(),
            all.samples
        );
        let weighted: f64 = rows
            .iter()
            .map(|r| r.garmatnet.whole_mm * r.garmatnet.samples as f64)
            .sum();
        assert!((weighted / all.samples as f64 - all.whole_mm).abs() < 1e-9 * all.whole_mm);
        let mut unseen: Vec<&str> = rows
            .iter()
            .filter(|r| r.unseen)
            .map(|r| r.material.as_str())
            .collect();
        let mut targets: Vec<&str> = report.test_materials.iter().map(String::as_str).collect();
        unseen.sort_unstable();
        targets.sort_unstable();
        assert_eq!(unseen, targets);
        assert!(rows.iter().any(|r| !r.unseen));
        assert!(
            rows.iter()
                .all(|r| r.unseen == r.nearest_training.is_some())
        );
        assert!(
            report
                .to_markdown()
                .contains("## Per material, whole test set")
        );
        for e in [fabric, pose, dev] {
            assert!(e.whole_mm.is_finite() && e.whole_mm <= e.fitting_mm + e.local_mm + 1e-9);
        }
        // The development row says what the development set is.
        assert!(parts.dev_materials.is_empty());
        assert!(
            report
                .to_markdown()
                .contains("development set (seen fabric and pose)")
        );
        // The fabric-lookup reference: each target's nearest training fabric, never a target;
        // the oracle's pick is at least as close as the nearest fabric's, sample by sample.
        let lookup = report.fabric_lookup.clone().unwrap();
        let split_spec = TrainingDataset::open(&data, false).unwrap().spec().clone();
        assert_eq!(lookup.nearest_material.samples, report.garmatnet.samples);
        assert_eq!(lookup.best_material.samples, report.garmatnet.samples);
        assert_eq!(lookup.nearest_to.len(), report.test_materials.len());
        for (target, near) in &lookup.nearest_to {
            assert!(report.test_materials.contains(target));
            assert!(!report.test_materials.contains(near), "{near}");
            // Its per-material row names the same nearest training fabric, at the distance
            // between the two fabrics' normalised ω.
            let row = rows.iter().find(|r| &r.material == target).unwrap();
            let nearest = row.nearest_training.as_ref().unwrap();
            assert_eq!(&nearest.material, near);
            let omega = |name: &str| {
                split_spec
                    .materials
                    .iter()
                    .find(|m| m.name == name)
                    .unwrap()
                    .omega_normalized
            };
            let (a, b) = (omega(target), omega(near));
            let distance = a
                .iter()
                .zip(&b)
                .map(|(x, y)| (x - y) * (x - y))
                .sum::<f64>();
            assert!((nearest.distance - distance.sqrt()).abs() < 1e-12);
            assert!(nearest.distance > 0.0);
            assert!(
                report.to_markdown().contains(&format!(
                    "{target} (never trained on; nearest: {near}, {:.3} away)",
                    nearest.distance
                )),
                "{target}"
            );
        }
        let (near, best) = (lookup.nearest_material, lookup.best_material);
        assert!(best.whole_mm <= near.whole_mm + 1e-9, "{best:?} {near:?}");
        assert!(best.whole_mm > 0.0 && best.whole_mm <= best.fitting_mm + best.local_mm + 1e-9);
        assert!(
            report
                .to_markdown()
                .contains("Nearest training fabric in ω")
        );
        // Each target against the range of the fabrics the model trained on (every non-target
        // here): the components outside are exactly those past the training box.
        let spec = TrainingDataset::open(&data, false).unwrap().spec().clone();
        let trained: Vec<[f64; 6]> = spec
            .materials
            .iter()
            .filter(|m| !report.test_materials.contains(&m.name))
            .map(|m| m.omega_normalized)
            .collect();
        let range = MaterialRange::of(trained.iter().copied()).unwrap();
        assert_eq!(report.material_support.len(), report.test_materials.len());
        assert!(
            report
                .material_support
                .iter()
                .any(|s| !s.outside.is_empty()),
            "random targets lie outside 4 training fabrics somewhere: {:?}",
            report.material_support
        );
        for support in &report.material_support {
            let omega = spec
                .materials
                .iter()
                .find(|m| m.name == support.material)
                .unwrap()
                .omega_normalized;
            assert_eq!(support.outside, range.outside(&omega), "{support:?}");
        }
        assert!(
            report
                .to_markdown()
                .contains("| Material | Outside the training range |")
        );
        let mut by_fabric = report.clone();
        if let Some(p) = &mut by_fabric.garmatnet_by_part {
            p.dev_materials = vec!["Felt".into()];
        }
        assert!(
            by_fabric
                .to_markdown()
                .contains("development set (unseen fabrics Felt at training poses)")
        );
        let p = report.penetration;
        assert!(p.inside_fraction_after <= p.inside_fraction_before);
        assert!(report.timing.batch1_ms_per_frame > 0.0);
        assert!(report.sizes.garmatnet_mb > 0.0 && report.sizes.baseline_mb.unwrap() > 0.0);
        let c = report.frame_comparison.unwrap();
        assert_eq!(
            (c.primary.0.as_str(), c.other.0.as_str()),
            ("world", "canonical")
        );
        for f in ["report.json", "report.md"] {
            assert!(out.join(f).exists(), "{f} missing");
        }
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(out.join("report.md"))
                .unwrap()
                .permissions()
                .mode();
            assert_eq!(mode & 0o777, 0o644, "reports get ordinary permissions");
        }
        assert!(
            report
                .files
                .iter()
                .filter(|f| f.starts_with("per_pose_"))
                .count()
                == 2
        );
        assert!(report.files.iter().any(|f| f.starts_with("heatmap_")));
        for f in &report.files {
            assert!(out.join(f).exists(), "{f} missing");
        }
        let md = std::fs::read_to_string(out.join("report.md")).unwrap();
        assert!(md.contains("Baseline (TailorNet-style)") && md.contains("Winner"));
        assert!(md.contains("GarMatNet, whole test set"), "{md}");
        // Per target material, both methods, over its 2 compared samples.
        let per_material = md.split("## Per material (whole pipeline").nth(1).unwrap();
        let per_material = per_material.split("\n## ").next().unwrap();
        let rows: Vec<&str> = per_material
            .lines()
            .filter(|l| l.contains(" | 2 | "))
            .take_while(|l| l.starts_with('|'))
            .collect();
        assert_eq!(rows.len(), 2, "{md}");
        assert!(rows.iter().all(|r| !r.ends_with("| – |")), "{rows:?}");
        assert!(md.contains("every 10th frame"), "{md}");
        // The held-out set's fabrics, and the error against the distance to the nearest
        // training fabric: the training fabrics at distance 0 and each unseen one in a bin,
        // for the test set and the held-out set alike.
        assert!(
            md.contains("## Per material, whole (GarMatNet, mm)"),
            "{md}"
        );
        let distance = md
            .split("## Error against the distance to the nearest training fabric")
            .nth(1)
            .unwrap();
        let distance = distance.split("\n## ").next().unwrap();
        for set in ["test set", "whole"] {
            let rows: Vec<&str> = distance
                .lines()
                .filter(|l| l.starts_with(&format!("| {set} | ")))
                .collect();
            assert!(
                rows.iter().any(|r| r.contains("| trained on |")),
                "{distance}"
            );
            let unseen: usize = rows
                .iter()
                .filter(|r| !r.contains("| trained on |"))
                .map(|r| r.split(" | ").nth(2).unwrap().parse::<usize>().unwrap())
                .sum();
            assert_eq!(unseen, 2, "{distance}");
        }

        // A baseline trained with other held-out poses may have seen the comparison poses.
        let manifest_path = inputs
            .baseline
            .as_ref()
            .unwrap()
            .join(crate::BASELINE_MANIFEST);
        let mut json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&manifest_path).unwrap()).unwrap();
        let original = json.clone();
        json["config"]["split"]["held_out_block"] = 2.into();
        json["config"]["split"]["held_out_frame_every"] = 20.into();
        std::fs::write(&manifest_path, serde_json::to_vec(&json).unwrap()).unwrap();
        let err = evaluate(&inputs, &config).unwrap_err().to_string();
        assert!(
            err.contains("frames 0–1 of every 20") && err.contains("--held-out"),
            "{err}"
        );

        // A baseline without a net for one of the targets would be averaged over fewer
        // samples than GarMatNet's row beside it.
        let mut json = original;
        let dropped = json["materials"].as_array_mut().unwrap().remove(0);
        std::fs::write(&manifest_path, serde_json::to_vec(&json).unwrap()).unwrap();
        let refused = EvalInputs {
            held_out: Vec::new(),
            out_dir: out.with_file_name("refused"),
            ..inputs.clone()
        };
        let err = evaluate(&refused, &config).unwrap_err().to_string();
        assert!(
            !refused.out_dir.exists(),
            "refused before anything is written"
        );
        let dropped = dropped["name"].as_str().unwrap();
        assert!(
            err.contains(&format!(
                "no net for the model's target material(s) {dropped} "
            )) && err.contains("--test-materials"),
            "{err}"
        );
    }

    #[test]
    fn a_model_trained_on_every_fabric_is_evaluated_on_the_held_out_poses() {
        let _serial = training_lock();
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 4, 20);
        let model = dir.path().join("all.safetensors");
        let mut config = tiny_config(5);
        config.split.test_materials.clear();
        train(&data, &model, &config, &RunOptions::default()).unwrap();
        // No target material, so no per-target baseline: a clear error, not an empty one.
        let err = train_baseline(
            &data,
            &dir.path().join("baseline"),
            &BaselineConfig::from_train_config(&config),
        )
        .unwrap_err()
        .to_string();
        assert!(err.contains("name the target materials"), "{err}");
        // A baseline for the usual targets, on the same data and held-out poses, is refused
        // beside this model: it tests every fabric, the baseline only its targets.
        let baseline = dir.path().join("baseline-targets");
        train_baseline(
            &data,
            &baseline,
            &BaselineConfig::from_train_config(&tiny_config(5)),
        )
        .unwrap();
        let with_baseline = EvalInputs {
            held_out: Vec::new(),
            data_dir: data.clone(),
            model: model.clone(),
            baseline: Some(baseline),
            compare_model: None,
            out_dir: dir.path().join("eval-baseline"),
        };
        let err = evaluate(&with_baseline, &EvalConfig::default())
            .unwrap_err()
            .to_string();
        assert!(err.contains("holds out no target fabric"), "{err}");

        let out = dir.path().join("eval");
        let inputs = EvalInputs {
            held_out: Vec::new(),
            data_dir: data,
            model,
            baseline: None,
            compare_model: None,
            out_dir: out.clone(),
        };
        let eval_config = EvalConfig {
            timing_repeats: 1,
            timing_batch: 2,
            ..EvalConfig::default()
        };
        let report = evaluate(&inputs, &eval_config).unwrap();
        // 4 fabrics x held-out frames 0 and 10, all of them compared.
        assert!(report.test_materials.is_empty());
        assert_eq!(report.garmatnet.samples, 8);
        assert_eq!(report.garmatnet_all_test.samples, 8);
        assert_eq!(report.per_sample.len(), 8);
        let g = report.garmatnet;
        assert!(g.whole_mm.is_finite() && g.whole_mm <= g.fitting_mm + g.local_mm + 1e-9);
        let parts = report.garmatnet_by_part.clone().unwrap();
        assert!(parts.unseen_material.is_none());
        assert_eq!(parts.unseen_pose.unwrap().samples, 8);
        assert_eq!(report.per_material.len(), 4);
        assert!(
            report
                .per_material
                .iter()
                .all(|r| !r.unseen && r.garmatnet.samples == 2 && r.nearest_training.is_none())
        );
        assert!(report.fabric_lookup.is_none() && report.baseline.is_none());
        let md = report.to_markdown();
        assert!(
            md.contains("test materials: none (every fabric trained on)"),
            "{md}"
        );
        assert!(md.contains("every fabric × held-out poses"), "{md}");
        // The comparison set is the whole test set: its rows are not repeated, and the
        // per-material summary ranks the 4 fabrics (2 samples each, no baseline).
        assert!(
            !md.contains("whole test set") && !md.contains("at unseen poses"),
            "{md}"
        );
        assert!(md.contains("## Per material (whole pipeline"), "{md}");
        assert_eq!(md.matches(" | 2 | ").count(), 4, "{md}");
        // The heat maps fall back to a fabric that was tested.
        assert!(report.files.iter().any(|f| f.starts_with("heatmap_")));
        for f in &report.files {
            assert!(out.join(f).exists(), "{f} missing");
        }
    }

    #[test]
    fn without_the_split_file_only_held_out_sets_are_evaluated() {
        let _serial = training_lock();
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 6, 20);
        let model = dir.path().join("m.safetensors");
        train(&data, &model, &tiny_config(1), &RunOptions::default()).unwrap();
        std::fs::remove_file(crate::data::files::split_path(&model)).unwrap();
        let inputs = EvalInputs {
            held_out: Vec::new(),
            data_dir: data.clone(),
            model: model.clone(),
            baseline: None,
            compare_model: None,
            out_dir: dir.path().join("eval"),
        };
        assert!(evaluate(&inputs, &EvalConfig::default()).is_err());

        // The held-out sets alone need no split (the training set read whole: the code path).
        let held_out = |out: &str, held_out: Vec<(String, PathBuf)>| HeldOutInputs {
            model: model.clone(),
            out_dir: dir.path().join(out),
            held_out,
        };
        let set = vec![("whole".to_owned(), data.clone())];
        // Named poses, as `simulate --poses everyday` names them.
        let names: Vec<String> = (0..20).map(|i| format!("pose-{i}")).collect();
        std::fs::write(
            data.join(POSE_NAMES_FILE),
            serde_json::to_vec(&names).unwrap(),
        )
        .unwrap();
        let on = evaluate_held_out(&held_out("on", set.clone()), &EvalConfig::default()).unwrap();
        assert!(on.mirror_averaging);
        assert_eq!(on.training_fabrics.len(), 4, "6 fabrics less the 2 targets");
        let whole = &on.held_out_sets[0];
        assert_eq!(whole.all.samples, 6 * 20);
        assert_eq!(whole.unseen_fabrics.as_ref().unwrap().samples, 2 * 20);
        assert!(whole.all.whole_mm.is_finite() && whole.all.whole_mm > 0.0);
        // One row a sample, each pose once per fabric; every sample has as many vertices, so
        // the rows' mean is the set's.
        assert_eq!(whole.per_sample.len(), 6 * 20);
        assert!(
            whole
                .per_sample
                .iter()
                .all(|r| r.pose_name == Some(format!("pose-{}", r.pose)))
        );
        assert!(whole.per_sample.windows(2).all(|w| {
            (w[0].material == w[1].material && w[0].pose + 1 == w[1].pose)
                || (w[0].material != w[1].material && w[1].pose == 0)
        }));
        let mean = whole
            .per_sample
            .iter()
            .map(|r| r.garmatnet.whole_mm)
            .sum::<f64>()
            / whole.per_sample.len() as f64;
        assert!(
            (mean - whole.all.whole_mm).abs() < 1e-9 * mean,
            "{mean} vs {:?}",
            whole.all
        );
        // The synthetic poses are random: none is its own mirror image.
        assert!(whole.symmetry.is_none());
        let md = std::fs::read_to_string(dir.path().join("on/report.md")).unwrap();
        assert!(
            md.contains("mirror averaging on")
                && md.contains("GarMatNet, whole")
                && md.contains("## Per pose, whole")
                && md.contains("| 3 (pose-3) | 3 | 6 |"),
            "{md}"
        );
        let off_config = EvalConfig {
            mirror_averaging: false,
            ..EvalConfig::default()
        };
        let off = evaluate_held_out(&held_out("off", set), &off_config).unwrap();
        assert!(!off.mirror_averaging);
        assert_ne!(off.held_out_sets[0].all, whole.all);
        let err = evaluate_held_out(&held_out("none", Vec::new()), &EvalConfig::default())
            .unwrap_err()
            .to_string();
        assert!(err.contains("at least one held-out set"), "{err}");
    }
}
