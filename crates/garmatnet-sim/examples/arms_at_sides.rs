//! Run: `cargo run -p garmatnet-sim --release --example arms_at_sides -- [coarse|default|paper] [angle_rad] [steps]`
//!
//! The pinch: every preset's T-shirt draped from the rest pose (T-pose) to the arms hanging
//! at the sides (both shoulders rotated about the forward axis by `angle_rad`, default 1.35),
//! walked through `steps` (default 3) equal poses with [`drape_sequence`]'s default settings.
//! One row per preset: the largest stretch of a structural or shear spring over every pose of
//! the walk (length over rest length, minus one; sound drapes stay below 1.2), the deepest
//! penetration left after the final projection and the deepest before it (mm), whether any
//! coordinate is NaN, whether the last pose converged, its Newton iterations, the mirror
//! asymmetry of the last pose (mm; [`garmatnet_sim::MirrorMap::asymmetry`], twins paired within a third of the grid spacing)
//! and the solver time. `PRESETS=Denim,Spandex` limits the presets (substring match);
//! `FUSED=1` drapes on the body as one smooth union of every capsule (no limb roots).

use std::time::Instant;

use garmatnet_core::{
    CapsuleBody, Garment, Pose, Real, Resolution, SpringKind, Vec3, joint_index, presets,
};
use garmatnet_sim::{MirrorMap, SequenceSettings, drape_sequence};

/// The largest stretch `|x_a - x_b| / L - 1` of a structural or shear spring.
fn max_stretch(garment: &Garment, x: &[Vec3]) -> Real {
    garment
        .springs
        .iter()
        .filter(|s| {
            !matches!(
                s.kind,
                SpringKind::FlexionVertical | SpringKind::FlexionHorizontal
            )
        })
        .map(|s| (x[s.a as usize] - x[s.b as usize]).norm() / s.rest_length - 1.0)
        .fold(Real::NEG_INFINITY, Real::max)
}

/// Both arms lowered by `angle` radians about the forward axis (left arm, along +x at rest,
/// turns toward -y).
fn arms_lowered(angle: Real) -> Pose {
    let mut pose = Pose::zero();
    let left = joint_index("left_shoulder").unwrap_or_else(|| unreachable!());
    let right = joint_index("right_shoulder").unwrap_or_else(|| unreachable!());
    pose.set_joint(left, Vec3::new(0.0, 0.0, -angle));
    pose.set_joint(right, Vec3::new(0.0, 0.0, angle));
    pose
}

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let resolution: Resolution = args.next().unwrap_or("coarse".into()).parse()?;
    let angle: Real = args.next().unwrap_or("1.35".into()).parse()?;
    let steps: usize = args.next().unwrap_or("3".into()).parse()?;
    let filter: Vec<String> = std::env::var("PRESETS")
        .map(|s| s.split(',').map(str::to_lowercase).collect())
        .unwrap_or_default();
    // FUSED=1: the body as one smooth union of every capsule (no limb roots), as before
    // arms were kept apart from the trunk.
    let body = if std::env::var("FUSED").is_ok_and(|v| v == "1") {
        let skeleton = garmatnet_core::Skeleton::smpl_neutral();
        let capsules = garmatnet_core::smpl_neutral_capsules(&skeleton);
        CapsuleBody::with_limb_roots(
            skeleton,
            capsules,
            garmatnet_core::DEFAULT_BLEND_RADIUS,
            &[],
        )?
    } else {
        CapsuleBody::smpl_neutral()
    };
    let garment = Garment::tshirt(resolution, &body)?;
    let poses: Vec<Pose> = (1..=steps)
        .map(|k| arms_lowered(angle * k as Real / steps as Real))
        .collect();
    println!(
        "{} vertices; shoulders ±{angle} rad in {steps} poses",
        garment.vertex_count()
    );
    // The template's left and right halves differ by the skeleton's asymmetry (millimetres),
    // so its twins are paired within a third of the grid spacing.
    let mirror =
        MirrorMap::with_tolerance(&garment.rest.vertices, resolution.grid_spacing() / 3.0).ok();
    if let Some(m) = &mirror {
        println!(
            "rest template's own mirror asymmetry: {:.2} mm",
            m.asymmetry(&garment.rest.vertices)? * 1e3
        );
    }
    println!(
        "| preset | max stretch | penetration (mm) | depth before projection (mm) | NaN | converged | iterations | mirror asym. (mm) | time (s) |"
    );
    println!("|---|---:|---:|---:|---|---|---:|---:|---:|");
    let settings = SequenceSettings::default();
    for preset in presets() {
        let lower = preset.name.to_lowercase();
        if !filter.is_empty() && !filter.iter().any(|f| lower.contains(f.as_str())) {
            continue;
        }
        let t = Instant::now();
        let mut stretch: Real = Real::NEG_INFINITY;
        let mut nan = false;
        let mut last = Vec::new();
        let result = drape_sequence(
            &garment,
            &body,
            &preset.material,
            &poses,
            &settings,
            None,
            |_, x, _| {
                stretch = stretch.max(max_stretch(&garment, x));
                nan |= x.iter().any(|p| !p.iter().all(|c| c.is_finite()));
                last = x.to_vec();
                Ok(())
            },
        );
        let seconds = t.elapsed().as_secs_f64();
        match result {
            Ok(stats) => {
                let s = stats.last().unwrap_or_else(|| unreachable!());
                let penetration = stats[1..]
                    .iter()
                    .map(|s| s.max_penetration)
                    .fold(0.0, Real::max);
                let depth = stats[1..]
                    .iter()
                    .map(|s| s.max_depth_before_projection)
                    .fold(0.0, Real::max);
                let asymmetry = mirror.as_ref().map_or(Ok("n/a".to_string()), |m| {
                    m.asymmetry(&last).map(|a| format!("{:.1}", a * 1e3))
                })?;
                println!(
                    "| {} | {stretch:.3} | {:.2} | {:.2} | {} | {} | {} | {asymmetry} | {seconds:.1} |",
                    preset.name,
                    penetration * 1e3,
                    depth * 1e3,
                    if nan { "yes" } else { "no" },
                    s.converged,
                    s.iterations,
                );
            }
            Err(e) => println!(
                "| {} | failed: {e} | | | | | | | {seconds:.1} |",
                preset.name
            ),
        }
    }
    Ok(())
}
