//! Run: `cargo run -p garmatnet-sim --release --example fitted_fit -- [coarse|default|paper] [out_dir] [style]`
//!
//! Drapes the T-shirt (fitted by default, `boxy` as the third argument) from its rest pose
//! to the rest pose itself and to arms hanging at the sides (shoulders ±1.3 rad about the
//! forward axis) for four presets, and prints for each drape: whether the shirt stays on
//! the shoulders (how far the neckline's centre sank and slid sideways from the rest
//! mesh's), the largest spring strain, the deepest penetration and the mean mirror
//! asymmetry. Writes each drape and the posed body as OBJ, and front and side PNG renders,
//! into `out_dir` (default `/tmp/fitted_fit`). `PRESETS="a;b"` picks other presets.

use std::path::Path;

use garmatnet_core::render::{GARMENT_COLOR, Shading};
use garmatnet_core::{
    CapsuleBody, Garment, GarmentStyle, Material, Opening, Pose, Real, Resolution, TriMesh, Vec3,
    write_obj,
};
use garmatnet_sim::{SequenceSettings, drape_sequence};

#[path = "common/views.rs"]
mod views;

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let resolution: Resolution = args.next().unwrap_or("default".into()).parse()?;
    let out = args.next().unwrap_or("/tmp/fitted_fit".into());
    let style: GarmentStyle = args.next().unwrap_or("fitted".into()).parse()?;
    let out = Path::new(&out);
    std::fs::create_dir_all(out)?;
    let body = CapsuleBody::smpl_neutral();
    let garment = Garment::with_style(style, resolution, &body)?;
    let presets = std::env::var("PRESETS")
        .unwrap_or("Cotton Poplin;Cashmere;Denim Heavy;Silk Duchess Satin".into());
    let mut arms_down = garment.rest_pose.clone();
    arms_down.set_joint(16, Vec3::new(0.0, 0.0, -1.3));
    arms_down.set_joint(17, Vec3::new(0.0, 0.0, 1.3));
    let poses = [
        ("rest", garment.rest_pose.clone()),
        ("arms_down", arms_down),
    ];
    println!(
        "{style} {resolution}: {} vertices, {} springs",
        garment.vertex_count(),
        garment.springs.len()
    );
    let neck = &garment
        .boundary
        .iter()
        .find(|b| b.opening == Opening::Neck)
        .ok_or_else(|| anyhow::anyhow!("no neck opening"))?
        .vertices;
    let centre =
        |x: &[Vec3]| neck.iter().map(|&i| x[i as usize]).sum::<Vec3>() / neck.len() as Real;
    let rest_neck = centre(&garment.rest.vertices);
    println!(
        "{:<20} {:<10} {:>9} {:>9} {:>8} {:>9} {:>9} {:>7} {:>6}",
        "preset", "pose", "neck dy", "neck dx", "strain", "pen (mm)", "asym (mm)", "resid", "iters"
    );
    for preset in presets.split(';') {
        let material = Material::preset(preset)?;
        let pose_list: Vec<Pose> = poses.iter().map(|p| p.1.clone()).collect();
        let mut drapes = Vec::new();
        drape_sequence(
            &garment,
            &body,
            &material,
            &pose_list,
            &SequenceSettings::default(),
            None,
            |k, x, stats| {
                drapes.push((k, x.to_vec(), stats.clone()));
                Ok(())
            },
        )?;
        for (k, x, stats) in drapes {
            let (name, pose) = &poses[k];
            let neck_now = centre(&x);
            let twins = garment.mirror_twins();
            let asymmetry = x
                .iter()
                .zip(twins)
                .map(|(p, &t)| {
                    let q = x[t as usize];
                    (p - Vec3::new(-q.x, q.y, q.z)).norm()
                })
                .sum::<Real>()
                / x.len() as Real;
            println!(
                "{preset:<20} {name:<10} {:>+9.4} {:>+9.4} {:>8.3} {:>9.2} {:>9.2} {:>7.4} {:>6}",
                neck_now.y - rest_neck.y,
                neck_now.x - rest_neck.x,
                stats.max_strain,
                stats.max_penetration * 1e3,
                asymmetry * 1e3,
                stats.final_residual,
                stats.iterations
            );
            if let Some((s, strain)) = garment
                .springs
                .iter()
                .map(|s| {
                    (
                        s,
                        (x[s.a as usize] - x[s.b as usize]).norm() / s.rest_length - 1.0,
                    )
                })
                .max_by(|a, b| a.1.total_cmp(&b.1))
            {
                let mid = (x[s.a as usize] + x[s.b as usize]) / 2.0;
                println!(
                    "    most stretched: {:?} by {strain:.2} at ({:.3}, {:.3}, {:.3}) m",
                    s.kind, mid.x, mid.y, mid.z
                );
            }
            let tag = format!("{}_{name}", preset.to_lowercase().replace(' ', "_"));
            let mesh = TriMesh::new(x, garment.rest.faces.clone())?;
            let body_mesh = body.pose(pose).mesh();
            write_obj(out.join(format!("{tag}.obj")), &mesh)?;
            write_obj(out.join(format!("body_{name}.obj")), &body_mesh)?;
            views::save_front_and_side(
                &out.join(&tag),
                &body_mesh,
                &mesh,
                Shading::Uniform(GARMENT_COLOR),
                0.1,
            )?;
        }
    }
    Ok(())
}
