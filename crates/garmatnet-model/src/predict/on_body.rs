//! A predicted garment placed on its body: [`Predictor::predict_on_body`], and the push-out
//! every prediction of a predictor that knows its body goes through.

use garmatnet_core::{Pose, Real, SignedDistance, Vec3, push_mesh_outside};

use crate::error::Result;
use crate::net::garmatnet_net::MATERIAL_DIM;
use crate::predict::predictor::{Detail, GarmentMesh, Predictor};
use crate::predict::push_out::{PushOutReport, push_out};

impl Predictor {
    /// `meshes`, each pushed out of the body posed at its pose in `poses`, when the
    /// predictor knows the body and push-out is enabled.
    pub(crate) fn pushed_out(
        &self,
        mut meshes: Vec<GarmentMesh>,
        poses: &[Pose],
    ) -> Vec<GarmentMesh> {
        for (mesh, pose) in meshes.iter_mut().zip(poses) {
            self.push_out_vertices(&mut mesh.vertices, pose);
        }
        meshes
    }

    /// Pushes `vertices` (any of the garment's, in any order) out of the body posed at
    /// `pose`, when the predictor knows the body and push-out is enabled.
    pub(crate) fn push_out_vertices(&self, vertices: &mut [Vec3], pose: &Pose) {
        if let Some(body) = self.body().filter(|_| self.push_out_settings().enabled) {
            // As in `predict`, the report is dropped: `predict_on_body` returns it.
            let _ = self.push_out_mesh(vertices, &body.pose(pose));
        }
    }

    /// Push-out of a predicted garment as [`Predictor::with_push_out`] set it: every vertex
    /// to its clearance, then, with [`PushOut::faces`], the triangles between them
    /// ([`push_mesh_outside`]). The report counts both.
    ///
    /// [`PushOut::faces`]: crate::PushOut::faces
    fn push_out_mesh(
        &self,
        vertices: &mut [Vec3],
        body: &(dyn SignedDistance + Sync),
    ) -> PushOutReport {
        let settings = self.push_out_settings();
        if !settings.faces {
            return push_out(vertices, body, settings.epsilon);
        }
        let start = vertices.to_vec();
        let _ = push_out(vertices, body, settings.epsilon);
        push_mesh_outside(vertices, self.faces(), body, &[]);
        start
            .iter()
            .zip(vertices.iter())
            .map(|(a, b)| (b - a).norm())
            .fold(PushOutReport::default(), |r, d| PushOutReport {
                moved: r.moved + usize::from(d > 0.0),
                max_move: r.max_move.max(d),
            })
    }

    /// Predicts the garment and pushes it out of the posed `body` (when push-out is enabled;
    /// see [`Predictor::with_push_out`]).
    ///
    /// # Errors
    /// As [`Predictor::predict_normalized`].
    pub fn predict_on_body(
        &self,
        pose: &Pose,
        material: &[Real; MATERIAL_DIM],
        detail: Detail,
        body: &(dyn SignedDistance + Sync),
    ) -> Result<(GarmentMesh, PushOutReport)> {
        let mut mesh = self.predict_normalized(pose, material, detail)?;
        let report = if self.push_out_settings().enabled {
            self.push_out_mesh(&mut mesh.vertices, body)
        } else {
            PushOutReport::default()
        };
        Ok((mesh, report))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::predict::push_out::PushOut;
    use crate::test_util::small_predictor as predictor;
    use garmatnet_core::{DisplacementFrame, Sphere};

    #[test]
    fn push_out_on_body_moves_vertices_out_of_a_sphere() {
        let p = predictor(7, DisplacementFrame::World);
        let pose = Pose::zero();
        let m = [0.5; 6];
        let plain = p.predict_normalized(&pose, &m, Detail::Full).unwrap();
        let centre = plain.vertices[0];
        let sphere = Sphere {
            centre,
            radius: 0.1,
        };
        let inside = plain
            .vertices
            .iter()
            .filter(|v| sphere.distance(v) < 0.002)
            .count();
        assert!(inside > 0);
        let (mesh, report) = p.predict_on_body(&pose, &m, Detail::Full, &sphere).unwrap();
        assert_eq!(report.moved, inside);
        assert!(
            mesh.vertices
                .iter()
                .all(|v| sphere.distance(v) >= 0.002 - 1e-9)
        );
        for epsilon in [Real::NAN, -0.001, 1.0] {
            let refused = predictor(7, DisplacementFrame::World)
                .with_push_out(PushOut {
                    enabled: true,
                    epsilon,
                    faces: false,
                })
                .unwrap_err();
            assert!(refused.to_string().contains("epsilon"), "{refused}");
        }
        let off = predictor(7, DisplacementFrame::World)
            .with_push_out(PushOut {
                enabled: false,
                ..PushOut::default()
            })
            .unwrap();
        assert_eq!(p.push_out_settings(), PushOut::default());
        assert!(!off.push_out_settings().enabled);
        let (mesh, report) = off
            .predict_on_body(&pose, &m, Detail::Full, &sphere)
            .unwrap();
        assert_eq!(report.moved, 0);
        assert_eq!(mesh, plain);
    }
}
