//! throwaway: where a stored drape is over-stretched.
use garmatnet_core::{CapsuleBody, Garment, Resolution, SignedDistance, SpringKind};
use garmatnet_sim::MotionGenerator;
use garmatnet_sim::sample_arrays::read_points_npy;
use std::path::Path;

fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let body = CapsuleBody::smpl_neutral();
    let garment = Garment::tshirt(Resolution::Default, &body)?;
    let poses = MotionGenerator::new(0, 200).generate();
    for stem in &a[1..] {
        let x = read_points_npy(
            &Path::new(&a[0])
                .join("samples")
                .join(stem)
                .join("simulated.npy"),
            stem,
        )?;
        let f: usize = stem[6..].parse()?;
        let posed = body.pose(&poses[f]);
        let mut worst: Vec<(f64, usize)> = garment
            .springs
            .iter()
            .enumerate()
            .filter(|(_, s)| {
                matches!(
                    s.kind,
                    SpringKind::StructuralVertical
                        | SpringKind::StructuralHorizontal
                        | SpringKind::Shear
                )
            })
            .map(|(i, s)| {
                let (p, q) = (x[s.a as usize], x[s.b as usize]);
                let d = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2))
                    .sqrt() as f64;
                (d / s.rest_length - 1.0, i)
            })
            .collect();
        worst.sort_by(|a, b| b.0.total_cmp(&a.0));
        let over = worst.iter().filter(|w| w.0 > 0.5).count();
        println!("{stem}: {over} springs over 50 %");
        for &(strain, i) in worst.iter().take(4) {
            let s = &garment.springs[i];
            let ra = garment.rest.vertices[s.a as usize];
            let pa = x[s.a as usize];
            let pv = garmatnet_core::Vec3::new(pa[0] as f64, pa[1] as f64, pa[2] as f64);
            println!(
                "  strain {strain:.2} {:?} v{} rest ({:.3},{:.3},{:.3}) now ({:.3},{:.3},{:.3}) body dist {:.4}",
                s.kind,
                s.a,
                ra.x,
                ra.y,
                ra.z,
                pa[0],
                pa[1],
                pa[2],
                posed.distance(&pv)
            );
        }
    }
    Ok(())
}
