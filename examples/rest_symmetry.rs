//! Run: `cargo run --release --example rest_symmetry [-- --materials A,B] [--resolution R]`
//!
//! Whether every fabric's rest drape, the start of every revision-3 sample, is left-right
//! symmetric, as its rest pose (the A-pose) is. For each preset (at `--resolution`: coarse,
//! default, which is the default, or paper) it settles the garment once from its rest mesh
//! ([`settle_at_rest`], the first solve) and prints whether that converged and its mirror
//! asymmetry (mm), then the rest drape every sample and walk starts from
//! ([`CanonicalDraper::new`], [`garmatnet::sim::settle_rest_drape`]: a first solve that does
//! not converge is restarted from its mirror average) with its Newton iterations and
//! asymmetry.

use anyhow::Result;
use clap::Parser;
use garmatnet::core::{CapsuleBody, Garment, Material, Resolution, preset_names};
use garmatnet::sim::{
    CanonicalDraper, DrapeSolver, MirrorMap, canonical_settings, cloth_from_garment, settle_at_rest,
};

/// Command-line arguments.
#[derive(Debug, Parser)]
struct Args {
    /// Preset fabrics, comma-separated (default: every preset).
    #[arg(long, value_delimiter = ',')]
    materials: Vec<String>,
    /// Template resolution: coarse, default or paper.
    #[arg(long, default_value = "default")]
    resolution: Resolution,
}

fn main() -> Result<()> {
    let args = Args::parse();
    let body = CapsuleBody::smpl_neutral();
    let garment = Garment::tshirt(args.resolution, &body)?;
    let map = MirrorMap::of_garment(&garment)?;
    let settings = canonical_settings();
    let names: Vec<String> = if args.materials.is_empty() {
        preset_names().map(str::to_owned).collect()
    } else {
        args.materials
    };
    println!(
        "fabric | first solve: converged, iterations, asymmetry (mm) | kept: converged, iterations, asymmetry (mm)"
    );
    for name in &names {
        let fabric = Material::preset(name)?;
        let mut solver =
            DrapeSolver::new(&cloth_from_garment(&garment, &fabric)?, &settings.drape)?;
        let mut first = garment.rest.vertices.clone();
        let stats = settle_at_rest(
            &mut solver,
            &settings.drape,
            &mut first,
            &body,
            &garment.rest_pose,
        )?;
        let draper = CanonicalDraper::new(&garment, &body, &fabric, &settings)?;
        let kept = draper.rest_stats();
        println!(
            "{name} | {}, {}, {:.2} | {}, {}, {:.2}",
            stats.converged,
            stats.iterations,
            map.asymmetry(&first)? * 1e3,
            kept.converged,
            kept.iterations,
            map.asymmetry(draper.rest_drape())? * 1e3,
        );
    }
    Ok(())
}
