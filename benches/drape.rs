//! Run: `cargo bench --bench drape`
//!
//! Ground-truth solver speed, one thread: a warm-started pose (the previous frame's drape,
//! then the walk to the next frame of the built-in motion and a full converge, as walked
//! datasets, revision 2's among them, were made) at the default and paper resolutions, and a
//! cold drape from the rest template. The material is Cotton Poplin; settings are the walk's
//! defaults ([`SequenceSettings::default`]); the garment is the default fitted shirt (the
//! book's figures were measured on the boxy one). The motion is the gentle pace (frame 10 to
//! 11), so the figures stay comparable with earlier runs; the default brisk pace walks about
//! 5x farther between frames (book/src/performance.md: 1.85x per sample).
//! Beside them, the interactive frame: the same pose change stepped as an application would
//! step it ([`FrameStepper`]: the drape carried with the skin in one step, then at most 8
//! Newton iterations, on a solver made once).

use criterion::{BatchSize, BenchmarkId, Criterion, criterion_group, criterion_main};
use garmatnet::core::{CapsuleBody, Garment, Material, Pose, Resolution};
use garmatnet::sim::{
    DrapeSettings, FrameStepper, MotionGenerator, MotionPace, SequenceResume, SequenceSettings,
    drape_poses, drape_sequence,
};

fn bench_drape(c: &mut Criterion) {
    let body = CapsuleBody::smpl_neutral();
    let material = Material::preset("Cotton Poplin").expect("preset");
    let settings = SequenceSettings::default();
    let poses = MotionGenerator::with_pace(0, 12, MotionPace::Gentle).generate();
    let mut group = c.benchmark_group("drape_one_thread");
    for resolution in [Resolution::Default, Resolution::Paper] {
        let garment = Garment::tshirt(resolution, &body).expect("template");
        // Drape frames 0..10 once; each iteration then re-drapes frame 11 from frame 10.
        let warm = drape_poses(&garment, &body, &material, &poses[..11], &settings)
            .expect("warm-up sequence")
            .pop()
            .expect("frame 10");
        group.bench_function(BenchmarkId::new("warm_started_pose", resolution), |b| {
            b.iter(|| {
                let resume = SequenceResume {
                    next: 11,
                    positions: warm.clone(),
                };
                drape_sequence(
                    &garment,
                    &body,
                    &material,
                    &poses,
                    &settings,
                    Some(resume),
                    |_, _, _| Ok(()),
                )
                .expect("drape")
            })
        });
        let budget = DrapeSettings {
            max_iterations: 8,
            ..settings.drape.clone()
        };
        let stepper = FrameStepper::new(
            &garment,
            &body,
            &material,
            &budget,
            &poses[10],
            warm.clone(),
        )
        .expect("stepper");
        group.bench_function(
            BenchmarkId::new("interactive_frame_8_iterations", resolution),
            |b| {
                b.iter_batched(
                    || stepper.clone(),
                    |mut s| s.step(&poses[11]).expect("step"),
                    BatchSize::LargeInput,
                )
            },
        );
        group.bench_function(BenchmarkId::new("cold_from_rest", resolution), |b| {
            b.iter(|| {
                drape_sequence(
                    &garment,
                    &body,
                    &material,
                    &[Pose::zero()],
                    &settings,
                    None,
                    |_, _, _| Ok(()),
                )
                .expect("drape")
            })
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().without_plots().sample_size(10).measurement_time(std::time::Duration::from_secs(20));
    targets = bench_drape
}
criterion_main!(benches);
