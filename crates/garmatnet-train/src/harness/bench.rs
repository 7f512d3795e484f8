//! The run-time-against-error harness behind `garmatnet bench`. On the same held-out samples
//! (target materials × held-out poses of a model's split) it measures milliseconds per frame
//! and the mean per-vertex error (mm) against the dataset's ground truth of
//! - the simulator at several Newton-iteration budgets, warm-started from the previous
//!   frame's ground truth, up to the converged reference the dataset was generated with;
//! - the simulator as an interactive application steps it ([`FrameStepper`]: the previous
//!   frame's ground truth carried with the skin in one step, then a small budget);
//! - GarMatNet at `Detail::Full` and `Detail::Smooth`, batch 1 and batched, on every device
//!   asked for, for the main model and any variants (other hidden sizes, low-rank heads);
//! - the TailorNet-style baseline (one pose-only model per target material).
//!
//! Every network output goes through the same body push-out as [`Predictor::predict`].
//! Results are written as `bench.json`, `bench.md` and `pareto.png` (log-scale time axis).

use std::path::{Path, PathBuf};
use std::time::Instant;

use garmatnet_core::{Material, Pose, Real, Vec3};
use garmatnet_model::{Detail, GarMatNetModel, Predictor, PushOut, push_out, select_device};
use garmatnet_sim::{
    CanonicalDraper, DrapeProtocol, DrapeSettings, FrameStepper, SequenceResume, SequenceSettings,
    drape_sequence,
};
use serde::{Deserialize, Serialize};

use crate::data::files::split_path;
use crate::data::loader::{SampleKey, TrainingDataset};
use crate::data::split::Split;
use crate::error::{Error, Result};
use crate::evaluation::prediction_errors::{load_with_same_test, mirror_of, predict_baseline};
use crate::training::baseline::Baseline;

pub use crate::harness::bench_report::{BenchReport, BenchRow};
use crate::harness::bench_report::{mark_pareto, revision_note, write_report};

/// What to measure.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct BenchConfig {
    /// Devices the networks run on (`cpu`, `gpu`); one that this build or machine lacks is
    /// skipped and listed in [`BenchReport::skipped`].
    pub devices: Vec<String>,
    /// Held-out samples the networks are measured on (spread evenly over the test set).
    pub samples: usize,
    /// How many of those the simulator is run on (it is ~1000× slower).
    pub sim_samples: usize,
    /// Newton-iteration budgets of the simulator's final converge; budgets at or above the
    /// dataset's own cap give the converged reference.
    pub sim_budgets: Vec<usize>,
    /// Newton-iteration budgets of the simulator stepped frame by frame ([`FrameStepper`]):
    /// the previous frame's ground truth carried with the skin to the sample's pose in one
    /// step (no walk) and given at most this many iterations, on a solver made beforehand as
    /// an application keeps one (only the step is timed). Empty: none.
    pub sim_frame_budgets: Vec<usize>,
    /// Newton-iteration budgets to polish the main model's predictions with, on each device
    /// (the solver runs on the CPU): each sample's prediction handed to the simulator on its
    /// posed body ([`FrameStepper`], friction measured from the prediction) and given at most
    /// this many iterations; the time covers the prediction, making the solver and the
    /// iterations. Empty: none.
    pub polish_budgets: Vec<usize>,
    /// Batch size of the batched rows (the samples repeated to fill it).
    pub batch: usize,
    /// Timed repetitions of every batch-1 prediction (the median is reported).
    pub repeats: usize,
}

impl Default for BenchConfig {
    fn default() -> Self {
        Self {
            devices: vec!["cpu".into()],
            samples: 16,
            sim_samples: 3,
            sim_budgets: vec![4, 10, 25, 50, 100, 300],
            sim_frame_budgets: vec![8],
            polish_budgets: Vec::new(),
            batch: 64,
            repeats: 5,
        }
    }
}

/// The files `garmatnet bench` reads and where it writes.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchInputs {
    /// The dataset directory the models were trained on.
    pub data_dir: PathBuf,
    /// The main model; its split (next to it) chooses the held-out samples.
    pub model: PathBuf,
    /// More models on the same template, each with a display name (e.g. `hidden 256`,
    /// `rank 64`).
    pub variants: Vec<(String, PathBuf)>,
    /// A baseline directory from `garmatnet train-baseline`.
    pub baseline: Option<PathBuf>,
    /// Output directory.
    pub out_dir: PathBuf,
}

/// Runs the harness and writes `bench.json`, `bench.md` and `pareto.png` into
/// `inputs.out_dir`.
///
/// # Errors
/// [`Error::Split`] if the main model has no split, or a variant's split holds out other
/// test samples (or it has none); dataset, model and baseline loading errors; [`Error::InvalidConfig`] for zero samples, budgets, batch or repeats.
pub fn run_bench(inputs: &BenchInputs, config: &BenchConfig) -> Result<BenchReport> {
    if config.samples == 0 || config.batch == 0 || config.repeats == 0 {
        return Err(Error::InvalidConfig(
            "bench samples, batch and repeats must be at least 1".into(),
        ));
    }
    let data = TrainingDataset::open(&inputs.data_dir, true)?;
    // The main model's own split, checked against the dataset and the model's record of it.
    let provenance = GarMatNetModel::load(&inputs.model, &select_device("cpu")?)?
        .meta
        .provenance;
    let split =
        Split::read_for_model(&inputs.model, &provenance, data.spec(), data.dataset_hash())?;
    let keys = choose_samples(&split.comparison_test(), config.samples);
    if keys.is_empty() {
        return Err(Error::Split {
            path: split_path(&inputs.model),
            message: "no held-out sample of a target material after the first frame".into(),
        });
    }
    // Each variant must hold out the same test samples as the main model, or its error
    // could be measured on its own training data; checked before the simulator's long phase.
    for (name, path) in &inputs.variants {
        let what = format!("variant `{name}`");
        load_with_same_test(path, &what, &split, &data, &select_device("cpu")?)?;
    }
    // So must the baseline cover the main model's target materials.
    let baseline = match &inputs.baseline {
        Some(dir) => Some(Baseline::load_for(
            dir,
            &select_device("cpu")?,
            &data,
            &split,
        )?),
        None => None,
    };
    let _lock = crate::data::loader::create_locked_dir(&inputs.out_dir, "benchmark")?;
    let spec = data.spec();
    let mut cases = Vec::with_capacity(keys.len());
    for &key in &keys {
        let omega = spec.materials[key.material].omega;
        cases.push(Case {
            key,
            pose: spec.poses[key.pose].clone(),
            material: Material::from_array(omega)?,
            truth: data.truth(key)?.simulated,
        });
    }
    let mut rows = Vec::new();
    let mut skipped = Vec::new();

    rows.extend(bench_simulator(
        &data,
        &cases[..config.sim_samples.min(cases.len())],
        config,
    )?);

    let mut models = vec![("GarMatNet".to_owned(), inputs.model.clone())];
    models.extend(
        inputs
            .variants
            .iter()
            .map(|(name, path)| (format!("GarMatNet {name}"), path.clone())),
    );
    for device_name in &config.devices {
        let device = match select_device(device_name) {
            Ok(d) => d,
            Err(e) => {
                skipped.push(format!("device {device_name}: {e}"));
                continue;
            }
        };
        for (m, (name, path)) in models.iter().enumerate() {
            let model = GarMatNetModel::load(path, &device)?;
            model.ensure_template(data.template_hash(), data.vertex_count())?;
            let size_mb = file_mb(path);
            let predictor =
                Predictor::for_garment(model, data.garment(), data.body().clone(), &device)?;
            for detail in [Detail::Full, Detail::Smooth] {
                let label = format!("{name} {detail}");
                rows.extend(bench_network(
                    &predictor,
                    &data,
                    &cases,
                    detail,
                    config,
                    &label,
                    device_name,
                    size_mb,
                )?);
            }
            // The main model (the first) also hands its predictions to the simulator.
            if m == 0 {
                rows.extend(bench_polish(
                    &predictor,
                    &data,
                    &cases,
                    config,
                    device_name,
                    size_mb,
                )?);
            }
        }
    }

    if let (Some(dir), Some(baseline)) = (&inputs.baseline, &baseline) {
        match bench_baseline(dir, baseline, &data, &cases, config)? {
            Ok(row) => rows.push(row),
            Err(why) => skipped.push(why),
        }
    }

    mark_pareto(&mut rows);
    rows.sort_by(|a, b| a.ms_per_frame.total_cmp(&b.ms_per_frame));
    let report = BenchReport {
        dataset_hash: data.dataset_hash().to_owned(),
        samples: keys
            .iter()
            .map(|k| garmatnet_sim::sample_stem(k.material, k.pose))
            .collect(),
        rows,
        skipped,
        notes: revision_note(data.spec().ground_truth_revision, config.sim_samples > 0)
            .into_iter()
            .collect(),
        threads: std::thread::available_parallelism().map_or(1, usize::from),
    };
    write_report(&inputs.out_dir, &report)?;
    Ok(report)
}

/// One held-out sample with its inputs and ground truth.
struct Case {
    key: SampleKey,
    pose: Pose,
    material: Material,
    truth: Vec<Vec3>,
}

/// Up to `count` keys spread evenly over `test`, skipping first frames (the simulator needs
/// the previous frame to warm-start from).
fn choose_samples(test: &[SampleKey], count: usize) -> Vec<SampleKey> {
    let usable: Vec<SampleKey> = test.iter().copied().filter(|k| k.pose >= 1).collect();
    if usable.len() <= count {
        return usable;
    }
    (0..count)
        .map(|i| usable[i * usable.len() / count])
        .collect()
}

fn mean_error_mm(predicted: &[Vec3], truth: &[Vec3]) -> Real {
    let sum: Real = predicted
        .iter()
        .zip(truth)
        .map(|(p, t)| (p - t).norm())
        .sum();
    1e3 * sum / truth.len().max(1) as Real
}

fn median(mut values: Vec<Real>) -> Real {
    values.sort_by(Real::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(Real::NAN)
}

fn file_mb(path: &Path) -> Option<Real> {
    std::fs::metadata(path).ok().map(|m| m.len() as Real / 1e6)
}

/// The solver settings `data` was made with, from its manifest.
fn dataset_settings(data: &TrainingDataset) -> Result<SequenceSettings> {
    SequenceSettings::from_manifest(&data.spec().solver).map_err(|e| Error::Dataset {
        dir: data.dir().to_owned(),
        message: format!("the manifest's solver settings do not parse: {e}"),
    })
}

fn bench_simulator(
    data: &TrainingDataset,
    cases: &[Case],
    config: &BenchConfig,
) -> Result<Vec<BenchRow>> {
    if cases.is_empty() {
        return Ok(Vec::new());
    }
    let reference = dataset_settings(data)?;
    let cap = reference.drape.max_iterations;
    let mut budgets: Vec<usize> = config
        .sim_budgets
        .iter()
        .map(|&b| b.clamp(1, cap))
        .collect();
    budgets.push(cap);
    budgets.sort_unstable();
    budgets.dedup();
    // Every case starts from the ground truth of the frame before it.
    let previous_truth = |case: &Case| {
        data.truth(SampleKey {
            material: case.key.material,
            pose: case.key.pose - 1,
        })
    };
    let mut rows = Vec::new();
    for budget in budgets {
        let mut settings = reference.clone();
        settings.drape.max_iterations = budget;
        let (mut ms, mut err) = (Vec::new(), 0.0);
        for case in cases {
            if data.spec().protocol == DrapeProtocol::Canonical {
                // A canonical sample is draped on its own from the fabric's rest drape; only
                // the path and converge are timed, the rest drape is shared by its samples.
                let draper =
                    CanonicalDraper::new(data.garment(), data.body(), &case.material, &settings)?;
                let started = Instant::now();
                let (result, _) = draper.drape(&data.spec().poses[case.key.pose])?;
                ms.push(started.elapsed().as_secs_f64() * 1e3);
                err += mean_error_mm(&result, &case.truth);
                continue;
            }
            let previous = previous_truth(case)?;
            let mut result = Vec::new();
            let started = Instant::now();
            drape_sequence(
                data.garment(),
                data.body(),
                &case.material,
                &data.spec().poses[..=case.key.pose],
                &settings,
                Some(SequenceResume {
                    next: case.key.pose,
                    positions: previous.simulated,
                }),
                |_, x, _| {
                    result = x.to_vec();
                    Ok(())
                },
            )?;
            ms.push(started.elapsed().as_secs_f64() * 1e3);
            err += mean_error_mm(&result, &case.truth);
        }
        let method = if budget == cap {
            format!("simulator ≤ {budget} it (reference)")
        } else {
            format!("simulator ≤ {budget} it")
        };
        rows.push(simulator_row(method, &ms, err));
    }
    for &budget in &config.sim_frame_budgets {
        let settings = DrapeSettings {
            max_iterations: budget.clamp(1, cap),
            ..reference.drape.clone()
        };
        let (mut ms, mut err) = (Vec::new(), 0.0);
        for case in cases {
            let previous = previous_truth(case)?;
            let poses = &data.spec().poses;
            let mut shirt = FrameStepper::new(
                data.garment(),
                data.body(),
                &case.material,
                &settings,
                &poses[case.key.pose - 1],
                previous.simulated,
            )?
            .follow_body(reference.follow_body);
            let started = Instant::now();
            shirt.step(&poses[case.key.pose])?;
            ms.push(started.elapsed().as_secs_f64() * 1e3);
            err += mean_error_mm(shirt.positions(), &case.truth);
        }
        let method = format!("simulator frame, one step ≤ {} it", settings.max_iterations);
        rows.push(simulator_row(method, &ms, err));
    }
    Ok(rows)
}

/// A simulator row from each sample's milliseconds and the sum of their errors (mm).
fn simulator_row(method: String, ms: &[Real], error_sum_mm: Real) -> BenchRow {
    BenchRow {
        method,
        family: "simulator".into(),
        device: "cpu, 1 thread".into(),
        batch: 1,
        ms_per_frame: ms.iter().sum::<Real>() / ms.len() as Real,
        error_mm: error_sum_mm / ms.len() as Real,
        samples: ms.len(),
        size_mb: None,
        pareto: false,
    }
}

/// `predictor`'s predictions polished by the simulator (on the CPU, one thread), one row per
/// budget of [`BenchConfig::polish_budgets`] (batch 1); none without budgets.
fn bench_polish(
    predictor: &Predictor,
    data: &TrainingDataset,
    cases: &[Case],
    config: &BenchConfig,
    device: &str,
    size_mb: Option<Real>,
) -> Result<Vec<BenchRow>> {
    if config.polish_budgets.is_empty() {
        return Ok(Vec::new());
    }
    let reference = dataset_settings(data)?;
    // Warm-up: the first prediction allocates.
    predictor.predict(&cases[0].pose, &cases[0].material, Detail::Full)?;
    let mut rows = Vec::new();
    for &budget in &config.polish_budgets {
        let settings = DrapeSettings {
            max_iterations: budget.clamp(1, reference.drape.max_iterations),
            ..reference.drape.clone()
        };
        let (mut ms, mut err) = (Vec::new(), 0.0);
        for case in cases {
            let started = Instant::now();
            let predicted = predictor.predict(&case.pose, &case.material, Detail::Full)?;
            let mut shirt = FrameStepper::new(
                data.garment(),
                data.body(),
                &case.material,
                &settings,
                &case.pose,
                predicted.vertices,
            )?;
            shirt.step(&case.pose)?;
            ms.push(started.elapsed().as_secs_f64() * 1e3);
            err += mean_error_mm(shirt.positions(), &case.truth);
        }
        rows.push(BenchRow {
            method: format!(
                "GarMatNet full + simulator ≤ {} it",
                settings.max_iterations
            ),
            family: "polish".into(),
            device: if device == "cpu" {
                device.to_owned()
            } else {
                format!("{device}, solver on cpu")
            },
            batch: 1,
            ms_per_frame: median(ms),
            error_mm: err / cases.len() as Real,
            samples: cases.len(),
            size_mb,
            pareto: false,
        });
    }
    Ok(rows)
}

#[allow(clippy::too_many_arguments)]
fn bench_network(
    predictor: &Predictor,
    data: &TrainingDataset,
    cases: &[Case],
    detail: Detail,
    config: &BenchConfig,
    label: &str,
    device: &str,
    size_mb: Option<Real>,
) -> Result<Vec<BenchRow>> {
    // Warm-up: the first call allocates and (on a GPU) compiles kernels.
    predictor.predict(&cases[0].pose, &cases[0].material, detail)?;
    let mut times = Vec::new();
    let mut err = 0.0;
    for case in cases {
        for r in 0..config.repeats {
            let started = Instant::now();
            let mesh = predictor.predict(&case.pose, &case.material, detail)?;
            times.push(started.elapsed().as_secs_f64() * 1e3);
            if r == 0 {
                err += mean_error_mm(&mesh.vertices, &case.truth);
            }
        }
    }
    let batch1 = BenchRow {
        method: label.to_owned(),
        family: "garmatnet".into(),
        device: device.to_owned(),
        batch: 1,
        ms_per_frame: median(times),
        error_mm: err / cases.len() as Real,
        samples: cases.len(),
        size_mb,
        pareto: false,
    };

    // Batched: every sample once, repeated to fill whole batches, each batch one call,
    // pushed out of the posed bodies. (Only the first `batch` samples were predicted before,
    // so with more samples than a batch the error was averaged over too few.)
    let batches = cases.len().div_ceil(config.batch);
    let items: Vec<(Pose, [Real; 6])> = (0..batches * config.batch)
        .map(|i| {
            let c = &cases[i % cases.len()];
            (c.pose.clone(), c.material.to_normalized())
        })
        .collect();
    let bodies: Vec<_> = cases.iter().map(|c| data.body().pose(&c.pose)).collect();
    let epsilon = PushOut::default().epsilon;
    let _ = predictor.predict_batch(&items[..1], detail)?;
    let started = Instant::now();
    let mut meshes = Vec::with_capacity(items.len());
    for chunk in items.chunks(config.batch) {
        meshes.extend(predictor.predict_batch(chunk, detail)?);
    }
    for (i, mesh) in meshes.iter_mut().enumerate() {
        let _ = push_out(&mut mesh.vertices, &bodies[i % cases.len()], epsilon);
    }
    let ms = started.elapsed().as_secs_f64() * 1e3 / items.len() as Real;
    let batched_err = cases
        .iter()
        .zip(&meshes)
        .map(|(c, m)| mean_error_mm(&m.vertices, &c.truth))
        .sum::<Real>()
        / cases.len() as Real;
    Ok(vec![
        batch1,
        BenchRow {
            method: label.to_owned(),
            family: "garmatnet".into(),
            device: device.to_owned(),
            batch: config.batch,
            ms_per_frame: ms,
            error_mm: batched_err,
            samples: cases.len(),
            size_mb,
            pareto: false,
        },
    ])
}

/// The baseline's batch-1 row, or why it could not be measured.
fn bench_baseline(
    dir: &Path,
    baseline: &Baseline,
    data: &TrainingDataset,
    cases: &[Case],
    config: &BenchConfig,
) -> Result<std::result::Result<BenchRow, String>> {
    let device = select_device("cpu")?;
    let epsilon = PushOut::default().epsilon;
    let (mut times, mut err, mut count) = (Vec::new(), 0.0, 0);
    for case in cases {
        let Some(net) = baseline
            .materials
            .iter()
            .find(|m| m.material == case.key.material)
        else {
            continue;
        };
        let posed = data.body().pose(&case.pose);
        let truth = data.truth(case.key)?;
        for r in 0..config.repeats {
            let started = Instant::now();
            // Mirror-averaged as the GarMatNet rows' predictor (`for_garment`) averages.
            let prediction =
                predict_baseline(net, data, &[case.key], &device, mirror_of(data, true))?.remove(0);
            let mut garment: Vec<Vec3> = truth
                .body_points
                .iter()
                .zip(prediction.d_fitting.iter().zip(&prediction.d_local))
                .map(|(b, (f, l))| b + (f + l))
                .collect();
            let _ = push_out(&mut garment, &posed, epsilon);
            times.push(started.elapsed().as_secs_f64() * 1e3);
            if r == 0 {
                err += mean_error_mm(&garment, &case.truth);
                count += 1;
            }
        }
    }
    if count == 0 {
        return Ok(Err(format!(
            "baseline {}: it has no net for the measured samples' materials",
            dir.display()
        )));
    }
    Ok(Ok(BenchRow {
        method: "TailorNet-style baseline".into(),
        family: "baseline".into(),
        device: "cpu".into(),
        batch: 1,
        ms_per_frame: median(times),
        error_mm: err / count as Real,
        samples: count,
        size_mb: dir_mb(dir),
        pareto: false,
    }))
}

fn dir_mb(dir: &Path) -> Option<Real> {
    let entries = std::fs::read_dir(dir).ok()?;
    let bytes: u64 = entries
        .flatten()
        .filter_map(|e| e.metadata().ok())
        .filter(std::fs::Metadata::is_file)
        .map(|m| m.len())
        .sum();
    Some(bytes as Real / 1e6)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_are_spread_and_skip_first_frames() {
        let test: Vec<SampleKey> = (0..3)
            .flat_map(|m| {
                (0..10).map(move |p| SampleKey {
                    material: m,
                    pose: p * 10,
                })
            })
            .collect();
        let chosen = choose_samples(&test, 6);
        assert_eq!(chosen.len(), 6);
        assert!(chosen.iter().all(|k| k.pose >= 1));
        let materials: std::collections::BTreeSet<usize> =
            chosen.iter().map(|k| k.material).collect();
        assert_eq!(
            materials.len(),
            3,
            "every material is represented: {chosen:?}"
        );
        assert_eq!(choose_samples(&test[..3], 10).len(), 2);
    }
}
