//! Run: `cargo bench --bench predict` (add `--features wgpu` to time the GPU too: the same
//! groups again, named `..._gpu...`, when a wgpu adapter answers; without one they are skipped
//! with a message)
//!
//! Prediction speed of the full pipeline (body skinning + nets on the pose and its mirror
//! image + mirror averaging + assembly + push-out; `Full_no_mirror` without the mirror) at
//! batch 1 and 64 (and 1024 with the rank-128 head), `Detail::Full` and `Detail::Smooth`,
//! default and paper resolutions, with the paper-sized nets (hidden 512/64/512), full-width
//! and with a rank-128 output head; a 100-character `Scene` with mixed detail where 10 % of
//! the characters change each frame (pushed out of the body, and with push-out off); and 120 frames of the built-in motion in
//! one `predict_sequence` call (batched nets, each frame pushed out of its posed body), as
//! `garmatnet drape --frames` predicts them. Weights are untrained: speed does not depend on
//! their values.

use burn::prelude::Device;
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use garmatnet::core::{
    CapsuleBody, Garment, JointLimits, Material, Pose, Resolution, SplitMix64, TemplateInfo,
    presets,
};
use garmatnet::model::{
    Character, Detail, GarMatNetConfig, GarMatNetModel, Predictor, PushOut, Scene,
};
use garmatnet::sim::MotionGenerator;

/// The paper-sized nets for `resolution`, with a low-rank output head of `rank` components
/// when given; returns the predictor and the weights' size (MB, f32).
fn predictor(resolution: Resolution, rank: Option<usize>, device: &Device) -> (Predictor, f64) {
    let body = CapsuleBody::smpl_neutral();
    let garment = Garment::tshirt(resolution, &body).expect("template");
    device.seed(1);
    let cfg = GarMatNetConfig::new(garment.vertex_count(), 512, 64, 512).with_output_rank(rank);
    let model = GarMatNetModel::untrained(&cfg, TemplateInfo::of(&garment), device);
    let n3 = 3 * garment.vertex_count();
    let head = match rank {
        Some(k) => 512 * k + k + k * n3 + n3,
        None => 512 * n3 + n3,
    };
    let params = 2 * (72 * 512 + 512 + 6 * 64 + 64 + (512 + 64) * 512 + 512 + head);
    let megabytes = params as f64 * 4.0 / 1e6;
    (
        Predictor::for_garment(model, &garment, body, device).expect("predictor"),
        megabytes,
    )
}

fn inputs(count: usize) -> Vec<(Pose, Material)> {
    let limits = JointLimits::default();
    let mut rng = SplitMix64::new(9);
    (0..count)
        .map(|k| {
            (
                limits.sample(&mut rng, 1.0),
                presets()[k % presets().len()].material,
            )
        })
        .collect()
}

/// The devices to time, with the name their groups carry: the CPU always; with the `wgpu`
/// feature also the GPU, when a wgpu adapter runs a probe kernel (probed once per run).
fn devices() -> &'static [(&'static str, Device)] {
    static DEVICES: std::sync::OnceLock<Vec<(&'static str, Device)>> = std::sync::OnceLock::new();
    DEVICES.get_or_init(|| {
        #[allow(unused_mut)]
        let mut devices = vec![("cpu", Device::flex())];
        #[cfg(feature = "wgpu")]
        match usable_gpu() {
            Some(gpu) => devices.push(("gpu", gpu)),
            None => eprintln!("no usable wgpu adapter: the GPU groups are skipped"),
        }
        devices
    })
}

/// The GPU, if it runs a kernel and reads the result back (wgpu starts lazily and panics
/// without an adapter or a working driver, hence the `catch_unwind`).
#[cfg(feature = "wgpu")]
fn usable_gpu() -> Option<Device> {
    let gpu = garmatnet::select_device("gpu").ok()?;
    let probe = gpu.clone();
    std::panic::catch_unwind(move || {
        (burn::prelude::Tensor::<1>::from_floats([1.0f32, 2.0], &probe) * 2.0)
            .into_data()
            .try_to_vec::<f32>()
            .ok()
    })
    .ok()
    .flatten()
    .filter(|v| v == &[2.0, 4.0])
    .map(|_| gpu)
}

/// The name of a device's variant of `group`: the CPU keeps the names it always had.
fn group_name(group: &str, device: &str) -> String {
    if device == "cpu" {
        group.to_string()
    } else {
        format!("{group}_{device}")
    }
}

fn bench_predict(c: &mut Criterion) {
    for (device_name, device) in devices() {
        bench_predict_on(c, device_name, device);
    }
}

fn bench_predict_on(c: &mut Criterion, device_name: &str, device: &Device) {
    for (resolution, rank) in [
        (Resolution::Default, None),
        (Resolution::Paper, None),
        (Resolution::Default, Some(128)),
        (Resolution::Paper, Some(128)),
    ] {
        let (predictor, mb) = predictor(resolution, rank, device);
        let name = match rank {
            Some(k) => format!("{resolution}_rank{k}"),
            None => resolution.to_string(),
        };
        eprintln!(
            "{device_name} {name}: {} vertices, model {mb:.1} MB (f32)",
            predictor.vertex_count()
        );
        let mut group = c.benchmark_group(format!("predict_{device_name}_{name}"));
        let one = inputs(1);
        let batch_of = |n| -> Vec<_> {
            inputs(n)
                .into_iter()
                .map(|(p, m)| (p, m.to_normalized()))
                .collect()
        };
        let batch = batch_of(64);
        // The shipped head also at batch 1024, where a GPU has work enough to pay off.
        let large = rank.map(|_| batch_of(1024));
        for detail in [Detail::Full, Detail::Smooth] {
            group.throughput(Throughput::Elements(1));
            group.bench_function(BenchmarkId::new(format!("{detail:?}"), "batch1"), |b| {
                b.iter(|| {
                    predictor
                        .predict(&one[0].0, &one[0].1, detail)
                        .expect("prediction")
                })
            });
            group.throughput(Throughput::Elements(64));
            group.bench_function(BenchmarkId::new(format!("{detail:?}"), "batch64"), |b| {
                b.iter(|| predictor.predict_batch(&batch, detail).expect("prediction"))
            });
            if let Some(large) = &large {
                group.throughput(Throughput::Elements(large.len() as u64));
                group.bench_function(BenchmarkId::new(format!("{detail:?}"), "batch1024"), |b| {
                    b.iter(|| predictor.predict_batch(large, detail).expect("prediction"))
                });
            }
        }
        // The raw nets, without mirror averaging's second pose (`drape --no-mirror-averaging`).
        let raw = self::predictor(resolution, rank, device)
            .0
            .with_mirror_averaging(false)
            .expect("averaging off");
        group.throughput(Throughput::Elements(1));
        group.bench_function(BenchmarkId::new("Full_no_mirror", "batch1"), |b| {
            b.iter(|| {
                raw.predict(&one[0].0, &one[0].1, Detail::Full)
                    .expect("prediction")
            })
        });
        group.throughput(Throughput::Elements(64));
        group.bench_function(BenchmarkId::new("Full_no_mirror", "batch64"), |b| {
            b.iter(|| raw.predict_batch(&batch, Detail::Full).expect("prediction"))
        });
        group.finish();
    }
}

fn bench_sequence(c: &mut Criterion) {
    for (device_name, device) in devices() {
        bench_sequence_on(c, device_name, device);
    }
}

fn bench_sequence_on(c: &mut Criterion, device_name: &str, device: &Device) {
    let mut group = c.benchmark_group(group_name("predict_sequence_120_frames", device_name));
    let motion = MotionGenerator::new(0, 120).generate();
    let denim = Material::preset("Denim Heavy").expect("preset");
    for resolution in [Resolution::Default, Resolution::Paper] {
        let (predictor, _) = predictor(resolution, Some(128), device);
        group.throughput(Throughput::Elements(motion.len() as u64));
        group.bench_function(
            BenchmarkId::new("Full", format!("{resolution}_rank128")),
            |b| {
                b.iter(|| {
                    predictor
                        .predict_sequence(&motion, &denim, Detail::Full)
                        .expect("prediction")
                })
            },
        );
    }
    group.finish();
}

fn bench_scene(c: &mut Criterion) {
    for (device_name, device) in devices() {
        bench_scene_on(c, device_name, device);
    }
}

fn bench_scene_on(c: &mut Criterion, device_name: &str, device: &Device) {
    let (shipped, _) = predictor(Resolution::Default, None, device);
    let mut group = c.benchmark_group(group_name("scene_100_characters", device_name));
    group.throughput(Throughput::Elements(1));
    // As shipped (each recomputed character pushed out of its posed body, as `predict`
    // does), and with push-out off, for applications that resolve contact themselves.
    let unpushed = {
        let (p, _) = predictor(Resolution::Default, None, device);
        p.with_push_out(PushOut {
            enabled: false,
            ..PushOut::default()
        })
        .expect("valid push-out")
    };
    for (name, predictor) in [
        ("10pct_changing_per_frame", &shipped),
        ("10pct_changing_per_frame_no_push_out", &unpushed),
    ] {
        let mut scene = Scene::new();
        for (id, (pose, material)) in inputs(100).iter().enumerate() {
            let mut character = Character::new(pose.clone(), material.to_normalized());
            character.detail = if id % 3 == 0 {
                Detail::Full
            } else {
                Detail::Smooth
            };
            scene.insert(id as u64, character).expect("valid character");
        }
        scene.update(predictor).expect("first frame");
        let limits = JointLimits::default();
        let mut rng = SplitMix64::new(4);
        group.bench_function(name, |b| {
            b.iter(|| {
                for _ in 0..10 {
                    let id = rng.below(100) as u64;
                    scene
                        .set_pose(id, limits.sample(&mut rng, 1.0))
                        .expect("known character");
                }
                scene.update(predictor).expect("frame")
            })
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().without_plots().sample_size(20).measurement_time(std::time::Duration::from_secs(4));
    targets = bench_predict, bench_scene, bench_sequence
}
criterion_main!(benches);
