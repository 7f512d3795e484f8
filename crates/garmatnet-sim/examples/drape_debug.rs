//! Run: `cargo run -p garmatnet-sim --release --example drape_debug -- '<settings json>' columns`
use garmatnet_core::{Sphere, Vec3};
use garmatnet_sim::{DrapeSettings, DrapeSolver, SheetStiffness, grid_sheet};
fn main() -> anyhow::Result<()> {
    let k = SheetStiffness {
        structural_warp: 300.0,
        structural_weft: 250.0,
        shear: 30.0,
        flexion_warp: 2.0,
        flexion_weft: 2.0,
    };
    let args: Vec<String> = std::env::args().collect();
    let base: DrapeSettings = serde_json::from_str(&args[1])?;
    let columns: usize = args[2].parse()?;
    let model = grid_sheet(columns, columns, 0.02, 0.15, k)?;
    let radius: f64 = args[3].parse()?;
    let sphere = Sphere {
        centre: Vec3::zeros(),
        radius,
    };
    let mut x: Vec<Vec3> = model
        .rest_positions()
        .iter()
        .map(|p| p + Vec3::new(0.0, radius + 0.005, 0.0))
        .collect();
    eprintln!("{base:?}");
    let mut solver = DrapeSolver::new(&model, &base)?;
    for chunk in 0..30 {
        let s = DrapeSettings {
            max_iterations: 100,
            ..base.clone()
        };
        solver.set_settings(&s)?;
        let st = solver.drape(&mut x, &sphere, &[])?;
        println!(
            "{chunk}: res {:.3e} max {:.3e} contacts {} cf {:.4} refac {} corner y {:.4}",
            st.final_residual,
            st.max_residual,
            st.contacts,
            st.contact_force.y,
            st.refactorizations,
            x[0].y
        );
        if st.converged {
            break;
        }
    }
    println!("weight {}", model.total_mass() * 9.81);
    Ok(())
}
