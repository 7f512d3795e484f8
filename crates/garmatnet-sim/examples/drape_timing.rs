//! Run: `cargo run -p garmatnet-sim --release --example drape_timing`
//!
//! Times cold and warm-started drapes of ~2,500 and ~4,300-vertex sheets on a sphere.

use garmatnet_core::{Real, Sphere, SplitMix64, Vec3};
use garmatnet_sim::{DrapeSettings, DrapeSolver, SheetStiffness, grid_sheet};

fn main() -> anyhow::Result<()> {
    let stiffness = SheetStiffness {
        structural_warp: 300.0,
        structural_weft: 250.0,
        shear: 30.0,
        flexion_warp: 2.0,
        flexion_weft: 2.0,
    };
    let settings = DrapeSettings::default();
    for columns in [50, 66] {
        let spacing = 0.01;
        let model = grid_sheet(columns, columns, spacing, 0.15, stiffness)?;
        let sphere = Sphere {
            centre: Vec3::zeros(),
            radius: 0.2,
        };
        let mut x: Vec<Vec3> = model
            .rest_positions()
            .iter()
            .map(|p| p + Vec3::new(0.0, 0.21, 0.0))
            .collect();
        let mut solver = DrapeSolver::new(&model, &settings)?;
        let cold = solver.drape(&mut x, &sphere, &[])?;
        println!(
            "{} vertices, {} springs",
            model.vertex_count(),
            model.springs().len()
        );
        println!("  cold: {cold:?}");
        let mut rng = SplitMix64::new(7);
        for p in &mut x {
            *p += Vec3::new(
                rng.uniform(-0.002, 0.002),
                rng.uniform(-0.002, 0.002),
                rng.uniform(-0.002, 0.002),
            );
        }
        let warm = solver.drape(&mut x, &sphere, &[])?;
        println!("  warm (2 mm perturbation): {warm:?}");
        let moved = Sphere {
            centre: Vec3::new(0.01, 0.0, 0.0),
            radius: 0.2,
        };
        let warm_moved = solver.drape(&mut x, &moved, &[])?;
        println!("  warm (body moved 1 cm): {warm_moved:?}");
        let _: Real = warm_moved.wall_time_ms;
    }
    Ok(())
}
