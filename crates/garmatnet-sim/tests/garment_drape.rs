//! The T-shirt on the capsule body: material mapping, stability under stress materials and
//! poses, and (ignored until the contact convergence gap is closed) convergence.

use approx::assert_relative_eq;
use garmatnet_core::{
    CapsuleBody, Garment, Material, Pose, Real, Resolution, SignedDistance, SpringKind,
};
use garmatnet_sim::{
    DrapeSettings, MotionGenerator, SequenceSettings, cloth_from_garment, drape_sequence,
    extreme_poses,
};

fn coarse() -> (CapsuleBody, Garment) {
    let body = CapsuleBody::smpl_neutral();
    let garment = Garment::tshirt(Resolution::Coarse, &body).unwrap();
    (body, garment)
}

#[test]
fn cloth_takes_each_spring_kind_and_the_density_from_the_material() {
    let (_, garment) = coarse();
    let m = Material::physical(1.0, 2.0, 3.0, 4.0, 5.0, 0.5).unwrap();
    let cloth = cloth_from_garment(&garment, &m).unwrap();
    for (s, spec) in garment.springs.iter().zip(cloth.springs()) {
        let want = match s.kind {
            SpringKind::StructuralVertical => 1.0,
            SpringKind::StructuralHorizontal => 2.0,
            SpringKind::FlexionVertical => 3.0,
            SpringKind::FlexionHorizontal => 4.0,
            SpringKind::Shear => 5.0,
        };
        assert_eq!(spec.stiffness, want);
        assert_eq!(spec.rest_length, s.rest_length);
    }
    let area: Real = garment.vertex_masses(1.0).iter().sum();
    assert_relative_eq!(cloth.total_mass(), 0.5 * area, max_relative = 1e-12);
    let bad = Material { density: -1.0, ..m };
    assert!(cloth_from_garment(&garment, &bad).is_err());
}

/// Few iterations per pose: this checks robustness (finite, no penetration), not
/// convergence.
fn quick() -> SequenceSettings {
    SequenceSettings {
        drape: DrapeSettings {
            max_iterations: 15,
            ..DrapeSettings::default()
        },
        max_step_rad: 0.1,
        intermediate_iterations: 2,
    }
}

#[test]
fn stress_materials_on_extreme_poses_stay_finite_and_outside_the_body() {
    let (body, garment) = coarse();
    let frames = MotionGenerator::new(5, 40).generate();
    let poses: Vec<Pose> = extreme_poses(&frames, 2)
        .into_iter()
        .map(|i| frames[i].clone())
        .collect();
    let mid = Material::preset("Cotton Poplin").unwrap();
    let materials = [
        Material::preset("Silk Chiffon").unwrap(),
        Material::preset("Trim Fusible Rigid").unwrap(),
        Material::preset("Cowhide Leather").unwrap(),
        mid.scaled(0.01, 1.0).unwrap(),
        mid.scaled(100.0, 1.0).unwrap(),
        mid.scaled(1.0, 0.1).unwrap(),
        mid.scaled(1.0, 10.0).unwrap(),
    ];
    for m in &materials {
        let stats = drape_sequence(&garment, &body, m, &poses, &quick(), |i, x, _| {
            let posed = body.pose(&poses[i]);
            assert!(x.iter().all(|p| p.iter().all(|v| v.is_finite())), "{m:?}");
            let deepest = x.iter().map(|p| -posed.distance(p)).fold(0.0, Real::max);
            assert!(deepest <= 1e-3, "{m:?}: {deepest}");
            Ok(())
        })
        .unwrap();
        assert!(
            stats
                .iter()
                .all(|s| s.max_penetration <= 1e-3 && s.final_residual.is_finite())
        );
    }
}

#[test]
fn sequences_are_deterministic() {
    let (body, garment) = coarse();
    let poses = MotionGenerator::new(9, 2).generate();
    let m = Material::preset("Cotton Poplin").unwrap();
    let run = || {
        let mut out = Vec::new();
        drape_sequence(&garment, &body, &m, &poses, &quick(), |_, x, _| {
            out.extend(x.iter().flat_map(|p| p.iter().map(|v| v.to_bits())));
            Ok(())
        })
        .unwrap();
        out
    };
    assert_eq!(run(), run());
}

#[test]
#[ignore = "known gap: the Newton/PTC solver stalls at RMS residual ~0.2-10 on the shirt (landing contacts force tiny line-search steps); see the solver report"]
fn coarse_shirt_hangs_on_the_rest_body_and_converges() {
    let (body, garment) = coarse();
    let m = Material::preset("Cotton Poplin").unwrap();
    let poses = MotionGenerator::new(3, 3).generate();
    let stats = drape_sequence(
        &garment,
        &body,
        &m,
        &poses,
        &SequenceSettings::default(),
        |_, _, s| {
            assert!(s.converged, "{s:?}");
            Ok(())
        },
    )
    .unwrap();
    assert!(stats[0].converged, "{:?}", stats[0]);
    assert!(stats.iter().all(|s| s.max_penetration <= 1e-3));
}
