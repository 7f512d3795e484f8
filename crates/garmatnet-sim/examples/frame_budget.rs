//! Run: `cargo run -p garmatnet-sim --release --example frame_budget -- [coarse|default|paper] [frames] [preset] [gentle|brisk]`
//!
//! What a fixed Newton budget per frame buys an interactive application that has the
//! previous frame's drape. The reference is the walk a walked dataset makes (revision 2's,
//! or `simulate --protocol walk`; converged at every frame). For each frame f ≥ 1 the
//! converged drape of frame f − 1 is carried with the skin to frame f's body in one step (no
//! intermediate poses) and given a budget of Newton iterations; each row prints the time of
//! that step on one solver kept across frames and the mean, 95th-percentile and largest
//! per-vertex distance (mm) to the reference at frame f. `BUDGETS=4,8` picks the budgets
//! (default 0,1,2,4,8,16,300). `CHAIN=1` starts each frame from the previous frame's
//! budgeted result instead of its reference, as an application stepping on its own does.
//! `WALK=1` walks the intermediate poses instead (the walk's steps and their iterations)
//! before the budget. Motion seed 0 (revision 2's datasets').

use std::time::Instant;

use garmatnet_core::{CapsuleBody, Garment, Material, Pose, Resolution};
use garmatnet_sim::{
    DrapeSettings, FrameStepper, MotionGenerator, MotionPace, SequenceSettings, drape_poses,
    surface_steps,
};

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let resolution: Resolution = args.next().unwrap_or("default".into()).parse()?;
    let frames: usize = args.next().unwrap_or("6".into()).parse()?;
    let preset = args.next().unwrap_or("Cotton Poplin".into());
    let pace: MotionPace = args.next().unwrap_or("brisk".into()).parse()?;
    let walk = std::env::var("WALK").is_ok_and(|v| v == "1");
    let chain = std::env::var("CHAIN").is_ok_and(|v| v == "1");
    let body = CapsuleBody::smpl_neutral();
    let garment = Garment::tshirt(resolution, &body)?;
    let material = Material::preset(&preset)?;
    let poses = MotionGenerator::with_pace(0, frames, pace).generate();
    let settings = SequenceSettings::default();
    let t = Instant::now();
    let reference = drape_poses(&garment, &body, &material, &poses, &settings)?;
    println!(
        "{} vertices, {preset}, {pace:?}; reference walk {:.1} s",
        garment.vertex_count(),
        t.elapsed().as_secs_f64()
    );
    let quick = DrapeSettings {
        max_iterations: settings.intermediate_iterations,
        ..settings.drape.clone()
    };
    let mut stepper = FrameStepper::new(
        &garment,
        &body,
        &material,
        &settings.drape,
        &poses[0],
        reference[0].clone(),
    )?;
    let budgets: Vec<usize> = match std::env::var("BUDGETS") {
        Ok(v) => v.split(',').map(str::parse).collect::<Result<_, _>>()?,
        Err(_) => vec![0, 1, 2, 4, 8, 16, 300],
    };
    for budget in budgets {
        let full = DrapeSettings {
            max_iterations: budget.max(1),
            ..settings.drape.clone()
        };
        let mut times = Vec::new();
        let mut errors = Vec::new();
        let mut worst_pen: f64 = 0.0;
        stepper.restart(&poses[0], &reference[0])?;
        for f in 1..frames {
            if !chain {
                stepper.restart(&poses[f - 1], &reference[f - 1])?;
            }
            let start = Instant::now();
            let steps: Vec<Pose> = if walk {
                let from = stepper.positions();
                surface_steps(
                    &body,
                    &poses[f - 1],
                    &poses[f],
                    from,
                    settings.max_step_rad,
                    0.0,
                )?
            } else {
                vec![poses[f].clone()]
            };
            let (last, between) = steps.split_last().expect("the walk ends at frame f");
            stepper.set_settings(&quick)?;
            for pose in between {
                stepper.step(pose)?;
            }
            if budget == 0 {
                // Carried with the skin only: the step's solve is skipped.
                let mut x = stepper.positions().to_vec();
                stepper.posed_body().carry_to(&body.pose(last), &mut x);
                stepper.restart(last, &x)?;
            } else {
                stepper.set_settings(&full)?;
                let s = stepper.step(last)?;
                worst_pen = worst_pen.max(s.max_penetration);
            }
            let x = stepper.positions();
            times.push(start.elapsed().as_secs_f64() * 1e3);
            let mut d: Vec<f64> = x
                .iter()
                .zip(&reference[f])
                .map(|(a, b)| (a - b).norm() * 1e3)
                .collect();
            d.sort_by(f64::total_cmp);
            let mean = d.iter().sum::<f64>() / d.len() as f64;
            errors.push((mean, d[d.len() * 95 / 100], d[d.len() - 1]));
        }
        let n = times.len() as f64;
        println!(
            "budget {budget}: {:.0} ms/frame (max {:.0}), error mean {:.2} mm, p95 {:.2}, max {:.2} (worst frame mean {:.2}), penetration {:.1e} m",
            times.iter().sum::<f64>() / n,
            times.iter().copied().fold(0.0, f64::max),
            errors.iter().map(|e| e.0).sum::<f64>() / n,
            errors.iter().map(|e| e.1).sum::<f64>() / n,
            errors.iter().map(|e| e.2).fold(0.0, f64::max),
            errors.iter().map(|e| e.0).fold(0.0, f64::max),
            worst_pen,
        );
    }
    Ok(())
}
