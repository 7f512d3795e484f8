//! Dataset generation: every (material, pose) drape of a T-shirt on the capsule body, or
//! those of a [strided plan](SamplePlan::Strided), written as a resumable, shardable dataset
//! ([`crate::dataset::writer`]).
//!
//! Under the [canonical protocol](DrapeProtocol::Canonical) (revisions 3 and 4, the default of
//! `garmatnet simulate`) each sample is draped on its own from its material's rest drape
//! ([`CanonicalDraper`]); the workers take samples pose-major (every material's first pose,
//! then every material's second, ...), so an interrupted run leaves a smaller dataset whose
//! materials share a prefix of the poses (of the plan's samples, under a strided plan), and a
//! resumed run drapes exactly the plan's samples not on disk. Materials run in parallel
//! (rayon). Under the
//! [walk](DrapeProtocol::Walk) each material walks the whole pose sequence in order, every
//! pose warm-started from the previous one ([`drape_sequence`]); a material whose first `k`
//! poses are on disk resumes from pose `k - 1`'s saved garment. Both round their state to the
//! f32 precision samples are stored in, so a resumed, sharded or differently threaded run
//! writes the same bytes an uninterrupted one would (tested).

use std::path::PathBuf;
use std::time::Instant;

use garmatnet_core::{
    CapsuleBody, Garment, Material, Pose, Resolution, SmoothingSettings, TemplateInfo, Vec3,
};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::dataset::manifest::{
    BodyInfo, DatasetSpec, GROUND_TRUTH_REVISION, MaterialEntry, SamplePlan, SampleStats,
    SmoothingInfo, sample_stem,
};
use crate::dataset::reuse::import_samples;
use crate::dataset::sample_arrays::read_simulated;
use crate::dataset::sample_deriver::{BODY_NAME, SampleDeriver};
use crate::dataset::shard::Shard;
use crate::dataset::writer::{DatasetWriter, samples_dir};
use crate::error::{Error, Result};
use crate::solver::canonical::{CanonicalDraper, DrapeProtocol};
use crate::solver::drape_solver::DrapeStats;
use crate::solver::garment_drape::{SequenceResume, SequenceSettings, drape_sequence};

/// What to generate.
#[derive(Debug, Clone)]
pub struct GenerateConfig {
    /// The dataset directory (created, or resumed when it exists).
    pub out: PathBuf,
    /// Named materials (physical ω).
    pub materials: Vec<(String, Material)>,
    /// The pose sequence, walked in order for every material.
    pub poses: Vec<Pose>,
    /// Each pose's frame index in its source sequence (held-out poses are chosen by it).
    pub frames: Vec<usize>,
    /// Template resolution.
    pub resolution: Resolution,
    /// Solver and sequence-walking settings.
    pub sequence: SequenceSettings,
    /// How each sample is draped: [`DrapeProtocol::Canonical`] (each on its own, from the
    /// rest drape; the datasets of revisions 3 and 4) or [`DrapeProtocol::Walk`] (each from the previous
    /// pose of its material's walk).
    pub protocol: DrapeProtocol,
    /// Which (material, pose) samples to drape: every one, or a
    /// [strided](SamplePlan::Strided) plan that covers more poses for the same solver time
    /// (canonical protocol only).
    pub plan: SamplePlan,
    /// The smoothing that splits drapes into smooth garment and details.
    pub smoothing: SmoothingSettings,
    /// Worker threads (materials in parallel); 0 = rayon's default (all cores).
    pub threads: usize,
    /// This process's share of the materials.
    pub shard: Shard,
    /// Existing datasets to build on: before anything is draped, their finished samples of
    /// the materials this dataset also lists (same name and ω; this shard's) are copied in
    /// ([`crate::import_samples`]), so only the rest is simulated. They must have been made
    /// with the same template and settings (a walk also with the same poses; canonical
    /// samples go to this dataset's equal poses).
    pub reuse: Vec<PathBuf>,
}

/// One finished sample, for progress reporting.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SampleDone {
    /// Material index.
    pub material: usize,
    /// Pose index.
    pub pose: usize,
    /// Whether the solver met its residual tolerances.
    pub converged: bool,
    /// Wall time of the sample (milliseconds): by the canonical protocol, the path from the
    /// rest drape to the pose plus the converge; in a walk, the walk from the previous pose
    /// (or the rest drape, for a material's first pose) plus the converge.
    pub wall_time_ms: f64,
}

/// What [`generate_dataset`] tells its progress callback.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum GenerateEvent {
    /// Once, before anything is draped: the samples of this shard in all, and how many of
    /// them will not be draped (finished by an earlier run, or just copied from
    /// [`GenerateConfig::reuse`], before each material's first missing pose), so progress
    /// can start where the dataset stands.
    Started {
        /// Samples of this shard in all.
        shard_samples: usize,
        /// Samples of this shard on disk that this run does not drape again
        /// ([`GenerateReport::skipped`]).
        done: usize,
    },
    /// A sample was draped and written.
    Sample(SampleDone),
}

/// What a generation run did.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct GenerateReport {
    /// Samples this run wrote.
    pub written: usize,
    /// Samples copied from the datasets in [`GenerateConfig::reuse`] (not counted in
    /// `written`; counted in `skipped` unless they lie after a gap in their material's walk,
    /// where the walk drapes them again).
    #[serde(default)]
    pub imported: usize,
    /// Samples of this shard already on disk and not draped again (a material's walk
    /// resumes at its first missing pose, so finished samples after it are re-draped and
    /// counted in `written`).
    pub skipped: usize,
    /// Samples of this shard in all.
    pub shard_samples: usize,
    /// Written samples whose drape did not meet the residual tolerances.
    pub not_converged: usize,
    /// Mean wall time per written sample (milliseconds, per worker).
    pub mean_sample_ms: f64,
    /// Wall time of the whole run (seconds).
    pub wall_time_s: f64,
}

/// The dataset spec `config` describes (template, body, materials, poses, settings).
///
/// # Errors
/// [`Error::SettingsJson`] if the solver settings cannot be serialised (a bug).
pub fn dataset_spec(config: &GenerateConfig, garment: &Garment) -> Result<DatasetSpec> {
    Ok(DatasetSpec {
        template: TemplateInfo::of(garment),
        body: BodyInfo {
            name: BODY_NAME.to_owned(),
        },
        materials: config
            .materials
            .iter()
            .map(|(name, m)| MaterialEntry {
                name: name.clone(),
                omega: m.as_array(),
                omega_normalized: m.to_normalized(),
            })
            .collect(),
        poses: config.poses.clone(),
        frames: config.frames.clone(),
        solver: serde_json::to_value(&config.sequence)
            .map_err(|source| Error::SettingsJson { source })?,
        smoothing: SmoothingInfo {
            lambda: config.smoothing.lambda,
            iterations: config.smoothing.iterations as u32,
            weights: format!("{:?}", config.smoothing.weights).to_lowercase(),
        },
        ground_truth_revision: Some(GROUND_TRUTH_REVISION),
        protocol: config.protocol,
        plan: config.plan,
    })
}

/// Generates (or resumes) the dataset. `on_progress` hears [`GenerateEvent::Started`] once,
/// then [`GenerateEvent::Sample`] after each written sample;
/// `should_stop` is polled between samples and stops the run with [`Error::Interrupted`]
/// (finished samples stay on disk).
///
/// # Errors
/// [`Error::Interrupted`]; dataset errors (lock held by another process, a different
/// existing dataset in `out`, unwritable directory); settings that fail
/// [`SequenceSettings::validate`] and a spec that fails [`DatasetSpec::validate`] (e.g.
/// [`Error::InvalidSpec`] for a strided plan under the walk protocol), before anything is
/// written; [`Error::ThreadPool`] if the
/// `threads` workers cannot be started; solver errors.
pub fn generate_dataset(
    config: &GenerateConfig,
    on_progress: &(dyn Fn(GenerateEvent) + Sync),
    should_stop: &(dyn Fn() -> bool + Sync),
) -> Result<GenerateReport> {
    let started = Instant::now();
    // Before anything is written: a walk with settings out of range could not finish.
    config.sequence.validate()?;
    let deriver = SampleDeriver::new(config.resolution, config.smoothing)?;
    let (body, garment) = (deriver.body(), deriver.garment());
    let writer = DatasetWriter::open(&config.out, dataset_spec(config, garment)?)?;
    let mut imported = 0;
    for source in &config.reuse {
        imported += import_samples(&writer, source, config.shard)?.imported;
    }
    let materials: Vec<usize> = (0..config.materials.len())
        .filter(|&m| config.shard.contains_material(m))
        .collect();
    let plan = config.plan;
    let shard_samples: usize = materials
        .iter()
        .map(|&m| plan.material_sample_count(m, config.poses.len()))
        .sum();
    // A material's walk resumes at its first unfinished pose and drapes every pose after it
    // (the walk is continuous), so finished samples past a gap are written again: only the
    // poses before that first gap are skipped. Canonical samples stand alone: every finished
    // one is skipped.
    let skipped: usize = materials
        .iter()
        .map(|&m| match config.protocol {
            DrapeProtocol::Walk => (0..config.poses.len())
                .find(|&p| !writer.is_done(m, p))
                .unwrap_or(config.poses.len()),
            DrapeProtocol::Canonical => (0..config.poses.len())
                .filter(|&p| plan.includes(m, p) && writer.is_done(m, p))
                .count(),
        })
        .sum();
    on_progress(GenerateEvent::Started {
        shard_samples,
        done: skipped,
    });

    // Writes one draped sample with its derived arrays and reports it.
    let record = |m: usize, p: usize, x: &[Vec3], stats: &DrapeStats, sample_ms: f64| {
        let arrays = deriver.arrays(x, &config.poses[p])?;
        let sample_stats = SampleStats {
            iterations: stats.iterations as u64,
            residual: stats.final_residual,
            max_penetration_m: stats.max_penetration,
            max_depth_before_projection_m: Some(stats.max_depth_before_projection),
            max_strain: stats.max_strain,
            wall_time_ms: sample_ms,
            converged: stats.converged,
        };
        writer.write_sample(m, p, &arrays, sample_stats)?;
        on_progress(GenerateEvent::Sample(SampleDone {
            material: m,
            pose: p,
            converged: stats.converged,
            wall_time_ms: sample_ms,
        }));
        Ok::<(), Error>(())
    };

    let walk_material = |m: usize| -> Result<(usize, usize, f64)> {
        let n_poses = config.poses.len();
        let Some(next) = (0..n_poses).find(|&p| !writer.is_done(m, p)) else {
            return Ok((0, 0, 0.0));
        };
        let resume = if next == 0 {
            None
        } else {
            let stem = sample_stem(m, next - 1);
            let positions = read_simulated(&samples_dir(&config.out).join(&stem), &stem)?;
            Some(SequenceResume { next, positions })
        };
        let (mut written, mut failed, mut time) = (0, 0, 0.0);
        let material = &config.materials[m].1;
        // A sample's cost is the walk from the previous frame plus the converge, not just the
        // final drape that `DrapeStats::wall_time_ms` times.
        let mut last = Instant::now();
        let on_pose = |p: usize, x: &[Vec3], stats: &DrapeStats| -> Result<()> {
            if should_stop() {
                return Err(Error::Interrupted);
            }
            let sample_ms = last.elapsed().as_secs_f64() * 1e3;
            record(m, p, x, stats, sample_ms)?;
            written += 1;
            failed += usize::from(!stats.converged);
            time += sample_ms;
            last = Instant::now();
            Ok(())
        };
        drape_sequence(
            garment,
            body,
            material,
            &config.poses,
            &config.sequence,
            resume,
            on_pose,
        )?;
        Ok((written, failed, time))
    };

    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(config.threads)
        .build()
        .map_err(|source| Error::ThreadPool {
            threads: config.threads,
            source,
        })?;
    let results: Vec<Result<(usize, usize, f64)>> = match config.protocol {
        // One material per task: rayon may otherwise hand a worker a run of several
        // materials to walk sequentially while the other workers sit idle at the end
        // (seen: the last two materials of a 30-material run on one worker of two).
        DrapeProtocol::Walk => pool.install(|| {
            materials
                .par_iter()
                .with_max_len(1)
                .map(|&m| walk_material(m))
                .collect()
        }),
        DrapeProtocol::Canonical => {
            let drape = |m: usize, p: usize, draper: &CanonicalDraper| {
                let started = Instant::now();
                let (x, stats) = draper.drape(&config.poses[p])?;
                let sample_ms = started.elapsed().as_secs_f64() * 1e3;
                record(m, p, &x, &stats, sample_ms)?;
                Ok((stats.converged, sample_ms))
            };
            vec![canonical_samples(
                &pool,
                config,
                garment,
                body,
                &materials,
                &|m, p| writer.is_done(m, p),
                &drape,
                should_stop,
            )]
        }
    };
    writer.flush()?;
    let mut report = GenerateReport {
        imported,
        skipped,
        shard_samples,
        ..GenerateReport::default()
    };
    let mut total_ms = 0.0;
    let mut first_error = None;
    for r in results {
        match r {
            Ok((w, f, t)) => {
                report.written += w;
                report.not_converged += f;
                total_ms += t;
            }
            Err(e) => {
                first_error.get_or_insert(e);
            }
        }
    }
    if let Some(e) = first_error {
        return Err(e);
    }
    report.mean_sample_ms = if report.written > 0 {
        total_ms / report.written as f64
    } else {
        0.0
    };
    report.wall_time_s = started.elapsed().as_secs_f64();
    Ok(report)
}

/// Drapes and records sample (material, pose) with a material's draper; returns whether
/// it converged and its cost in milliseconds.
type DrapeOne<'a> = dyn Fn(usize, usize, &CanonicalDraper) -> Result<(bool, f64)> + Sync + 'a;

/// Drapes every unfinished canonical sample of `materials`, pose-major: all materials' first
/// pose, then their second, and so on, handed out one at a time from a shared queue, so an
/// interrupted run leaves every material with the same prefix of poses (a smaller dataset
/// that can already be trained on) rather than some materials finished and others not
/// begun. A material's rest drape ([`CanonicalDraper::new`]) is made once, by the first
/// worker that needs it; its cost is shared equally among the material's samples in the
/// returned time. Returns (written, not converged, summed sample milliseconds).
#[allow(clippy::too_many_arguments)]
fn canonical_samples(
    pool: &rayon::ThreadPool,
    config: &GenerateConfig,
    garment: &Garment,
    body: &CapsuleBody,
    materials: &[usize],
    is_done: &(dyn Fn(usize, usize) -> bool + Sync),
    drape: &DrapeOne<'_>,
    should_stop: &(dyn Fn() -> bool + Sync),
) -> Result<(usize, usize, f64)> {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::{Mutex, OnceLock};

    let todo: Vec<(usize, usize)> = (0..config.poses.len())
        .flat_map(|p| materials.iter().map(move |&m| (m, p)))
        .filter(|&(m, p)| config.plan.includes(m, p) && !is_done(m, p))
        .collect();
    let per_material: Vec<usize> = (0..config.materials.len())
        .map(|m| todo.iter().filter(|t| t.0 == m).count())
        .collect();
    // The rest drape and its cost (ms) of each material, made on first use (`None` when it
    // failed: its error is the run's).
    let drapers: Vec<OnceLock<Option<(CanonicalDraper, f64)>>> = (0..config.materials.len())
        .map(|_| OnceLock::new())
        .collect();
    let next = AtomicUsize::new(0);
    let totals = Mutex::new((0usize, 0usize, 0.0f64));
    let first_error: Mutex<Option<Error>> = Mutex::new(None);
    let fail = |e: Error| {
        first_error
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .get_or_insert(e);
        // Stop handing out work: the run reports its first error.
        next.store(todo.len(), Ordering::Relaxed);
    };
    let worker = || {
        loop {
            let i = next.fetch_add(1, Ordering::Relaxed);
            let Some(&(m, p)) = todo.get(i) else { return };
            if should_stop() {
                fail(Error::Interrupted);
                return;
            }
            let made = drapers[m].get_or_init(|| {
                let started = Instant::now();
                match CanonicalDraper::new(garment, body, &config.materials[m].1, &config.sequence)
                {
                    Ok(d) => Some((d, started.elapsed().as_secs_f64() * 1e3)),
                    Err(e) => {
                        fail(e);
                        None
                    }
                }
            });
            let Some((draper, rest_ms)) = made else {
                return;
            };
            let result = drape(m, p, draper)
                .map(|(converged, ms)| (converged, ms + rest_ms / per_material[m] as f64));
            match result {
                Ok((converged, ms)) => {
                    let mut t = totals
                        .lock()
                        .unwrap_or_else(std::sync::PoisonError::into_inner);
                    t.0 += 1;
                    t.1 += usize::from(!converged);
                    t.2 += ms;
                }
                Err(e) => {
                    fail(e);
                    return;
                }
            }
        }
    };
    pool.scope(|s| {
        for _ in 0..pool.current_num_threads() {
            s.spawn(|_| worker());
        }
    });
    if let Some(e) = first_error
        .into_inner()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
    {
        return Err(e);
    }
    Ok(totals
        .into_inner()
        .unwrap_or_else(std::sync::PoisonError::into_inner))
}
