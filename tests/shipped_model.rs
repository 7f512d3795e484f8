//! The model that ships in `crates/garmatnet-model/models/`: it loads with no files to fetch,
//! fits the library's T-shirt, answers for any fabric, survives random valid inputs, and
//! drapes a symmetric pose symmetrically.

use garmatnet::core::{SignedDistance, deepest_point_inside};
use garmatnet::model::{SHIPPED_MODEL, select_device};
use garmatnet::train::stress_predictor;
use garmatnet::{Detail, Material, Predictor};

fn shipped() -> anyhow::Result<Predictor> {
    // The shipped file itself, whatever $GARMATNET_MODEL says.
    Ok(Predictor::from_file(SHIPPED_MODEL, &select_device("cpu")?)?)
}

#[test]
fn the_shipped_model_drapes_contrasting_fabrics_differently_and_near_the_body() -> anyhow::Result<()>
{
    let predictor = shipped()?;
    let body = predictor.body().expect("from_file keeps the body").clone();
    let frames = garmatnet::sim::MotionGenerator::new(0, 240).generate();
    for pose in [&frames[20], &frames[170]] {
        let posed = body.pose(pose);
        let mut shirts = Vec::new();
        for name in ["Silk Chiffon", "Denim Heavy", "Trim Fusible Rigid"] {
            let mesh = predictor.predict(pose, &Material::preset(name)?, Detail::Full)?;
            let far = mesh
                .vertices
                .iter()
                .map(|v| posed.distance(v))
                .fold(0.0, f64::max);
            let inside = mesh
                .vertices
                .iter()
                .filter(|v| posed.distance(v) < 0.0)
                .count();
            assert!(far < 0.3, "{name}: a vertex {far} m from the body");
            assert_eq!(
                inside, 0,
                "{name}: {inside} vertices inside the body after push-out"
            );
            shirts.push(mesh.vertices);
        }
        let mean_gap = |a: &[garmatnet::core::Vec3], b: &[garmatnet::core::Vec3]| {
            a.iter().zip(b).map(|(p, q)| (p - q).norm()).sum::<f64>() / a.len() as f64
        };
        assert!(
            mean_gap(&shirts[0], &shirts[2]) > 0.003,
            "silk and rigid trim should drape visibly differently"
        );
    }
    Ok(())
}

#[test]
fn the_shipped_model_stays_finite_and_near_the_body_on_random_inputs() -> anyhow::Result<()> {
    // `garmatnet stress --count 10000` runs the same check at full size.
    let report = stress_predictor(&shipped()?, 500, 11, 50)?;
    assert!(report.passed(), "{report:?}");
    Ok(())
}

#[test]
fn the_shipped_model_fits_the_default_fitted_shirt_and_trained_on_every_preset()
-> anyhow::Result<()> {
    // The default garment (the fitted T-shirt at default resolution) is the one it predicts.
    let device = select_device("cpu")?;
    let model = garmatnet::model::GarMatNetModel::load(SHIPPED_MODEL, &device)?;
    let body = garmatnet::core::CapsuleBody::smpl_neutral();
    let fitted = garmatnet::core::Garment::tshirt(garmatnet::core::Resolution::Default, &body)?;
    assert_eq!(
        model.meta.template,
        garmatnet::core::TemplateInfo::of(&fitted)
    );
    // Trained on every one of the 30 presets, with the solver's energy beside the labels ...
    let provenance = &model.meta.provenance;
    assert_eq!(provenance.training_fabrics.len(), 30);
    assert_eq!(
        provenance.extra["train_config"]["physics"]["weight"].as_f64(),
        Some(0.001)
    );
    // ... and with each training sample's mirror image (`train --mirrored-samples`).
    assert_eq!(
        provenance.extra["train_config"]["mirrored_samples"].as_bool(),
        Some(true)
    );
    Ok(())
}

#[test]
fn the_shipped_model_drapes_a_symmetric_pose_symmetrically() -> anyhow::Result<()> {
    use garmatnet::core::{CapsuleBody, Garment, Pose, Resolution, Vec3};
    let garment = Garment::tshirt(Resolution::Default, &CapsuleBody::smpl_neutral())?;
    let map = garmatnet::sim::MirrorMap::from_twins(garment.mirror_twins())?;
    // Mean over vertices of |x_i - mirror(x_twin(i))| (metres).
    let asymmetry = |v: &[Vec3]| map.asymmetry(v);
    let pose = Pose::a_pose();
    assert_eq!(pose.mirrored(), pose);
    let averaged = shipped()?;
    assert!(averaged.mirror_averaging(), "on by default");
    let raw = shipped()?.with_mirror_averaging(false)?;
    for name in ["Cashmere", "Denim Heavy"] {
        let fabric = Material::preset(name)?;
        let a = asymmetry(&averaged.predict(&pose, &fabric, Detail::Full)?.vertices)?;
        let r = asymmetry(&raw.predict(&pose, &fabric, Detail::Full)?.vertices)?;
        // Measured: averaged 0.01 mm, raw 4.84 (Cashmere) and 3.81 mm (Denim Heavy); the
        // truth at the everyday suite's symmetric poses: 0.56 mm on average.
        assert!(
            a < 0.5e-3,
            "{name}: averaged garment {a} m from its mirror image"
        );
        // A tripwire, not a requirement: it shows the check above can fail. A retrained model
        // whose own nets are symmetric trips it; then drop it.
        assert!(
            r > 2e-3,
            "{name}: the shipped nets alone were measured lopsided, now {r} m: retrained?"
        );
    }
    Ok(())
}

/// Push-out acts at the vertices, and at arms-crossed the shipped model's Trim Fusible Rigid
/// still cuts under the forearm between them (14.07 mm measured); with `PushOut::faces` no
/// point of its triangles is left more than 1 mm inside.
#[test]
fn pushing_the_faces_out_clears_the_predicted_triangles_from_the_body() -> anyhow::Result<()> {
    let plain = shipped()?;
    let faces = shipped()?.with_push_out(garmatnet::model::PushOut {
        faces: true,
        ..Default::default()
    })?;
    let body = plain.body().expect("from_file keeps the body").clone();
    let pose = garmatnet::sim::everyday_pose("arms-crossed")?;
    let posed = body.pose(&pose);
    let fabric = Material::preset("Trim Fusible Rigid")?;
    let deepest = |p: &Predictor| -> anyhow::Result<f64> {
        let mesh = p.predict(&pose, &fabric, Detail::Full)?;
        Ok(deepest_point_inside(&mesh.vertices, &mesh.faces, &posed, 8))
    };
    let (before, after) = (deepest(&plain)?, deepest(&faces)?);
    assert!(before > 0.005, "vertex push-out alone left {before} m");
    assert!(after <= 1e-3, "{after} m deep between the vertices");
    Ok(())
}
