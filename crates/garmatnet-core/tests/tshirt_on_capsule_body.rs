//! The T-shirt template against the real capsule body (the garment's unit tests use a
//! stand-in body so the two could be developed apart; this pins that they fit together).

use garmatnet_core::{CapsuleBody, Garment, GarmentStyle, Resolution, SignedDistance, SkinnedBody};

#[test]
fn every_resolution_sits_outside_the_body_with_ease() -> anyhow::Result<()> {
    let rest_body = CapsuleBody::smpl_neutral();
    for (style, resolution) in GarmentStyle::ALL
        .into_iter()
        .flat_map(|g| Resolution::ALL.map(|r| (g, r)))
    {
        let shirt = Garment::with_style(style, resolution, &rest_body)?;
        // The shirt fits the body in its rest pose (the A-pose for the fitted cut).
        let body = rest_body.pose(&shirt.rest_pose);
        let clearance = shirt
            .rest
            .vertices
            .iter()
            .map(|v| body.distance(v))
            .fold(f64::MAX, f64::min);
        assert!(
            clearance > 0.005,
            "{resolution}: closest vertex {clearance} m from the body"
        );
        // Ease is sensible: no vertex floats more than 12 cm off the body.
        let farthest = shirt
            .rest
            .vertices
            .iter()
            .map(|v| body.distance(v))
            .fold(0.0, f64::max);
        assert!(
            farthest < 0.12,
            "{resolution}: a vertex is {farthest} m off the body"
        );
        // Anchors, carried to the rest pose, lie on the body surface and are skinned to real
        // joints.
        let transforms = rest_body.skeleton().skinning_transforms(&shirt.rest_pose);
        for (a, p) in shirt.anchors.iter().zip(shirt.body_points(&transforms)) {
            assert!(body.distance(&p).abs() < 2e-3, "{style} {resolution}");
            let sum: f64 = a.weights.iter().map(|w| w.1).sum();
            assert!((sum - 1.0).abs() < 1e-9);
        }
        assert_eq!(rest_body.skeleton().rest_joints().len(), 24);
    }
    Ok(())
}
