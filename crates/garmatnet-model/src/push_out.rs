//! Body push-out: a post-process that moves garment vertices that ended up inside the posed
//! body (or closer than a clearance ε) out along the body's distance gradient.

use garmatnet_core::{Real, SignedDistance, Vec3};
use serde::{Deserialize, Serialize};

/// Push-out settings. On by default with ε = 2 mm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PushOut {
    /// Whether the predictor applies it.
    pub enabled: bool,
    /// The clearance ε (metres): vertices closer to the body than this are moved to it.
    pub epsilon: Real,
}

impl Default for PushOut {
    fn default() -> Self {
        Self {
            enabled: true,
            epsilon: 0.002,
        }
    }
}

/// What a push-out did.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PushOutReport {
    /// How many vertices were moved.
    pub moved: usize,
    /// The largest distance a vertex was moved (metres).
    pub max_move: Real,
}

/// Moves every vertex with signed distance below `epsilon` along the gradient until it is
/// `epsilon` outside `body`.
#[must_use]
pub fn push_out(vertices: &mut [Vec3], body: &dyn SignedDistance, epsilon: Real) -> PushOutReport {
    let mut report = PushOutReport::default();
    for v in vertices.iter_mut() {
        let start = *v;
        *v = body.push_outside(v, epsilon);
        let moved = (*v - start).norm();
        if moved > 0.0 {
            report.moved += 1;
            report.max_move = report.max_move.max(moved);
        }
    }
    report
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use garmatnet_core::Sphere;

    #[test]
    fn points_inside_or_too_close_move_to_the_clearance_and_others_stay() {
        let s = Sphere {
            centre: Vec3::new(0.0, 1.0, 0.0),
            radius: 0.2,
        };
        let mut pts = vec![
            Vec3::new(0.0, 1.1, 0.0),   // inside
            Vec3::new(0.201, 1.0, 0.0), // outside but within 2 mm
            Vec3::new(0.0, 1.0, 0.5),   // far outside
        ];
        let far = pts[2];
        let report = push_out(&mut pts, &s, 0.002);
        assert_eq!(report.moved, 2);
        assert_relative_eq!(report.max_move, 0.202 - 0.1, epsilon = 1e-12);
        assert_relative_eq!(s.distance(&pts[0]), 0.002, epsilon = 1e-12);
        assert_relative_eq!(s.distance(&pts[1]), 0.002, epsilon = 1e-12);
        assert_relative_eq!(pts[0], Vec3::new(0.0, 1.202, 0.0), epsilon = 1e-12);
        assert_eq!(pts[2], far);
        assert_eq!(
            push_out(&mut pts, &s, 0.002).moved,
            0,
            "a second pass finds nothing"
        );
    }
}
