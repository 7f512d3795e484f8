//! A tiny synthetic dataset for this crate's tests: no solver, garments that depend smoothly
//! on material and pose plus small wrinkles, smoothed with the real Laplacian smoother.

use std::path::Path;

use garmatnet_core::{
    CapsuleBody, Garment, JointLimits, LaplacianSmoother, Resolution, SkinnedBody,
    SmoothingSettings, SplitMix64, TemplateInfo,
};
use garmatnet_sim::{
    BodyInfo, DatasetSpec, DatasetWriter, MaterialEntry, SampleArrays, SampleStats, SmoothingInfo,
};

/// Burn's random state (weight init, dropout) is global to the process, so tests that train,
/// or run an untrained net (its weights are drawn at first use), hold this lock: otherwise
/// parallel tests reseed or draw from it under each other and runs that must repeat bit for
/// bit do not.
pub(crate) fn training_lock() -> std::sync::MutexGuard<'static, ()> {
    static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
    LOCK.lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// The custom target materials of the test datasets.
pub(crate) const TARGETS: [&str; 2] = ["Target A", "Target B"];

/// Writes a dataset of `materials` (the first two named [`TARGETS`]) × `poses` poses (frames
/// 0, 1, 2, …: every 10th held out) on the coarse T-shirt into `dir`.
pub(crate) fn synthetic_dataset(dir: &Path, materials: usize, poses: usize) {
    synthetic_dataset_with_plan(dir, materials, poses, garmatnet_sim::SamplePlan::Full);
}

/// [`synthetic_dataset`] holding only the samples `plan` holds (a strided plan needs the
/// canonical protocol, which the manifest then records).
pub(crate) fn synthetic_dataset_with_plan(
    dir: &Path,
    materials: usize,
    poses: usize,
    plan: garmatnet_sim::SamplePlan,
) {
    let body = CapsuleBody::smpl_neutral();
    let garment = Garment::tshirt(Resolution::Coarse, &body).unwrap();
    let smoother = LaplacianSmoother::new(&garment.rest, SmoothingSettings::default()).unwrap();
    let mut rng = SplitMix64::new(5);
    let limits = JointLimits::default();
    let pose_list: Vec<_> = (0..poses).map(|_| limits.sample(&mut rng, 0.3)).collect();
    let material_list: Vec<MaterialEntry> = (0..materials)
        .map(|i| {
            let omega_normalized: [f64; 6] = std::array::from_fn(|_| rng.next_f64());
            MaterialEntry {
                name: if i < TARGETS.len() {
                    TARGETS[i].to_owned()
                } else {
                    format!("Fabric {i}")
                },
                omega: garmatnet_core::Material::from_normalized(omega_normalized)
                    .unwrap()
                    .as_array(),
                omega_normalized,
            }
        })
        .collect();
    let spec = DatasetSpec {
        template: TemplateInfo::of(&garment),
        body: BodyInfo {
            name: "capsule-smpl-neutral".into(),
        },
        materials: material_list.clone(),
        poses: pose_list.clone(),
        frames: (0..poses).collect(),
        solver: serde_json::json!({ "synthetic": true }),
        smoothing: SmoothingInfo {
            lambda: 0.15,
            iterations: 80,
            weights: "uniform".into(),
        },
        ground_truth_revision: Some(garmatnet_sim::GROUND_TRUTH_REVISION),
        protocol: if plan.is_full() {
            garmatnet_sim::DrapeProtocol::default()
        } else {
            garmatnet_sim::DrapeProtocol::Canonical
        },
        plan,
    };
    let writer = DatasetWriter::open(dir, spec).unwrap();
    let skeleton = body.skeleton();
    for (m, material) in material_list.iter().enumerate() {
        let w = material.omega_normalized;
        for (p, pose) in pose_list.iter().enumerate() {
            if !plan.includes(m, p) {
                continue;
            }
            let t = skeleton.skinning_transforms(pose);
            let theta = pose.to_vec();
            let simulated: Vec<_> = garment
                .posed_rest_guess(&t)
                .iter()
                .zip(&garment.rest.vertices)
                .map(|(g, r)| {
                    let offset = garmatnet_core::Vec3::new(
                        0.01 * w[0] * (4.0 * r.y).sin() + 0.02 * theta[50],
                        0.01 * w[1] * (3.0 * r.x).cos() - 0.01 * w[5],
                        0.008 * w[2] + 0.02 * theta[5] * r.y,
                    );
                    let wrinkle = 0.002 * (40.0 * r.x + 10.0 * w[3]).sin() * (30.0 * r.y).cos();
                    g + offset + garmatnet_core::Vec3::new(0.0, 0.0, wrinkle)
                })
                .collect();
            let smoothed = smoother.smooth(&simulated).unwrap();
            let f32s = |v: &[garmatnet_core::Vec3]| -> Vec<[f32; 3]> {
                v.iter()
                    .map(|p| [p.x as f32, p.y as f32, p.z as f32])
                    .collect()
            };
            let arrays = SampleArrays {
                simulated: f32s(&simulated),
                smoothed: f32s(&smoothed),
                body: f32s(&garment.body_points(&t)),
            };
            let stats = SampleStats {
                iterations: 1,
                residual: 0.0,
                max_penetration_m: 0.0,
                max_depth_before_projection_m: Some(0.0),
                max_strain: 0.0,
                wall_time_ms: 0.0,
                converged: true,
            };
            writer.write_sample(m, p, &arrays, stats).unwrap();
        }
    }
    writer.flush().unwrap();
}
