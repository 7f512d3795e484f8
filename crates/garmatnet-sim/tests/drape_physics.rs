//! Physics sanity of the static-drape solver on sheets: symmetry, sag trends, force balance
//! on a sphere, stability over the material range, determinism and input errors.

use garmatnet_core::{Error as CoreError, Real, Sphere, UnitQuat, Vec3};
use garmatnet_sim::{
    ClothModel, DrapeSettings, DrapeSolver, DrapeStats, EmptySpace, Error, SheetStiffness,
    grid_sheet,
};

const MID: SheetStiffness = SheetStiffness {
    structural_warp: 300.0,
    structural_weft: 250.0,
    shear: 30.0,
    flexion_warp: 2.0,
    flexion_weft: 2.0,
};
const DENSITY: Real = 0.15;
/// The middle vertex of the 15 x 15 sheet on the sphere.
const CENTRE: usize = 15 * 15 / 2;

/// A sheet hanging in the x-y plane, pinned at its two top corners.
fn hanging(
    columns: usize,
    density: Real,
    stiffness: SheetStiffness,
) -> (ClothModel, Vec<Vec3>, Vec<usize>, DrapeStats) {
    let model = grid_sheet(columns, columns, 0.02, density, stiffness).unwrap();
    // Rotate x-z into x-y: row 0 at the top.
    let mut x: Vec<Vec3> = model
        .rest_positions()
        .iter()
        .map(|p| Vec3::new(p.x, -p.z, 0.0))
        .collect();
    let pins = vec![0, columns - 1];
    let mut solver = DrapeSolver::new(&model, &DrapeSettings::default()).unwrap();
    let stats = solver.drape(&mut x, &EmptySpace, &pins).unwrap();
    (model, x, pins, stats)
}

/// How far the middle of the top edge hangs below the pinned corners (metres).
fn sag(columns: usize, x: &[Vec3]) -> Real {
    x[0].y - x[columns / 2].y
}

#[test]
fn hanging_sheet_is_mirror_symmetric() {
    let columns = 15;
    let (_, x, _, stats) = hanging(columns, DENSITY, MID);
    assert!(stats.converged, "{stats:?}");
    let size = 0.02 * (columns - 1) as Real;
    for r in 0..columns {
        for c in 0..columns {
            let p = x[r * columns + c];
            let q = x[r * columns + columns - 1 - c];
            let mirror_error = (Vec3::new(-q.x, q.y, q.z) - p).norm();
            assert!(
                mirror_error < 1e-6 * size,
                "vertex ({c}, {r}) mirror error {mirror_error}"
            );
        }
    }
}

#[test]
fn the_line_search_expansion_drapes_a_sheet_on_a_sphere_in_fewer_iterations() {
    // Cloth settling into folds is where the projected Hessian's Newton steps fall short.
    let (model, start, sphere) = sheet_on_sphere(15, DENSITY, MID);
    let drape = |expansion: Real| {
        let settings = DrapeSettings {
            step_expansion: expansion,
            ..DrapeSettings::default()
        };
        let mut x = start.clone();
        let stats = DrapeSolver::new(&model, &settings)
            .unwrap()
            .drape(&mut x, &sphere, &[])
            .unwrap();
        assert!(stats.converged, "expansion {expansion}: {stats:?}");
        (x, stats)
    };
    let (plain, plain_stats) = drape(1.0);
    let (expanded, expanded_stats) = drape(2.0);
    let apart = plain
        .iter()
        .zip(&expanded)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, Real::max);
    assert_eq!(plain_stats.expanded_steps, 0);
    assert!(expanded_stats.expanded_steps > 0, "{expanded_stats:?}");
    assert!(
        expanded_stats.iterations < plain_stats.iterations,
        "expanded {expanded_stats:?} plain {plain_stats:?}"
    );
    let weight = model.total_mass() * 9.81;
    assert!(
        (expanded_stats.contact_force.y - weight).abs() < 0.01 * weight,
        "{expanded_stats:?}"
    );
    assert!(apart < 1e-3, "the two drapes lie {apart} m apart");
}

#[test]
fn hanging_sag_grows_with_density_and_shrinks_with_stiffness() {
    let columns = 11;
    let base = sag(columns, &hanging(columns, DENSITY, MID).1);
    let heavy = sag(columns, &hanging(columns, DENSITY * 4.0, MID).1);
    let stiff = sag(columns, &hanging(columns, DENSITY, MID.scaled(4.0)).1);
    assert!(heavy > base * 1.01, "heavy {heavy} vs base {base}");
    assert!(stiff < base * 0.99, "stiff {stiff} vs base {base}");
}

fn sheet_on_sphere(
    columns: usize,
    density: Real,
    stiffness: SheetStiffness,
) -> (ClothModel, Vec<Vec3>, Sphere) {
    let model = grid_sheet(columns, columns, 0.02, density, stiffness).unwrap();
    let sphere = Sphere {
        centre: Vec3::zeros(),
        radius: 0.15,
    };
    let x = model
        .rest_positions()
        .iter()
        .map(|p| p + Vec3::new(0.0, 0.16, 0.0))
        .collect();
    (model, x, sphere)
}

#[test]
fn sheet_on_sphere_rests_with_balanced_forces_and_no_penetration() {
    let (model, mut x, sphere) = sheet_on_sphere(15, DENSITY, MID);
    let mut solver = DrapeSolver::new(&model, &DrapeSettings::default()).unwrap();
    let stats = solver.drape(&mut x, &sphere, &[]).unwrap();
    assert!(stats.converged, "{stats:?}");
    let weight = model.total_mass() * 9.81;
    let f = stats.contact_force;
    assert!(
        (f.y - weight).abs() < 0.01 * weight,
        "contact {f:?} vs weight {weight}"
    );
    assert!(
        f.x.abs() < 0.01 * weight && f.z.abs() < 0.01 * weight,
        "{f:?}"
    );
    assert!(stats.max_penetration <= 1e-3, "{stats:?}");
    let deepest = x
        .iter()
        .map(|p| -garmatnet_core::SignedDistance::distance(&sphere, p))
        .fold(0.0, Real::max);
    assert!(deepest <= 1e-3, "deepest {deepest}");
    // It drapes: the corners hang below the top, following the sphere.
    assert!(x[0].y < 0.29, "corner at {}", x[0].y);
}

#[test]
fn extreme_materials_stay_finite_and_bounded() {
    for (density, k) in [
        (DENSITY, 0.01),
        (DENSITY, 100.0),
        (DENSITY * 0.1, 1.0),
        (DENSITY * 10.0, 1.0),
    ] {
        let (model, mut x, sphere) = sheet_on_sphere(15, density, MID.scaled(k));
        // The centre is pinned: a stiff flat sheet balanced on a sphere is an unstable
        // equilibrium and rightly slides off (friction would hold it only from where it
        // first touched, and a drape gives friction to the contacts it starts with).
        let settings = DrapeSettings {
            max_iterations: 400,
            ..DrapeSettings::default()
        };
        let mut solver = DrapeSolver::new(&model, &settings).unwrap();
        let stats = solver.drape(&mut x, &sphere, &[CENTRE]).unwrap();
        assert!(
            x.iter().all(|p| p.iter().all(|v| v.is_finite())),
            "density {density}, k x{k}"
        );
        assert!(
            x.iter().all(|p| p.norm() < 1.0),
            "density {density}, k x{k}: escaped"
        );
        assert!(
            stats.max_penetration <= 1e-3,
            "density {density}, k x{k}: {stats:?}"
        );
        assert!(stats.final_residual.is_finite());
    }
}

#[test]
fn same_inputs_give_bit_identical_outputs() {
    let (model, x0, sphere) = sheet_on_sphere(15, DENSITY, MID);
    let run = |solver: &mut DrapeSolver| {
        let mut x = x0.clone();
        solver.drape(&mut x, &sphere, &[]).unwrap();
        x
    };
    let mut a = DrapeSolver::new(&model, &DrapeSettings::default()).unwrap();
    let mut b = DrapeSolver::new(&model, &DrapeSettings::default()).unwrap();
    let first = run(&mut a);
    // A used solver (holding a factor from the previous drape) must not change the answer.
    let again = run(&mut a);
    let fresh = run(&mut b);
    assert!(first.iter().zip(&again).all(|(p, q)| {
        p.iter()
            .zip(q.iter())
            .all(|(u, v)| u.to_bits() == v.to_bits())
    }));
    assert!(first.iter().zip(&fresh).all(|(p, q)| {
        p.iter()
            .zip(q.iter())
            .all(|(u, v)| u.to_bits() == v.to_bits())
    }));
}

#[test]
fn warm_start_from_equilibrium_needs_few_iterations() {
    let (model, mut x, sphere) = sheet_on_sphere(15, DENSITY, MID);
    let mut solver = DrapeSolver::new(&model, &DrapeSettings::default()).unwrap();
    let cold = solver.drape(&mut x, &sphere, &[]).unwrap();
    let warm = solver.drape(&mut x, &sphere, &[]).unwrap();
    assert!(
        warm.converged && warm.iterations * 4 <= cold.iterations.max(4),
        "cold {cold:?} warm {warm:?}"
    );
}

#[test]
fn bad_drape_inputs_are_typed_errors() {
    let (model, mut x, sphere) = sheet_on_sphere(5, DENSITY, MID);
    let mut solver = DrapeSolver::new(&model, &DrapeSettings::default()).unwrap();
    x[3].y = Real::NAN;
    let e = solver.drape(&mut x, &sphere, &[]).unwrap_err();
    assert!(
        matches!(e, Error::Core(CoreError::NonFinite { index: 10, .. })),
        "{e}"
    );
    x[3].y = 0.0;
    let e = solver.drape(&mut x, &sphere, &[25]).unwrap_err();
    assert!(
        matches!(e, Error::Core(CoreError::OutOfRange { .. })),
        "{e}"
    );
    let e = solver.drape(&mut x[..4], &sphere, &[]).unwrap_err();
    assert!(
        matches!(e, Error::Core(CoreError::WrongLength { .. })),
        "{e}"
    );
    let bad = DrapeSettings {
        time_step: -1.0,
        ..DrapeSettings::default()
    };
    assert!(matches!(
        DrapeSolver::new(&model, &bad).unwrap_err(),
        Error::Core(CoreError::OutOfRange { .. })
    ));
    for expansion in [0.5, Real::NAN, 1e3] {
        let bad = DrapeSettings {
            step_expansion: expansion,
            ..DrapeSettings::default()
        };
        let e = DrapeSolver::new(&model, &bad).unwrap_err();
        assert!(
            matches!(&e, Error::Core(CoreError::OutOfRange { .. }))
                && e.to_string().contains("step expansion"),
            "{e}"
        );
    }
    let other = grid_sheet(6, 5, 0.02, DENSITY, MID).unwrap();
    assert!(matches!(
        solver.set_model(&other).unwrap_err(),
        Error::Core(CoreError::Mismatch { .. })
    ));
}

#[test]
fn scaling_every_stiffness_and_the_density_together_leaves_the_drape_in_place() {
    // Springs, gravity and the Coulomb cone all scale by c, so the equilibrium is the same;
    // only the fixed contact penalty sees c. This is why GarMatNet's `scale_free_material`
    // option may ignore that direction of ω. The centre is pinned (see
    // `extreme_materials_stay_finite_and_bounded`).
    let settings = DrapeSettings {
        max_iterations: 400,
        ..DrapeSettings::default()
    };
    let drape = |c: Real, stiffness: SheetStiffness| {
        let (model, mut x, sphere) = sheet_on_sphere(15, DENSITY * c, stiffness);
        let mut solver = DrapeSolver::new(&model, &settings).unwrap();
        let stats = solver.drape(&mut x, &sphere, &[CENTRE]).unwrap();
        assert!(stats.max_penetration <= 1e-3, "c = {c}: {stats:?}");
        x
    };
    let gap = |a: &[Vec3], b: &[Vec3]| {
        a.iter()
            .zip(b)
            .map(|(p, q)| (p - q).norm())
            .fold(0.0, Real::max)
    };
    let base = drape(1.0, MID);
    for c in [0.5, 2.0] {
        let g = gap(&drape(c, MID.scaled(c)), &base);
        assert!(g < 1e-3, "c = {c}: a vertex moved {g} m");
    }
    // While a change of stiffness alone moves it by far more (measured: 0.005-0.01 mm
    // above, 17 mm here).
    let g = gap(&drape(1.0, MID.scaled(2.0)), &base);
    assert!(g > 5e-3, "stiffness alone moved the sheet only {g} m");
}

/// A small sheet laid on a big sphere (nearly a plane) at `tilt` radians from its top,
/// 1.5 mm out, so every vertex starts within the contact margin; drapes it with friction
/// coefficient `friction` and returns how far its centre moved (metres) and the stats.
fn slide_on_tilted_sphere(tilt: Real, friction: Real) -> (Real, DrapeStats) {
    let columns = 7;
    let model = grid_sheet(columns, columns, 0.02, DENSITY, MID).unwrap();
    let radius = 5.0;
    let sphere = Sphere {
        centre: Vec3::zeros(),
        radius,
    };
    let rotation = UnitQuat::from_axis_angle(&Vec3::z_axis(), -tilt);
    let mut x: Vec<Vec3> = model
        .rest_positions()
        .iter()
        .map(|p| rotation * (p + Vec3::new(0.0, radius + 0.0015, 0.0)))
        .collect();
    let centre = columns * columns / 2;
    let start = x[centre];
    let settings = DrapeSettings {
        friction,
        ..DrapeSettings::default()
    };
    let mut solver = DrapeSolver::new(&model, &settings).unwrap();
    let stats = solver.drape(&mut x, &sphere, &[]).unwrap();
    ((x[centre] - start).norm(), stats)
}

#[test]
fn friction_holds_cloth_on_a_slope_below_its_angle_and_lets_it_slide_above() {
    // On a slope of 20 degrees (tan = 0.36) Coulomb friction holds cloth when mu > 0.36.
    let tilt = (20.0 as Real).to_radians();
    let (held, stats) = slide_on_tilted_sphere(tilt, 0.6);
    assert!(stats.converged, "{stats:?}");
    assert!(held < 2e-3, "the sheet crept {held} m with mu = 0.6");
    // At equilibrium the body carries the weight: normal force plus friction.
    let weight = 0.02 * 0.02 * 36.0 * DENSITY * 9.81;
    assert!(
        (stats.contact_force.y - weight).abs() < 0.02 * weight,
        "{:?} vs {weight}",
        stats.contact_force
    );
    for slippery in [0.0, 0.1] {
        let (slid, stats) = slide_on_tilted_sphere(tilt, slippery);
        assert!(
            slid > 0.05,
            "mu = {slippery}: slid only {slid} m ({stats:?})"
        );
    }
}

#[test]
fn friction_anchors_carry_cloth_with_a_moving_body() {
    // A sheet at rest on a sphere, with friction; then the sphere moves 4 mm sideways.
    let (model, mut x, sphere) = sheet_on_sphere(11, DENSITY, MID);
    let settings = DrapeSettings {
        friction: 0.6,
        ..DrapeSettings::default()
    };
    let mut solver = DrapeSolver::new(&model, &settings).unwrap();
    assert!(solver.drape(&mut x, &sphere, &[]).unwrap().converged);
    let shift = Vec3::new(0.004, 0.0, 0.0);
    let moved = Sphere {
        centre: sphere.centre + shift,
        ..sphere
    };
    // Anchored to the moving body, the sheet rides along: the same drape, shifted.
    let carried: Vec<Vec3> = x.iter().map(|p| p + shift).collect();
    let mut riding = carried.clone();
    let stats = solver
        .drape_with_anchors(&mut riding, &carried, &moved, &[])
        .unwrap();
    assert!(stats.converged, "{stats:?}");
    let off = riding
        .iter()
        .zip(&carried)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, Real::max);
    assert!(
        off < 1e-4,
        "the riding sheet moved {off} m off the body's motion"
    );
    // Anchored where it was (a body taken to be still), friction holds the contact
    // vertices back against the body's motion, and the drape is a different one.
    let mut held = carried.clone();
    solver
        .drape_with_anchors(&mut held, &x, &moved, &[])
        .unwrap();
    let apart = held
        .iter()
        .zip(&riding)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, Real::max);
    assert!(apart > 1e-3, "anchors made no difference ({apart} m)");
    // Wrong-sized or non-finite anchors are typed errors.
    assert!(matches!(
        solver
            .drape_with_anchors(&mut held, &x[..5], &moved, &[])
            .unwrap_err(),
        Error::Core(CoreError::WrongLength { .. })
    ));
    let mut bad = x.clone();
    bad[2].z = Real::INFINITY;
    assert!(matches!(
        solver
            .drape_with_anchors(&mut held, &bad, &moved, &[])
            .unwrap_err(),
        Error::Core(CoreError::NonFinite { .. })
    ));
}
