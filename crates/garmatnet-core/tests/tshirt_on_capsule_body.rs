//! The T-shirt template against the real capsule body (the garment's unit tests use a
//! stand-in body so the two could be developed apart; this pins that they fit together).

use garmatnet_core::{CapsuleBody, Garment, Resolution, SignedDistance, SkinnedBody};

#[test]
fn every_resolution_sits_outside_the_body_with_ease() -> anyhow::Result<()> {
    let body = CapsuleBody::smpl_neutral();
    for resolution in Resolution::ALL {
        let shirt = Garment::tshirt(resolution, &body)?;
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
        // Anchors lie on the body surface and are skinned to real joints.
        for a in &shirt.anchors {
            assert!(body.distance(&a.rest_point).abs() < 2e-3);
            let sum: f64 = a.weights.iter().map(|w| w.1).sum();
            assert!((sum - 1.0).abs() < 1e-9);
        }
        assert_eq!(body.skeleton().rest_joints().len(), 24);
    }
    Ok(())
}
