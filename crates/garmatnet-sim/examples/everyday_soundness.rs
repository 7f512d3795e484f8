//! Run: `cargo run -p garmatnet-sim --release --example everyday_soundness -- [coarse|default|paper]`
//!
//! Every preset's fitted T-shirt draped by the canonical protocol (revision 4) at every pose
//! of the everyday suite: one row per (pose, preset) with the largest structural or shear
//! stretch (sound drapes stay below `SOUND_STRETCH`, 1.2), the deepest penetration left
//! (mm), whether any coordinate is NaN, whether the solve converged and in how many Newton
//! iterations, the mirror asymmetry on symmetric poses (mm) and the solver time; then one
//! summary line per pose. `PRESETS=Denim,Spandex` and `POSES=arms-at-sides,sitting` limit the
//! presets and poses (substring match, case-insensitive); `THREADS` sets rayon's pool;
//! `SAMPLED=N` drapes the first N independent poses of seed 0 instead;
//! `SOLVER=settings.json` drapes with other `SequenceSettings` (missing fields: defaults);
//! `RENDER=DIR` writes a front and a side view of each drape on its body to `DIR`, the
//! garment coloured by each vertex's largest spring stretch (red at `SOUND_STRETCH`).

use std::time::Instant;

use garmatnet_core::{CapsuleBody, Garment, Real, Resolution, presets};
use garmatnet_sim::{
    CanonicalDraper, EverydayPose, MirrorMap, SOUND_STRETCH, canonical_settings, everyday_poses,
};
use rayon::prelude::*;

#[path = "common/views.rs"]
mod views;

/// The comma-separated, lower-cased filter in environment variable `name` (empty: all).
fn filter(name: &str) -> Vec<String> {
    std::env::var(name)
        .map(|s| s.split(',').map(|f| f.trim().to_lowercase()).collect())
        .unwrap_or_default()
}

fn keep(filter: &[String], name: &str) -> bool {
    let lower = name.to_lowercase();
    filter.is_empty() || filter.iter().any(|f| lower.contains(f.as_str()))
}

/// One drape's row.
struct Row {
    pose: &'static str,
    preset: &'static str,
    stretch: Real,
    penetration: Real,
    nan: bool,
    converged: bool,
    iterations: usize,
    asymmetry: Option<Real>,
    seconds: f64,
}

/// Writes `DIR/POSE_PRESET_{front,side}.png`: the drape `x` on the posed body, coloured by
/// each vertex's largest spring stretch.
fn render_drape(
    dir: &std::path::Path,
    garment: &Garment,
    body: &CapsuleBody,
    pose: &garmatnet_sim::EverydayPose,
    preset: &str,
    x: &[garmatnet_core::Vec3],
) -> anyhow::Result<()> {
    use garmatnet_core::render::{Shading, heat_colors};
    std::fs::create_dir_all(dir)?;
    let mut stretch = vec![0.0; x.len()];
    for s in &garment.springs {
        let e = (x[s.a as usize] - x[s.b as usize]).norm() / s.rest_length - 1.0;
        for v in [s.a as usize, s.b as usize] {
            stretch[v] = Real::max(stretch[v], e);
        }
    }
    let colors = heat_colors(&stretch, SOUND_STRETCH);
    let mesh = garmatnet_core::TriMesh::new(x.to_vec(), garment.rest.faces.clone())?;
    let body_mesh = body.pose(&pose.pose).mesh();
    let tag = format!("{}_{}", pose.name, preset.to_lowercase().replace(' ', "_"));
    views::save_front_and_side(
        &dir.join(tag),
        &body_mesh,
        &mesh,
        Shading::PerVertex(&colors),
        0.15,
    )?;
    Ok(())
}

fn main() -> anyhow::Result<()> {
    let resolution: Resolution = std::env::args()
        .nth(1)
        .unwrap_or_else(|| "coarse".into())
        .parse()?;
    if let Ok(threads) = std::env::var("THREADS") {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads.parse()?)
            .build_global()?;
    }
    let (preset_filter, pose_filter) = (filter("PRESETS"), filter("POSES"));
    let body = CapsuleBody::smpl_neutral();
    let garment = Garment::tshirt(resolution, &body)?;
    let mirror = MirrorMap::of_garment(&garment)?;
    let poses: Vec<EverydayPose> = match std::env::var("SAMPLED") {
        // SAMPLED=N: the first N independent poses of seed 0 (as `simulate --poses N`
        // draws them) instead of the everyday suite.
        Ok(n) => {
            let sampler = garmatnet_sim::PoseSampler::new(Default::default())?;
            (0..n.parse::<u64>()?)
                .map(|i| {
                    Ok(EverydayPose {
                        name: Box::leak(format!("sampled-{i}").into_boxed_str()),
                        pose: sampler.pose(i)?,
                        symmetric: false,
                    })
                })
                .filter(|p: &anyhow::Result<EverydayPose>| {
                    p.as_ref().map_or(true, |p| keep(&pose_filter, p.name))
                })
                .collect::<anyhow::Result<_>>()?
        }
        Err(_) => everyday_poses()
            .into_iter()
            .filter(|p| keep(&pose_filter, p.name))
            .collect(),
    };
    let chosen: Vec<_> = presets()
        .iter()
        .filter(|p| keep(&preset_filter, p.name))
        .collect();
    println!(
        "{} vertices, {} poses x {} presets, canonical protocol",
        garment.vertex_count(),
        poses.len(),
        chosen.len()
    );
    let settings = match std::env::var("SOLVER") {
        Ok(path) => serde_json::from_str(&std::fs::read_to_string(path)?)?,
        Err(_) => canonical_settings(),
    };
    let rows: Vec<Row> = chosen
        .par_iter()
        .map(|preset| -> anyhow::Result<Vec<Row>> {
            let draper = CanonicalDraper::new(&garment, &body, &preset.material, &settings)?;
            poses
                .iter()
                .map(|p| {
                    let t = Instant::now();
                    let (x, stats) = draper.drape(&p.pose)?;
                    if let Ok(dir) = std::env::var("RENDER") {
                        render_drape(
                            std::path::Path::new(&dir),
                            &garment,
                            &body,
                            p,
                            preset.name,
                            &x,
                        )?;
                    }
                    Ok(Row {
                        pose: p.name,
                        preset: preset.name,
                        stretch: stats.max_strain,
                        penetration: stats.max_penetration,
                        nan: x.iter().any(|v| !v.iter().all(|c| c.is_finite())),
                        converged: stats.converged,
                        iterations: stats.iterations,
                        asymmetry: if p.symmetric {
                            Some(mirror.asymmetry(&x)?)
                        } else {
                            None
                        },
                        seconds: t.elapsed().as_secs_f64(),
                    })
                })
                .collect()
        })
        .collect::<anyhow::Result<Vec<_>>>()?
        .into_iter()
        .flatten()
        .collect();
    println!(
        "| pose | preset | max stretch | penetration (mm) | NaN | converged | iterations | mirror asym. (mm) | time (s) |"
    );
    println!("|---|---|---:|---:|---|---|---:|---:|---:|");
    for r in &rows {
        println!(
            "| {} | {} | {:.3} | {:.2} | {} | {} | {} | {} | {:.1} |",
            r.pose,
            r.preset,
            r.stretch,
            r.penetration * 1e3,
            if r.nan { "yes" } else { "no" },
            r.converged,
            r.iterations,
            r.asymmetry
                .map_or("-".into(), |a| format!("{:.1}", a * 1e3)),
            r.seconds
        );
    }
    println!(
        "\n| pose | presets | past {SOUND_STRETCH} | worst stretch | worst penetration (mm) | NaN | not converged | worst asym. (mm) | mean time (s) |"
    );
    println!("|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for p in &poses {
        let of: Vec<&Row> = rows.iter().filter(|r| r.pose == p.name).collect();
        let worst = |f: &dyn Fn(&Row) -> Real| of.iter().map(|r| f(r)).fold(0.0, Real::max);
        println!(
            "| {} | {} | {} | {:.3} | {:.2} | {} | {} | {} | {:.1} |",
            p.name,
            of.len(),
            of.iter().filter(|r| r.stretch > SOUND_STRETCH).count(),
            worst(&|r| r.stretch),
            worst(&|r| r.penetration) * 1e3,
            of.iter().filter(|r| r.nan).count(),
            of.iter().filter(|r| !r.converged).count(),
            if p.symmetric {
                format!("{:.1}", worst(&|r| r.asymmetry.unwrap_or(0.0)) * 1e3)
            } else {
                "-".into()
            },
            of.iter().map(|r| r.seconds).sum::<f64>() / of.len().max(1) as f64
        );
    }
    Ok(())
}
