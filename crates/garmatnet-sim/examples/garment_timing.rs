//! Run: `cargo run -p garmatnet-sim --release --example garment_timing -- [coarse|default|paper] [poses] [preset]`
//!
//! Times the T-shirt's cold drape on the rest body and a short warm-started pose sequence.
//! `FRICTION=mu` sets the friction coefficient (0: frictionless, the cloth not carried with
//! the body, as datasets made before friction). `SEED=s` picks the built-in motion's seed
//! (default 3; revision 2's walked datasets used 0) and `ARM_CLEARANCE=m` its arm–torso
//! clearance (0: the motion before the clearance existed). `MAX_SURFACE_STEP=m` walks in
//! steps that carry the cloth at most m metres (`SequenceSettings::max_surface_step`; 0, the
//! default, is off).
//! `STEP_EXPANSION=f` sets the line search's expansion (`DrapeSettings::step_expansion`; 1
//! is off), `INTERMEDIATE=k` the Newton iterations per intermediate step and
//! `CONTACT_HARDENING=m` the penalty's hardening length inside the body
//! (`DrapeSettings::contact_hardening`; 0 is off).

use std::time::Instant;

use garmatnet_core::{CapsuleBody, Garment, Material, Resolution};
use garmatnet_sim::{MotionGenerator, SequenceSettings, drape_sequence};

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let resolution: Resolution = args.next().unwrap_or("default".into()).parse()?;
    let frames: usize = args.next().unwrap_or("5".into()).parse()?;
    let preset = args.next().unwrap_or("Cotton Poplin".into());
    let body = CapsuleBody::smpl_neutral();
    let garment = Garment::tshirt(resolution, &body)?;
    let material = Material::preset(&preset)?;
    println!(
        "{} vertices, {} springs, {preset}",
        garment.vertex_count(),
        garment.springs.len()
    );
    let seed: u64 = std::env::var("SEED").map_or(Ok(3), |v| v.parse())?;
    let mut motion = MotionGenerator::new(seed, frames);
    if let Ok(v) = std::env::var("ARM_CLEARANCE") {
        motion.arm_clearance = v.parse()?;
    }
    let poses = motion.generate();
    let mut settings = SequenceSettings::default();
    if let Ok(v) = std::env::var("FRICTION") {
        settings.drape.friction = v.parse()?;
        settings.follow_body = settings.drape.friction > 0.0;
    }
    if let Ok(v) = std::env::var("MAX_SURFACE_STEP") {
        settings.max_surface_step = v.parse()?;
    }
    if let Ok(v) = std::env::var("CONTACT_HARDENING") {
        settings.drape.contact_hardening = v.parse()?;
    }
    if let Ok(v) = std::env::var("STEP_EXPANSION") {
        settings.drape.step_expansion = v.parse()?;
    }
    if let Ok(v) = std::env::var("INTERMEDIATE") {
        settings.intermediate_iterations = v.parse()?;
    }
    if let Ok(v) = std::env::var("KC_RATIO") {
        settings.drape.contact_stiffness_ratio = v.parse()?;
    }
    let start = Instant::now();
    let stats = drape_sequence(
        &garment,
        &body,
        &material,
        &poses,
        &settings,
        None,
        |i, _, s| {
            println!(
                "pose {i}: {:.0} ms, {} it, rms {:.1e}, max {:.1e}, pen {:.1e}, strain {:.3}, conv {}, expanded {}",
                s.wall_time_ms,
                s.iterations,
                s.final_residual,
                s.max_residual,
                s.max_penetration,
                s.max_strain,
                s.converged,
                s.expanded_steps
            );
            Ok(())
        },
    )?;
    let s = &stats[0];
    println!(
        "rest (cold): {:.0} ms, {} it, rms {:.1e}, max {:.1e}, pen {:.1e}, conv {}",
        s.wall_time_ms,
        s.iterations,
        s.final_residual,
        s.max_residual,
        s.max_penetration,
        s.converged
    );
    let total = start.elapsed().as_secs_f64() * 1e3;
    println!(
        "total {total:.0} ms; per sample after rest {:.0} ms",
        (total - s.wall_time_ms) / frames.max(1) as f64
    );
    Ok(())
}
