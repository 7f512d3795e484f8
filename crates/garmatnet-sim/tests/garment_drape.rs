//! The T-shirt on the capsule body: material mapping, stability under stress materials and
//! poses, convergence, bit-identical resumption, and stepping frame by frame on a budget.

use approx::assert_relative_eq;
use garmatnet_core::{
    CapsuleBody, Garment, Material, Pose, Real, Resolution, SignedDistance, SkinnedBody,
    SpringKind, Vec3,
};
use garmatnet_sim::{
    DrapeSettings, FactorPrecision, FrameStepper, LANDING_ITERATIONS, MotionGenerator, MotionPace,
    SequenceSettings, cloth_from_garment, drape_poses, drape_sequence, extreme_poses,
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
        ..SequenceSettings::default()
    }
}

/// Drapes `garment` in every material through `poses`; asserts no NaN and no vertex more
/// than 1 mm inside the body at every pose.
fn assert_stable(body: &CapsuleBody, garment: &Garment, materials: &[Material], poses: &[Pose]) {
    for m in materials {
        let stats = drape_sequence(garment, body, m, poses, &quick(), None, |i, x, _| {
            let posed = body.pose(&poses[i]);
            assert!(x.iter().all(|p| p.iter().all(|v| v.is_finite())), "{m:?}");
            let deepest = x.iter().map(|p| -posed.distance(p)).fold(0.0, Real::max);
            assert!(deepest <= 1e-3, "{m:?}: {deepest}");
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{m:?}: {e}"));
        assert!(
            stats
                .iter()
                .all(|s| s.max_penetration <= 1e-3 && s.final_residual.is_finite()),
            "{m:?}"
        );
    }
}

/// The `count` most extreme poses of a seeded motion.
fn extreme(count: usize) -> Vec<Pose> {
    let frames = MotionGenerator::new(5, 200).generate();
    extreme_poses(&frames, count)
        .into_iter()
        .map(|i| frames[i].clone())
        .collect()
}

#[test]
fn stress_materials_on_extreme_poses_stay_finite_and_outside_the_body() {
    let (body, garment) = coarse();
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
    assert_stable(&body, &garment, &materials, &extreme(2));
}

/// The full stress matrix: every preset and its stiffness ×0.01/×100 and density ×0.1/×10
/// variants through the 20 most extreme poses of the generator (coarse template; about ten
/// minutes on one core). Run: `cargo test --release -p garmatnet-sim --test garment_drape --
/// --ignored`.
#[test]
#[ignore = "the full stress matrix takes minutes; CI runs the sample above"]
fn full_stress_matrix_every_preset_and_variant_at_the_20_most_extreme_poses() {
    let (body, garment) = coarse();
    let mut materials = Vec::new();
    for preset in garmatnet_core::presets() {
        let m = preset.material;
        materials.push(m);
        for (stiffness, density) in [(0.01, 1.0), (100.0, 1.0), (1.0, 0.1), (1.0, 10.0)] {
            materials.push(m.scaled(stiffness, density).unwrap());
        }
    }
    assert_eq!(materials.len(), 5 * garmatnet_core::presets().len());
    assert_stable(&body, &garment, &materials, &extreme(20));
}

#[test]
fn sequences_are_deterministic() {
    let (body, garment) = coarse();
    let poses = MotionGenerator::new(9, 2).generate();
    let m = Material::preset("Cotton Poplin").unwrap();
    let run = || {
        let mut out = Vec::new();
        drape_sequence(&garment, &body, &m, &poses, &quick(), None, |_, x, _| {
            out.extend(x.iter().flat_map(|p| p.iter().map(|v| v.to_bits())));
            Ok(())
        })
        .unwrap();
        out
    };
    assert_eq!(run(), run());
}

#[test]
fn coarse_shirt_hangs_on_the_rest_body_and_converges_at_every_pose() {
    let (body, garment) = coarse();
    let m = Material::preset("Cotton Poplin").unwrap();
    let poses = MotionGenerator::new(3, 3).generate();
    let mut settled = Vec::new();
    let stats = drape_sequence(
        &garment,
        &body,
        &m,
        &poses,
        &SequenceSettings::default(),
        None,
        |_, x, s| {
            assert!(s.converged, "{s:?}");
            settled.push(x.to_vec());
            Ok(())
        },
    )
    .unwrap();
    assert!(
        stats[0].converged,
        "the rest drape converges: {:?}",
        stats[0]
    );
    assert!(stats.iter().all(|s| s.max_penetration <= 1e-3));
    assert!(
        stats
            .iter()
            .all(|s| s.final_residual <= 1e-3 && s.max_residual <= 5e-2)
    );

    // The shirt hangs: the hem drops below the rest template but stays above the knees, and
    // the shirt rests on the shoulders (vertices there within the contact margin).
    let hem = &garment
        .boundary
        .iter()
        .find(|l| l.opening == garmatnet_core::Opening::Hem)
        .unwrap()
        .vertices;
    let rest_y: Real = hem
        .iter()
        .map(|&i| garment.rest.vertices[i as usize].y)
        .sum::<Real>()
        / hem.len() as Real;
    let mut x = garment.rest.vertices.clone();
    let mut solver = garmatnet_sim::DrapeSolver::new(
        &cloth_from_garment(&garment, &m).unwrap(),
        &DrapeSettings::default(),
    )
    .unwrap();
    // The template is dressed in its rest pose (the A-pose for the fitted shirt).
    let rest_body = body.pose(&garment.rest_pose);
    assert!(solver.drape(&mut x, &rest_body, &[]).unwrap().converged);
    let hung_y: Real = hem.iter().map(|&i| x[i as usize].y).sum::<Real>() / hem.len() as Real;
    let knee_y = body.skeleton().rest_joints()[4].y;
    assert!(
        hung_y < rest_y - 0.005,
        "hem {hung_y} should drop below the template's {rest_y}"
    );
    assert!(
        hung_y > knee_y + 0.2,
        "hem {hung_y} should stay well above the knees ({knee_y})"
    );
    let shoulder_y = body.skeleton().rest_joints()[16].y;
    let resting = x
        .iter()
        .filter(|p| p.y > shoulder_y && rest_body.distance(p) < 4e-3)
        .count();
    assert!(
        resting > 5,
        "the shirt rests on the shoulders ({resting} vertices in contact there)"
    );
}

#[test]
fn mixed_precision_walks_the_coarse_shirt_to_the_same_drapes() {
    // Single-precision factors with double-precision refinement: every pose converges, and
    // the drapes land where the double-precision walk puts them, within a micrometre (on
    // these three frames; longer walks of finer shirts drift apart, book/src/solver.md).
    let (body, garment) = coarse();
    let m = Material::preset("Cotton Poplin").unwrap();
    let poses = MotionGenerator::new(3, 3).generate();
    let walk = |precision: FactorPrecision| {
        let mut settings = SequenceSettings::default();
        settings.drape.factor_precision = precision;
        let mut drapes = Vec::new();
        drape_sequence(&garment, &body, &m, &poses, &settings, None, |_, x, s| {
            assert!(s.converged, "{precision:?}: {s:?}");
            drapes.push(x.to_vec());
            Ok(())
        })
        .unwrap();
        drapes
    };
    let (double, mixed) = (walk(FactorPrecision::Double), walk(FactorPrecision::Mixed));
    for (frame, (a, b)) in double.iter().zip(&mixed).enumerate() {
        let mean = a.iter().zip(b).map(|(p, q)| (p - q).norm()).sum::<Real>() / a.len() as Real;
        assert!(
            mean < 1e-6,
            "frame {frame}: drapes {mean} m apart on average"
        );
    }
}

#[test]
fn a_resumed_sequence_continues_bit_identically() {
    let (body, garment) = coarse();
    let m =
        Material::preset("Silk Charmeuse").unwrap_or(Material::preset("Cotton Poplin").unwrap());
    let poses = MotionGenerator::new(11, 4).generate();
    let mut full = Vec::new();
    drape_sequence(&garment, &body, &m, &poses, &quick(), None, |_, x, _| {
        full.push(x.to_vec());
        Ok(())
    })
    .unwrap();
    // Resume after pose 1 from its f32 copy, as a dataset stores it.
    let saved: Vec<garmatnet_core::Vec3> = full[1]
        .iter()
        .map(|p| p.map(|c| f64::from(c as f32)))
        .collect();
    let mut resumed = Vec::new();
    let resume = garmatnet_sim::SequenceResume {
        next: 2,
        positions: saved,
    };
    drape_sequence(
        &garment,
        &body,
        &m,
        &poses,
        &quick(),
        Some(resume),
        |_, x, _| {
            resumed.push(x.to_vec());
            Ok(())
        },
    )
    .unwrap();
    assert_eq!(resumed.len(), 2);
    assert_eq!(resumed[0], full[2]);
    assert_eq!(resumed[1], full[3]);
}

#[test]
fn manifests_that_predate_a_setting_read_it_as_the_walk_was_made() {
    let defaults = SequenceSettings::default();
    assert!(defaults.drape.friction > 0.0 && defaults.follow_body);
    // Written before friction: no `drape.friction`, no `follow_body`.
    let mut old = serde_json::to_value(&defaults).unwrap();
    old["drape"].as_object_mut().unwrap().remove("friction");
    old.as_object_mut().unwrap().remove("follow_body");
    let read = SequenceSettings::from_manifest(&old).unwrap();
    assert_eq!(read.drape.friction, 0.0);
    assert!(!read.follow_body);
    assert_eq!(read.max_step_rad, defaults.max_step_rad);
    // Written before the line search's expansion: it reads as off, the rest as written.
    let mut before = serde_json::to_value(&defaults).unwrap();
    before["drape"]
        .as_object_mut()
        .unwrap()
        .remove("step_expansion");
    let read = SequenceSettings::from_manifest(&before).unwrap();
    assert!(defaults.drape.step_expansion > 1.0);
    assert_eq!(read.drape.step_expansion, 1.0);
    assert_eq!(read.drape.friction, defaults.drape.friction);
    // Written before the factor's precision was a setting: it reads as double precision,
    // the only one there was.
    let mut before = serde_json::to_value(&defaults).unwrap();
    before["drape"]
        .as_object_mut()
        .unwrap()
        .remove("factor_precision");
    let read = SequenceSettings::from_manifest(&before).unwrap();
    assert_eq!(read.drape.factor_precision, FactorPrecision::Double);
    assert_eq!(read.drape.step_expansion, defaults.drape.step_expansion);
    // Written now: read back as written.
    let now = serde_json::to_value(&defaults).unwrap();
    assert_eq!(SequenceSettings::from_manifest(&now).unwrap(), defaults);
    assert!(SequenceSettings::from_manifest(&serde_json::json!([1, 2])).is_err());
}

#[test]
fn surface_steps_follow_the_cloth_not_the_joints_it_does_not_cover() {
    let (body, garment) = coarse();
    let cloth = &garment.rest.vertices;
    let rest = Pose::zero();
    let steps = |to: &Pose, surface: Real| {
        garmatnet_sim::surface_steps(&body, &rest, to, cloth, 0.014, surface).unwrap()
    };
    // A wrist turning 0.6 rad: the angle rule takes 43 steps, the cloth moves not at all.
    let mut wrist = Pose::zero();
    wrist.set_joint(20, Vec3::new(0.0, 0.0, 0.6));
    assert_eq!(steps(&wrist, 0.0).len(), 43);
    assert_eq!(steps(&wrist, 0.01), vec![wrist.clone()]);
    // A lowered shoulder carries the sleeve: several steps, each moving the carried cloth
    // by about the limit at most, never more steps than the angle rule.
    let mut shoulder = Pose::zero();
    shoulder.set_joint(16, Vec3::new(0.0, 0.0, -0.6));
    let walk = steps(&shoulder, 0.01);
    assert!(walk.len() > 5 && walk.len() <= 43, "{} steps", walk.len());
    assert_eq!(walk.last(), Some(&shoulder));
    let (mut points, mut posed) = (cloth.clone(), body.pose(&rest));
    for pose in &walk {
        let next = body.pose(pose);
        let before = points.clone();
        posed.carry_to(&next, &mut points);
        let moved = before
            .iter()
            .zip(&points)
            .map(|(a, b)| (b - a).norm())
            .fold(0.0, Real::max);
        assert!(moved < 0.011, "a step carried cloth {moved} m");
        posed = next;
    }
    // Off is exactly the angle rule; bad limits are refused.
    assert_eq!(
        steps(&shoulder, 0.0),
        garmatnet_sim::interpolation_steps(&rest, &shoulder, 0.014).unwrap()
    );
    for bad in [-0.01, Real::NAN] {
        assert!(garmatnet_sim::surface_steps(&body, &rest, &shoulder, cloth, 0.014, bad).is_err());
    }
    // Left out of the manifest when off, so older datasets' settings still match.
    let json = serde_json::to_value(SequenceSettings::default()).unwrap();
    assert!(json.get("max_surface_step").is_none(), "{json}");
}

/// Mean distance (mm) between two drapes of the same garment.
fn mean_mm(a: &[Vec3], b: &[Vec3]) -> Real {
    a.iter().zip(b).map(|(p, q)| (p - q).norm()).sum::<Real>() * 1e3 / a.len() as Real
}

#[test]
#[ignore = "not met on revision 3's body: stepping in place moves 1.26 mm (slip 1 mm) and \
            frame 2's 8-iteration drape lies 4.80 mm from the walked one against 4.68 carried \
            only; open in issue 48"]
fn a_frame_stepper_follows_the_motion_within_its_budget() {
    // Measured on the boxy shirt: on the fitted one, walked from the A-pose, frame 3 of this
    // motion lies 2.61 mm from the walked drape against 2.46 mm merely carried (open).
    let body = CapsuleBody::smpl_neutral();
    let garment = Garment::boxy_tshirt(Resolution::Coarse, &body).unwrap();
    let m = Material::preset("Cotton Poplin").unwrap();
    let poses = MotionGenerator::with_pace(0, 4, MotionPace::Gentle).generate();
    let reference = drape_poses(&garment, &body, &m, &poses, &SequenceSettings::default()).unwrap();
    let budget = DrapeSettings {
        max_iterations: 8,
        ..DrapeSettings::default()
    };
    let stepper = |settings: &DrapeSettings| {
        FrameStepper::new(
            &garment,
            &body,
            &m,
            settings,
            &poses[0],
            reference[0].clone(),
        )
        .unwrap()
    };
    // Stepping in place from an equilibrium stays there, up to the friction's slip length
    // (friction is measured afresh from where the step starts, and its static spring has to
    // take up the tangential load again).
    let mut still = stepper(&DrapeSettings::default());
    let s = still.step(&poses[0]).unwrap();
    assert!(s.converged, "{s:?}");
    let moved = mean_mm(still.positions(), &reference[0]);
    assert!(
        moved < 1e3 * DrapeSettings::default().friction_slip,
        "moved {moved} mm"
    );

    // Eight iterations a frame, each frame from the last budgeted one (no walk between
    // frames): the budget holds, nothing enters the body, and the drapes stay near the
    // walked, converged ones — nearer than the cloth merely carried with the skin.
    let mut budgeted = stepper(&budget);
    let mut carried = reference[0].clone();
    for f in 1..poses.len() {
        let s = budgeted.step(&poses[f]).unwrap();
        assert!(s.iterations <= 8 && s.max_penetration <= 1e-3, "{s:?}");
        body.pose(&poses[f - 1])
            .carry_to(&body.pose(&poses[f]), &mut carried);
        let (stepped, only_carried) = (
            mean_mm(budgeted.positions(), &reference[f]),
            mean_mm(&carried, &reference[f]),
        );
        assert!(
            stepped < 5.0 && stepped < only_carried,
            "frame {f}: {stepped:.2} mm from the walked drape, carried only {only_carried:.2}"
        );
        // Keep the carried-only chain on the reference, so it measures one frame's carry.
        carried.clone_from(&reference[f]);
    }
    assert_eq!(
        budgeted.posed_body().skinning_transforms(),
        body.pose(&poses[3]).skinning_transforms()
    );

    // Restarting at a saved frame steps exactly as a stepper made there.
    let mut restarted = stepper(&budget);
    restarted.restart(&poses[2], &reference[2]).unwrap();
    let mut made_there = FrameStepper::new(
        &garment,
        &body,
        &m,
        &budget,
        &poses[2],
        reference[2].clone(),
    )
    .unwrap();
    restarted.step(&poses[3]).unwrap();
    made_there.step(&poses[3]).unwrap();
    assert_eq!(restarted.positions(), made_there.positions());
}

#[test]
fn a_frame_stepper_refuses_positions_it_cannot_step_from() {
    let (body, garment) = coarse();
    let m = Material::preset("Cotton Poplin").unwrap();
    let new = |positions: Vec<Vec3>| {
        FrameStepper::new(
            &garment,
            &body,
            &m,
            &DrapeSettings::default(),
            &Pose::zero(),
            positions,
        )
    };
    let short = garment.rest.vertices[1..].to_vec();
    let err = new(short).unwrap_err().to_string();
    assert!(err.contains("garment positions to step from"), "{err}");
    let mut bad = garment.rest.vertices.clone();
    bad[7].y = Real::NAN;
    let err = new(bad.clone()).unwrap_err().to_string();
    assert!(
        err.contains("garment positions") && err.contains("vertex 7"),
        "{err}"
    );
    let mut stepper = new(garment.rest.vertices.clone()).unwrap();
    assert!(stepper.restart(&Pose::zero(), &bad).is_err());
    assert!(stepper.restart(&Pose::zero(), &bad[1..]).is_err());
    assert_eq!(
        stepper.positions(),
        &garment.rest.vertices[..],
        "a refused restart changes nothing"
    );
    // A pose assembled with a NaN (set_joint does not check) is refused before anything
    // moves, so the stepper stays usable.
    let mut nan_pose = Pose::zero();
    nan_pose.set_joint(16, Vec3::new(Real::NAN, 0.0, 0.0));
    assert!(stepper.step(&nan_pose).is_err());
    assert_eq!(
        stepper.positions(),
        &garment.rest.vertices[..],
        "a refused step changes nothing"
    );
}

/// A stiff fabric pressed against the body by its own tension (Trim Fusible Rigid on the
/// coarse shirt, three of seed 0's most extreme poses): the plain 300 N/m penalty lets it
/// settle centimetres inside the body before the final projection moves it out (41 mm
/// measured, and so deep that the projection leaves its triangles 4.3 mm under the body
/// between their vertices); the penalty's hardening inside the body keeps it within a few
/// millimetres (7.1 mm), and the projection then clears every triangle.
#[test]
fn the_penalty_hardening_keeps_a_stiff_fabric_from_sinking_into_the_body() {
    let (body, garment) = coarse();
    let frames = MotionGenerator::new(0, 200).generate();
    let poses: Vec<Pose> = extreme_poses(&frames, 20)[..3]
        .iter()
        .map(|&i| frames[i].clone())
        .collect();
    let material = Material::preset("Trim Fusible Rigid").unwrap();
    let deepest = |hardening: Real| {
        let mut settings = SequenceSettings::default();
        settings.drape.contact_hardening = hardening;
        let stats = drape_sequence(
            &garment,
            &body,
            &material,
            &poses,
            &settings,
            None,
            |_, _, _| Ok(()),
        )
        .unwrap();
        assert!(stats.iter().all(|s| s.converged));
        let depth = stats
            .iter()
            .map(|s| s.max_depth_before_projection)
            .fold(0.0, Real::max);
        let after = stats.iter().map(|s| s.max_penetration).fold(0.0, Real::max);
        (depth, after)
    };
    let (plain, _) = deepest(0.0);
    let (hardened, hardened_after) = deepest(SequenceSettings::default().drape.contact_hardening);
    assert!(plain > 0.010, "the scene presses the cloth in: {plain} m");
    assert!(
        hardened < 0.008,
        "hardened: {hardened} m deep (plain {plain} m)"
    );
    assert!(
        hardened_after <= 1e-3,
        "{hardened_after} m deep after the projection"
    );
}

/// A left-right symmetric pose gives a left-right symmetric drape. Before the skeleton was
/// made mirror-symmetric and the rest drape landed before friction took hold, every fabric
/// slid along the raised arms at the T-pose (Cashmere 83.6 mm of mirror asymmetry, Silk
/// Duchess Satin 61.6 mm at coarse resolution; Satin 62.8 mm even on a symmetric skeleton).
#[test]
fn symmetric_poses_give_symmetric_drapes() {
    let (body, garment) = coarse();
    // The template itself pairs every vertex with its mirror twin to the micrometre.
    let mirror = garmatnet_sim::MirrorMap::of_garment(&garment).unwrap();
    assert_eq!(mirror.asymmetry(&garment.rest.vertices).unwrap(), 0.0);
    for name in ["Cashmere", "Silk Duchess Satin"] {
        let material = Material::preset(name).unwrap();
        let drapes = drape_poses(
            &garment,
            &body,
            &material,
            &[Pose::zero()],
            &SequenceSettings::default(),
        )
        .unwrap();
        let asymmetry = mirror.asymmetry(&drapes[0]).unwrap();
        assert!(
            asymmetry <= 5e-3,
            "{name}: {:.1} mm of mirror asymmetry at the T-pose",
            asymmetry * 1e3
        );
    }
}

/// A walk starts from the same rest drape as a canonical sample: Spandex's drape from the rest
/// mesh does not settle within the iteration cap and drifts toward the body's left, so the
/// walk too restarts it from its mirror average ([`garmatnet_sim::settle_rest_drape`]). Before
/// the walk shared that restart, its first pose (the rest pose itself) was 59 mm from its
/// mirror image.
#[test]
fn a_walk_starts_from_the_symmetric_rest_drape() {
    let body = CapsuleBody::smpl_neutral();
    let garment = Garment::tshirt(Resolution::Default, &body).unwrap();
    let mirror = garmatnet_sim::MirrorMap::of_garment(&garment).unwrap();
    let spandex = Material::preset("Spandex").unwrap();
    let settings = SequenceSettings::default();
    let stats = drape_sequence(
        &garment,
        &body,
        &spandex,
        std::slice::from_ref(&garment.rest_pose),
        &settings,
        None,
        |_, x, _| {
            let asymmetry = mirror.asymmetry(x).unwrap();
            assert!(
                asymmetry < 1e-3,
                "{:.2} mm of mirror asymmetry at the rest pose",
                asymmetry * 1e3
            );
            Ok(())
        },
    )
    .unwrap();
    // Converged after a restart: the first solve alone stops at the iteration cap.
    assert!(stats[0].converged, "rest drape: {:?}", stats[0]);
    assert!(
        stats[0].iterations > settings.drape.max_iterations + LANDING_ITERATIONS,
        "rest drape: {:?}",
        stats[0]
    );
}
