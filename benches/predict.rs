//! Run: `cargo bench --bench predict` (add `--features wgpu` to include the GPU when present)
//!
//! Prediction speed of the full pipeline (body skinning + nets + assembly + push-out) at
//! batch 1 and 64, `Detail::Full` and `Detail::Smooth`, default and paper resolutions, with
//! the paper-sized nets (hidden 512/64/512), full-width and with a rank-128 output head; a 100-character `Scene` with mixed detail
//! where 10 % of the characters change each frame; and 120 frames of the built-in motion in
//! one `predict_sequence` call (batched nets, each frame pushed out of its posed body), as
//! `garmatnet drape --frames` predicts them. Weights are untrained: speed does not depend on
//! their values.

use burn::prelude::Device;
use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use garmatnet::core::{
    CapsuleBody, Garment, JointLimits, Material, Pose, Resolution, SplitMix64, presets,
};
use garmatnet::model::{
    Character, Detail, GarMatNetConfig, GarMatNetModel, Predictor, Scene, TemplateInfo,
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

fn bench_predict(c: &mut Criterion) {
    let device = Device::flex();
    for (resolution, rank) in [
        (Resolution::Default, None),
        (Resolution::Paper, None),
        (Resolution::Default, Some(128)),
        (Resolution::Paper, Some(128)),
    ] {
        let (predictor, mb) = predictor(resolution, rank, &device);
        let name = match rank {
            Some(k) => format!("{resolution}_rank{k}"),
            None => resolution.to_string(),
        };
        eprintln!(
            "{name}: {} vertices, model {mb:.1} MB (f32)",
            predictor.vertex_count()
        );
        let mut group = c.benchmark_group(format!("predict_cpu_{name}"));
        let one = inputs(1);
        let batch: Vec<_> = inputs(64)
            .into_iter()
            .map(|(p, m)| (p, m.to_normalized()))
            .collect();
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
        }
        group.finish();
    }
}

fn bench_sequence(c: &mut Criterion) {
    let device = Device::flex();
    let mut group = c.benchmark_group("predict_sequence_120_frames");
    let motion = MotionGenerator::new(0, 120).generate();
    let denim = Material::preset("Denim Heavy").expect("preset");
    for resolution in [Resolution::Default, Resolution::Paper] {
        let (predictor, _) = predictor(resolution, Some(128), &device);
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
    let device = Device::flex();
    let (predictor, _) = predictor(Resolution::Default, None, &device);
    let mut scene = Scene::new();
    let start = inputs(100);
    for (id, (pose, material)) in start.iter().enumerate() {
        let detail = if id % 3 == 0 {
            Detail::Full
        } else {
            Detail::Smooth
        };
        let mut character = Character::new(pose.clone(), material.to_normalized());
        character.detail = detail;
        scene.insert(id as u64, character).expect("valid character");
    }
    scene.update(&predictor).expect("first frame");
    let limits = JointLimits::default();
    let mut rng = SplitMix64::new(4);
    let mut group = c.benchmark_group("scene_100_characters");
    group.throughput(Throughput::Elements(1));
    group.bench_function("10pct_changing_per_frame", |b| {
        b.iter(|| {
            for _ in 0..10 {
                let id = rng.below(100) as u64;
                scene
                    .set_pose(id, limits.sample(&mut rng, 1.0))
                    .expect("known character");
            }
            scene.update(&predictor).expect("frame")
        })
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().without_plots().sample_size(20).measurement_time(std::time::Duration::from_secs(4));
    targets = bench_predict, bench_scene, bench_sequence
}
criterion_main!(benches);
