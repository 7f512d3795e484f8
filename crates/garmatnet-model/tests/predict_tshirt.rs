//! The typed prediction path on the real T-shirt and capsule body: template checks, material
//! validation, push-out and finiteness, with an untrained model (the weights do not matter for
//! these guarantees; the trained model's accuracy is measured by `garmatnet eval`).

use burn::prelude::Device;
use garmatnet_core::{
    CapsuleBody, Garment, JointLimits, Material, Pose, Resolution, SignedDistance, SplitMix64,
    TemplateInfo, presets,
};
use garmatnet_model::{
    Detail, Error, GarMatNetConfig, GarMatNetModel, OutputNormalizer, Predictor,
};

fn coarse() -> (Garment, CapsuleBody) {
    let body = CapsuleBody::smpl_neutral();
    (Garment::tshirt(Resolution::Coarse, &body).unwrap(), body)
}

/// An untrained model whose fitting output is scaled to a few centimetres, so predicted
/// garments lie around the body like real ones (and some vertices land inside it).
fn model_for(garment: &Garment, dev: &Device) -> GarMatNetModel {
    dev.seed(7);
    let n = garment.vertex_count();
    let cfg = GarMatNetConfig::new(n, 32, 16, 32);
    let mut model = GarMatNetModel::untrained(&cfg, TemplateInfo::of(garment), dev);
    model.fitting_norm = OutputNormalizer::from_parts(vec![0.0; 3 * n], vec![0.02; 3 * n]).unwrap();
    model.local_norm = OutputNormalizer::from_parts(vec![0.0; 3 * n], vec![0.003; 3 * n]).unwrap();
    model
}

#[test]
fn predictions_are_finite_near_the_body_and_pushed_out() -> anyhow::Result<()> {
    let dev = Device::flex();
    let (garment, body) = coarse();
    let predictor =
        Predictor::for_garment(model_for(&garment, &dev), &garment, body.clone(), &dev)?;
    let limits = JointLimits::default();
    let mut rng = SplitMix64::new(3);
    for k in 0..20 {
        let pose = limits.sample(&mut rng, 1.0);
        let material = presets()[k % presets().len()].material;
        let mesh = predictor.predict(&pose, &material, Detail::Full)?;
        assert_eq!(mesh.vertices.len(), garment.vertex_count());
        let posed = body.pose(&pose);
        for v in &mesh.vertices {
            assert!(v.iter().all(|c| c.is_finite()));
            let d = posed.distance(v);
            assert!(
                d >= 0.002 - 1e-9,
                "push-out leaves every vertex at least its 2 mm clearance out (got {d})"
            );
            assert!(
                d < 1.0,
                "no vertex farther than 1 m from the body (got {d})"
            );
        }
    }
    Ok(())
}

#[test]
fn smooth_detail_is_the_fitting_net_alone() -> anyhow::Result<()> {
    let dev = Device::flex();
    let (garment, body) = coarse();
    let model = model_for(&garment, &dev);
    let predictor = Predictor::for_garment(model, &garment, body, &dev)?.with_push_out(
        garmatnet_model::PushOut {
            enabled: false,
            ..Default::default()
        },
    )?;
    let material = Material::preset("denim heavy")?;
    let pose = Pose::zero();
    let full = predictor.predict(&pose, &material, Detail::Full)?;
    let smooth = predictor.predict(&pose, &material, Detail::Smooth)?;
    let normalized =
        predictor.predict_normalized(&pose, &material.to_normalized(), Detail::Smooth)?;
    assert_eq!(smooth.vertices, normalized.vertices);
    assert!(
        full.vertices
            .iter()
            .zip(&smooth.vertices)
            .any(|(a, b)| (a - b).norm() > 1e-6)
    );
    Ok(())
}

#[test]
fn wrong_templates_and_bad_materials_are_refused() -> anyhow::Result<()> {
    let dev = Device::flex();
    let (garment, body) = coarse();
    let other = Garment::tshirt(Resolution::Default, &body)?;
    let model = model_for(&garment, &dev);
    match Predictor::for_garment(model.clone(), &other, body.clone(), &dev) {
        Err(Error::TemplateMismatch { .. }) => {}
        other => panic!("expected a template mismatch, got {other:?}"),
    }
    let predictor = Predictor::for_garment(model, &garment, body, &dev)?;
    let mut material = Material::preset("cotton poplin")?;
    material.shear = 1e9;
    let err = predictor
        .predict(&Pose::zero(), &material, Detail::Full)
        .unwrap_err();
    assert!(
        err.to_string().contains("shear"),
        "the error names the component: {err}"
    );
    material.shear = f64::NAN;
    assert!(
        predictor
            .predict(&Pose::zero(), &material, Detail::Full)
            .is_err()
    );
    Ok(())
}
