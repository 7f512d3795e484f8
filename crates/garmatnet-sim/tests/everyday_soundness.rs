//! The ground truth is sound at everyday poses: hanging arms press into the ribs and
//! raised arms pull the underarm, and neither tears the cloth, sinks it into the body (at its
//! vertices or between them) or breaks a symmetric pose's symmetry. Coarse resolution, four fabrics from the softest to the
//! stiffest; `cargo run -p garmatnet-sim --release --example everyday_soundness` measures every
//! preset at every pose (the ground-truth chapter of the book has the table).

use garmatnet_core::{
    CapsuleBody, Garment, Material, Resolution, SpringKind, deepest_point_inside,
};
use garmatnet_sim::{
    CanonicalDraper, MirrorMap, SOUND_STRETCH, canonical_settings, everyday_poses,
};

#[test]
fn hanging_and_raised_arms_neither_tear_nor_sink_nor_break_symmetry() {
    let body = CapsuleBody::smpl_neutral();
    let garment = Garment::tshirt(Resolution::Coarse, &body).unwrap();
    let mirror = MirrorMap::of_garment(&garment).unwrap();
    let poses: Vec<_> = everyday_poses()
        .into_iter()
        .filter(|p| ["arms-at-sides", "both-arms-raised"].contains(&p.name))
        .collect();
    assert_eq!(poses.len(), 2);
    for name in [
        "Tulle",
        "Cotton Jersey",
        "Denim Heavy",
        "Trim Fusible Rigid",
    ] {
        let material = Material::preset(name).unwrap();
        let draper =
            CanonicalDraper::new(&garment, &body, &material, &canonical_settings()).unwrap();
        for pose in &poses {
            let (x, stats) = draper.drape(&pose.pose).unwrap();
            let what = format!("{name} at {}", pose.name);
            assert!(
                x.iter().all(|p| p.iter().all(|c| c.is_finite())),
                "{what}: NaN"
            );
            // The solver's own strain (every spring) and the structural and shear springs
            // `dataset check` measures.
            let stretch = garment
                .springs
                .iter()
                .filter(|s| {
                    matches!(
                        s.kind,
                        SpringKind::StructuralHorizontal
                            | SpringKind::StructuralVertical
                            | SpringKind::Shear
                    )
                })
                .map(|s| (x[s.a as usize] - x[s.b as usize]).norm() / s.rest_length - 1.0)
                .fold(f64::NEG_INFINITY, f64::max);
            assert!(
                stats.max_strain < SOUND_STRETCH,
                "{what}: strain {}",
                stats.max_strain
            );
            assert!(stretch <= stats.max_strain + 1e-3, "{what}: {stretch}");
            assert!(
                stats.max_penetration <= 1e-3,
                "{what}: {} m deep",
                stats.max_penetration
            );
            let between = deepest_point_inside(&x, &garment.rest.faces, &body.pose(&pose.pose), 8);
            assert!(
                between <= 1e-3,
                "{what}: {:.2} mm deep between the vertices",
                between * 1e3
            );
            assert!(pose.symmetric);
            let asymmetry = mirror.asymmetry(&x).unwrap();
            assert!(
                asymmetry <= 5e-3,
                "{what}: {:.1} mm asymmetric",
                asymmetry * 1e3
            );
        }
    }
}
