//! throwaway: resume a material's walk from a stored drape and report.
use garmatnet_core::{CapsuleBody, Garment, Material, Resolution, Vec3};
use garmatnet_sim::sample_arrays::read_points_npy;
use garmatnet_sim::{MotionGenerator, SequenceResume, SequenceSettings, drape_sequence};
use std::path::Path;

fn main() -> anyhow::Result<()> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let (dir, m, name, from, to) = (
        &a[0],
        a[1].parse::<usize>()?,
        &a[2],
        a[3].parse::<usize>()?,
        a[4].parse::<usize>()?,
    );
    let body = CapsuleBody::smpl_neutral();
    let garment = Garment::tshirt(Resolution::Default, &body)?;
    let material = Material::preset(name)?;
    let poses = MotionGenerator::new(0, 200).generate();
    let stem = format!("m{m:03}_p{:04}", from - 1);
    let x = read_points_npy(
        &Path::new(dir)
            .join("samples")
            .join(&stem)
            .join("simulated.npy"),
        &stem,
    )?;
    let positions: Vec<Vec3> = x
        .iter()
        .map(|p| Vec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
        .collect();
    let mut settings = SequenceSettings::default();
    if let Ok(v) = std::env::var("PENALTY") {
        settings.drape.min_contact_stiffness = v.parse()?;
    }
    if let Ok(v) = std::env::var("RATIO") {
        settings.drape.contact_stiffness_ratio = v.parse()?;
    }
    drape_sequence(
        &garment,
        &body,
        &material,
        &poses[..=to],
        &settings,
        Some(SequenceResume {
            next: from,
            positions,
        }),
        |f, x, s| {
            let strain = garment
                .springs
                .iter()
                .filter(|s| {
                    !matches!(
                        s.kind,
                        garmatnet_core::SpringKind::FlexionVertical
                            | garmatnet_core::SpringKind::FlexionHorizontal
                    )
                })
                .map(|sp| (x[sp.a as usize] - x[sp.b as usize]).norm() / sp.rest_length - 1.0)
                .fold(0.0, f64::max);
            println!(
                "frame {f}: {} it, conv {}, stretch {strain:.3}",
                s.iterations, s.converged
            );
            Ok(())
        },
    )?;
    Ok(())
}
