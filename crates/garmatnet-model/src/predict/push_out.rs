//! Body push-out: a post-process that moves garment vertices that ended up inside the posed
//! body (or closer than a clearance ε) out along the body's distance gradient.

use garmatnet_core::{Real, SignedDistance, Vec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Push-out settings. On by default with ε = 2 mm, at the vertices.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PushOut {
    /// Whether the predictor applies it.
    pub enabled: bool,
    /// The clearance ε (metres): vertices closer to the body than this are moved to it.
    pub epsilon: Real,
    /// Whether the triangles are then pushed out between their vertices too
    /// ([`garmatnet_core::push_mesh_outside`], as ground-truth revision 4 records every
    /// drape): where the body is convex a triangle between pushed-out vertices can still cut
    /// under it (the shipped model's predictions at the everyday suite: up to 11 mm at
    /// arms-crossed; with it at most 0.6 mm). Off by default: it makes a prediction about five
    /// and a half times slower (17.6–18.3 ms against 3.2–3.3 at default resolution,
    /// `examples/prediction_depth.rs`).
    /// Settings saved without it read as off.
    #[serde(default)]
    pub faces: bool,
}

/// The largest clearance [`PushOut::validate`] accepts (metres): 5 cm, beyond any garment's
/// gap to the body; larger values would move a whole sleeve off the arm.
pub const MAX_PUSH_OUT_EPSILON: Real = 0.05;

impl PushOut {
    /// Checks the clearance: finite, from 0 to [`MAX_PUSH_OUT_EPSILON`] (a NaN or negative ε
    /// would move vertices without a reason, a metre-scale one would move the garment away).
    ///
    /// # Errors
    /// [`garmatnet_core::Error::OutOfRange`] naming ε and its range.
    pub fn validate(&self) -> garmatnet_core::Result<()> {
        if (0.0..=MAX_PUSH_OUT_EPSILON).contains(&self.epsilon) {
            Ok(())
        } else {
            Err(garmatnet_core::Error::OutOfRange {
                what: "push-out clearance epsilon (metres)".into(),
                value: self.epsilon,
                min: 0.0,
                max: MAX_PUSH_OUT_EPSILON,
                hint: String::new(),
            })
        }
    }
}

impl Default for PushOut {
    fn default() -> Self {
        Self {
            enabled: true,
            epsilon: 0.002,
            faces: false,
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

/// Below this many vertices push-out runs on the calling thread; above, on rayon's pool
/// (each vertex is independent, so the result is the same either way).
const PARALLEL_MIN_VERTICES: usize = 512;

/// Moves every vertex with signed distance below `epsilon` along the gradient until it is
/// `epsilon` outside `body`. Garment-sized inputs are processed in parallel; the result does
/// not depend on the thread count.
#[must_use]
pub fn push_out(
    vertices: &mut [Vec3],
    body: &(dyn SignedDistance + Sync),
    epsilon: Real,
) -> PushOutReport {
    let one = |v: &mut Vec3| {
        let start = *v;
        *v = body.push_outside(v, epsilon);
        let moved = (*v - start).norm();
        PushOutReport {
            moved: usize::from(moved > 0.0),
            max_move: moved,
        }
    };
    let merge = |a: PushOutReport, b: PushOutReport| PushOutReport {
        moved: a.moved + b.moved,
        max_move: a.max_move.max(b.max_move),
    };
    if vertices.len() < PARALLEL_MIN_VERTICES {
        vertices
            .iter_mut()
            .map(one)
            .fold(PushOutReport::default(), merge)
    } else {
        vertices
            .par_iter_mut()
            .map(one)
            .reduce(PushOutReport::default, merge)
    }
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

    #[test]
    fn the_parallel_path_moves_exactly_what_the_serial_one_does() {
        let s = Sphere {
            centre: Vec3::zeros(),
            radius: 0.3,
        };
        let mut rng = garmatnet_core::SplitMix64::new(4);
        let pts: Vec<Vec3> = (0..3 * PARALLEL_MIN_VERTICES)
            .map(|_| {
                Vec3::new(
                    rng.uniform(-0.5, 0.5),
                    rng.uniform(-0.5, 0.5),
                    rng.uniform(-0.5, 0.5),
                )
            })
            .collect();
        let mut parallel = pts.clone();
        let report = push_out(&mut parallel, &s, 0.002);
        let mut serial = Vec::new();
        let mut moved = 0;
        for chunk in pts.chunks(PARALLEL_MIN_VERTICES - 1) {
            let mut c = chunk.to_vec();
            moved += push_out(&mut c, &s, 0.002).moved;
            serial.extend(c);
        }
        assert_eq!(parallel, serial);
        assert_eq!(report.moved, moved);
        assert!(moved > 0 && moved < pts.len());
    }
}
