//! Pushing a triangle mesh out of a body between its vertices as well as at them.
//!
//! A mesh whose vertices all lie outside a body can still cut under it between them: where
//! the surface is convex (an arm pressed onto cloth from the other side) the body's ridge
//! pokes through a triangle by about `L² / 8R` for an edge `L` over a radius `R`, 4 mm for a
//! 3.5 cm edge over a forearm. [`push_mesh_outside`] moves vertices so that the corners and a
//! grid of points across every triangle end outside.

use crate::body::sdf::{INSIDE_SLACK, SignedDistance, push_step, unit_normal};
use crate::math::{Real, Vec3};

/// How finely [`push_mesh_outside`] samples each triangle: at the points whose barycentric
/// coordinates are multiples of `1 / FACE_DIVISIONS` (the corners are pushed as vertices),
/// and at the centroid ([`triangle_samples`]). With 4, twelve points and the centroid:
/// between them a convex body part of radius `R` can cut under a triangle with edges `L`
/// by about `(L/4)² / 8R`, 0.36 mm for a 4 cm edge over a 3.5 cm forearm.
pub const FACE_DIVISIONS: u8 = 4;

/// The barycentric weights of the points of a triangle whose coordinates are multiples of
/// `1 / divisions`, the corners left out, followed by the centroid: the points
/// [`push_mesh_outside`] keeps outside (with [`FACE_DIVISIONS`]), and a finer grid to check
/// between them. `divisions` 0 or 1 gives the centroid alone.
#[must_use]
pub fn triangle_samples(divisions: u8) -> Vec<[Real; 3]> {
    let n = divisions;
    let mut weights: Vec<[Real; 3]> = (0..=n)
        .flat_map(|i| (0..=n - i).map(move |j| [i, j, n - i - j]))
        .filter(|w| n > 1 && !w.contains(&n))
        .map(|w| w.map(|k| Real::from(k) / Real::from(n)))
        .collect();
    weights.push([1.0 / 3.0; 3]);
    weights
}

/// How deep (metres, ≥ 0) the deepest point of a triangle mesh lies inside `body`, taken at
/// every vertex and at [`triangle_samples`]`(divisions)` across every triangle: how
/// [`push_mesh_outside`]'s result is checked, on a finer grid than it pushes. Faces with an
/// index past the vertices are skipped.
#[must_use]
pub fn deepest_point_inside(
    positions: &[Vec3],
    faces: &[[u32; 3]],
    body: &(impl SignedDistance + ?Sized),
    divisions: u8,
) -> Real {
    let weights = triangle_samples(divisions);
    let between = faces
        .iter()
        .filter_map(|f| {
            let corners = f.map(|i| positions.get(i as usize).copied());
            Some([corners[0]?, corners[1]?, corners[2]?])
        })
        .flat_map(|[a, b, c]| weights.iter().map(move |w| a * w[0] + b * w[1] + c * w[2]));
    positions
        .iter()
        .copied()
        .chain(between)
        .map(|p| -body.distance(&p))
        .fold(0.0, Real::max)
}

/// The most rounds of [`push_mesh_outside`]. A ridge through a triangle's middle is cleared
/// in one round (to first order in the surface's curvature) and the next cleans up the
/// curvature's remainder; more are needed only where a push out of one body part reaches
/// another.
pub const MESH_PUSH_ROUNDS: usize = 32;

/// What [`push_mesh_outside`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct MeshPush {
    /// The deepest free vertex, or sample point of a triangle with a free corner of positive
    /// weight there, left inside the body afterwards (metres, ≥ 0).
    pub deepest: Real,
    /// The deepest of those points before the push (metres, ≥ 0).
    pub deepest_before: Real,
    /// Rounds taken (0 when nothing was inside).
    pub rounds: usize,
    /// Vertices moved at least once.
    pub moved: usize,
}

/// Moves the free vertices of a triangle mesh (`fixed[i]` false) until each vertex and each
/// triangle's sample points ([`FACE_DIVISIONS`]) lie outside `body`, and returns how deep the
/// deepest of them is left.
///
/// The first round evaluates the distance at every such point that can be inside (a triangle
/// whose corners are all farther out than its longest edge is skipped: a distance field
/// changes by at most one metre per metre); each later round only at the vertices moved in
/// the round before and across the triangles with a moved corner, which gives the same
/// result as evaluating everything again. A point at depth `d` with outward normal `n` asks
/// each free corner `i` of its triangle with barycentric weight `bᵢ` to move by
/// `bᵢ s / Σⱼ bⱼ²` along `n`, the smallest move of the corners that carries the point `s`
/// out, where `s` is the depth divided by the field's gradient length and capped at the
/// depth plus [`crate::PUSH_SLACK`] as in [`SignedDistance::push_outside`]. A vertex inside the body
/// asks for its own push. Each vertex takes the largest move asked of it in the round (two of
/// exactly equal length averaged), so the result does not depend on the order of the faces.
/// A point where the field's gradient is not finite asks for nothing. Rounds repeat until nothing is inside
/// or [`MESH_PUSH_ROUNDS`] have run. Fixed vertices never move; a point whose weighted
/// corners are all fixed is left where it is and not counted. A face with an index past the
/// vertices is skipped, and `fixed` shorter than `positions` leaves the rest free.
pub fn push_mesh_outside(
    positions: &mut [Vec3],
    faces: &[[u32; 3]],
    body: &(impl SignedDistance + ?Sized),
    fixed: &[bool],
) -> MeshPush {
    push_rounds(positions, faces, body, fixed, false)
}

/// [`push_mesh_outside`]'s rounds. The first evaluates every vertex and every triangle that
/// can reach into the body; each later one only the vertices moved in the round before and
/// the triangles with a moved corner (`recompute_all` evaluates everything every round, for
/// the test that both agree bit for bit). That skips nothing that matters: a point whose
/// triangle did not move is where it was, and one that was inside then asked its free
/// corners to move unless its gradient was not finite, in which case it asks nothing again
/// and only its depth, kept from when it was evaluated, counts.
fn push_rounds(
    positions: &mut [Vec3],
    faces: &[[u32; 3]],
    body: &(impl SignedDistance + ?Sized),
    fixed: &[bool],
    recompute_all: bool,
) -> MeshPush {
    let n = positions.len();
    let is_free = |i: usize| !fixed.get(i).copied().unwrap_or(false);
    let faces: Vec<[usize; 3]> = faces
        .iter()
        .map(|f| f.map(|i| i as usize))
        .filter(|f| f.iter().all(|&i| i < n))
        .collect();
    let mut report = MeshPush::default();
    let samples = triangle_samples(FACE_DIVISIONS);
    let mut moved = vec![false; n];
    // Whether a vertex was asked to move in the last round (every vertex before the first).
    let mut stale = vec![true; n];
    let mut vertex_distance = vec![0.0; n];
    // The depth of the deepest counted point of each vertex and triangle at its last
    // evaluation (0 outside).
    let mut vertex_depth: Vec<Real> = vec![0.0; n];
    let mut face_depth: Vec<Real> = vec![0.0; faces.len()];
    // The move each vertex is asked for this round: the largest one.
    let mut asked: Vec<Option<Vec3>> = vec![None; n];
    for round in 0..=MESH_PUSH_ROUNDS {
        for (i, x) in positions.iter().enumerate() {
            if !(recompute_all || stale[i]) {
                continue;
            }
            let (d, g) = body.distance_and_gradient(x);
            vertex_distance[i] = d;
            vertex_depth[i] = 0.0;
            if d < -INSIDE_SLACK && is_free(i) {
                vertex_depth[i] = -d;
                if finite(&g) {
                    ask(&mut asked, i, unit_normal(&g) * push_step(-d, &g));
                }
            }
        }
        for (f, depth) in faces.iter().zip(face_depth.iter_mut()) {
            if recompute_all || f.iter().any(|&i| stale[i]) {
                *depth = face_round(
                    f,
                    positions,
                    &vertex_distance,
                    body,
                    &samples,
                    &is_free,
                    &mut asked,
                );
            }
        }
        let deepest = vertex_depth
            .iter()
            .chain(&face_depth)
            .copied()
            .fold(0.0, Real::max);
        if round == 0 {
            report.deepest_before = deepest;
        }
        report.deepest = deepest;
        if deepest == 0.0 || round == MESH_PUSH_ROUNDS {
            break;
        }
        report.rounds = round + 1;
        for (i, a) in asked.iter_mut().enumerate() {
            stale[i] = a.is_some();
            if let Some(m) = a.take() {
                positions[i] += m;
                moved[i] = true;
            }
        }
    }
    report.moved = moved.iter().filter(|m| **m).count();
    report
}

/// One round of a triangle `f`: its sample points' moves asked of its corners ([`ask`], in
/// sample order), and the depth of its deepest counted sample point (0 when none is inside).
fn face_round(
    f: &[usize; 3],
    positions: &[Vec3],
    vertex_distance: &[Real],
    body: &(impl SignedDistance + ?Sized),
    samples: &[[Real; 3]],
    is_free: &impl Fn(usize) -> bool,
    asked: &mut [Option<Vec3>],
) -> Real {
    let mut depth: Real = 0.0;
    let corners = f.map(|i| positions[i]);
    let longest = (0..3)
        .map(|k| (corners[k] - corners[(k + 1) % 3]).norm())
        .fold(0.0, Real::max);
    let nearest = f
        .iter()
        .map(|&i| vertex_distance[i])
        .fold(Real::MAX, Real::min);
    if nearest - longest > 0.0 {
        return depth;
    }
    let free = f.map(is_free);
    for w in samples {
        let p = corners[0] * w[0] + corners[1] * w[1] + corners[2] * w[2];
        let (d, g) = body.distance_and_gradient(&p);
        if d.is_nan() || d >= -INSIDE_SLACK {
            continue;
        }
        let norm: Real = (0..3).filter(|&k| free[k]).map(|k| w[k] * w[k]).sum();
        if norm == 0.0 {
            continue;
        }
        depth = depth.max(-d);
        if !finite(&g) {
            continue;
        }
        let along = unit_normal(&g) * (push_step(-d, &g) / norm);
        for k in (0..3).filter(|&k| free[k] && w[k] > 0.0) {
            ask(asked, f[k], along * w[k]);
        }
    }
    depth
}

/// Records that vertex `i` is asked to move by `m`, keeping the largest move asked; two
/// asks of exactly the same length (mirror images, at a vertex on a symmetric mesh's mirror
/// plane) are averaged, so the order they come in does not choose between them.
fn ask(asked: &mut [Option<Vec3>], i: usize, m: Vec3) {
    let len = m.norm_squared();
    asked[i] = match asked[i] {
        Some(a) if a.norm_squared() > len => Some(a),
        Some(a) if a.norm_squared() == len => Some((a + m) / 2.0),
        _ => Some(m),
    };
}

/// Whether every component of `g` is finite (a broken field's gradient moves nothing).
fn finite(g: &Vec3) -> bool {
    g.iter().all(|c| c.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::sdf::{PUSH_SLACK, Sphere};
    use approx::assert_relative_eq;

    fn sphere() -> Sphere {
        Sphere {
            centre: Vec3::zeros(),
            radius: 0.05,
        }
    }

    /// A triangle whose corners sit on a 5 cm sphere while its middle cuts under it.
    fn chord_triangle() -> Vec<Vec3> {
        let r = 0.05;
        (0..3)
            .map(|k| {
                let a = k as Real * std::f64::consts::TAU / 3.0;
                let t: Real = 0.5;
                Vec3::new(r * t.sin() * a.cos(), r * t.cos(), r * t.sin() * a.sin())
            })
            .collect()
    }

    fn deepest_sample(x: &[Vec3], faces: &[[u32; 3]], s: &Sphere) -> Real {
        deepest_point_inside(x, faces, s, FACE_DIVISIONS)
    }

    #[test]
    fn a_triangle_cutting_under_a_sphere_is_lifted_clear_of_it() {
        let s = sphere();
        let mut x = chord_triangle();
        let faces = [[0, 1, 2]];
        let before = deepest_sample(&x, &faces, &s);
        assert!(before > 5e-3, "the chord should cut {before} m deep");
        let report = push_mesh_outside(&mut x, &faces, &s, &[false; 3]);
        assert_relative_eq!(report.deepest_before, before, max_relative = 1e-12);
        assert!(
            report.deepest <= INSIDE_SLACK,
            "left {} m inside",
            report.deepest
        );
        assert!(deepest_sample(&x, &faces, &s) <= INSIDE_SLACK);
        assert_eq!(report.moved, 3);
        // Lifted along the normal, not flung: no corner moves more than the cut was deep
        // plus the push's slack.
        for (a, b) in x.iter().zip(chord_triangle()) {
            assert!((a - b).norm() <= before + PUSH_SLACK);
        }
    }

    #[test]
    fn fixed_corners_stay_and_the_free_one_carries_the_push() {
        let s = sphere();
        let mut x = chord_triangle();
        let start = x.clone();
        let report = push_mesh_outside(&mut x, &[[0, 1, 2]], &s, &[true, true, false]);
        assert_eq!(x[0], start[0]);
        assert_eq!(x[1], start[1]);
        assert_ne!(x[2], start[2]);
        assert_eq!(report.moved, 1);
        assert!(
            report.deepest <= INSIDE_SLACK,
            "left {} m inside",
            report.deepest
        );
        // The edge between the two fixed corners cannot move: it stays as deep as it was,
        // and is not counted.
        let fixed_edge = |x: &[Vec3]| -s.distance(&((x[0] + x[1]) / 2.0));
        assert!(fixed_edge(&x) > 1e-3);
        assert_eq!(fixed_edge(&x), fixed_edge(&start));
    }

    #[test]
    fn a_mesh_already_outside_is_left_bit_for_bit() {
        let s = sphere();
        let mut x: Vec<Vec3> = chord_triangle().iter().map(|p| p * 3.0).collect();
        let start = x.clone();
        let report = push_mesh_outside(&mut x, &[[0, 1, 2]], &s, &[false; 3]);
        assert_eq!(x, start);
        assert_eq!(report, MeshPush::default());
    }

    #[test]
    fn the_result_does_not_depend_on_the_order_of_the_faces() {
        let s = sphere();
        // Two triangles sharing an edge, both cutting under the sphere.
        let mut x = chord_triangle();
        x.push(Vec3::new(0.0, 0.045, -0.03));
        let (mut a, mut b) = (x.clone(), x);
        push_mesh_outside(&mut a, &[[0, 1, 2], [0, 2, 3]], &s, &[false; 4]);
        push_mesh_outside(&mut b, &[[0, 2, 3], [0, 1, 2]], &s, &[false; 4]);
        assert_eq!(a, b);
    }

    #[test]
    fn triangle_samples_are_the_grid_without_corners_and_the_centroid() {
        for (divisions, count) in [(0, 1), (1, 1), (2, 4), (4, 13), (8, 43)] {
            let w = triangle_samples(divisions);
            assert_eq!(w.len(), count, "{divisions}");
            assert_eq!(*w.last().unwrap(), [1.0 / 3.0; 3]);
            for p in &w {
                assert_relative_eq!(p.iter().sum::<Real>(), 1.0, epsilon = 1e-12);
                assert!(p.iter().all(|&c| (0.0..1.0).contains(&c)), "{p:?}");
            }
        }
    }

    #[test]
    fn mirrored_asks_of_equal_length_are_averaged_whatever_their_order() {
        let (a, b) = (Vec3::new(0.3, 0.4, 0.0), Vec3::new(-0.3, 0.4, 0.0));
        let mut one = vec![None];
        ask(&mut one, 0, a);
        ask(&mut one, 0, b);
        let mut other = vec![None];
        ask(&mut other, 0, b);
        ask(&mut other, 0, a);
        assert_eq!(one[0], Some(Vec3::new(0.0, 0.4, 0.0)));
        assert_eq!(one, other);
        // A longer ask still wins.
        ask(&mut one, 0, Vec3::new(0.0, 0.0, 1.0));
        assert_eq!(one[0], Some(Vec3::new(0.0, 0.0, 1.0)));
    }

    /// A 3 × 3 sheet of spacing `h` (metres) in the plane through `centre` square to
    /// `normal`: 9 vertices, 8 triangles.
    fn sheet(centre: Vec3, normal: Vec3, h: Real) -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let n = normal.normalize();
        let u = n
            .cross(&Vec3::x())
            .try_normalize(1e-6)
            .unwrap_or_else(|| n.cross(&Vec3::y()).normalize());
        let v = n.cross(&u);
        let x = (0..9)
            .map(|k| centre + u * (h * Real::from(k % 3) - h) + v * (h * Real::from(k / 3) - h))
            .collect();
        let mut faces = Vec::new();
        for r in 0..2_u32 {
            for c in 0..2_u32 {
                let a = 3 * r + c;
                faces.push([a, a + 1, a + 4]);
                faces.push([a, a + 4, a + 3]);
            }
        }
        (x, faces)
    }

    proptest::proptest! {
        /// On a convex body: every sample point ends outside, fixed vertices never move,
        /// and the faces' order changes nothing.
        #[test]
        fn a_sheet_cutting_into_a_sphere_ends_outside_whatever_the_face_order(
            dir in proptest::array::uniform3(-1.0..1.0_f64),
            tilt in proptest::array::uniform3(-1.0..1.0_f64),
            depth in 0.8..1.05_f64,
            h in 0.005..0.03_f64,
            fixed in proptest::collection::vec(proptest::bool::weighted(0.2), 9),
        ) {
            let s = sphere();
            let d = Vec3::from(dir);
            proptest::prop_assume!(d.norm() > 0.1);
            let normal = d.normalize() + Vec3::from(tilt) * 0.3;
            let (x, faces) = sheet(d.normalize() * (s.radius * depth), normal, h);
            let mut a = x.clone();
            let report = push_mesh_outside(&mut a, &faces, &s, &fixed);
            let mut reversed = faces.clone();
            reversed.reverse();
            let mut b = x.clone();
            push_mesh_outside(&mut b, &reversed, &s, &fixed);
            proptest::prop_assert_eq!(&a, &b);
            for i in (0..9).filter(|&i| fixed[i]) {
                proptest::prop_assert_eq!(a[i], x[i]);
            }
            if fixed.iter().all(|f| !f) {
                proptest::prop_assert!(report.deepest <= 1e-6, "{:?}", report);
                proptest::prop_assert!(deepest_sample(&a, &faces, &s) <= 1e-6);
            }
        }
    }

    /// Only re-evaluating what moved gives bit for bit what evaluating everything every
    /// round gives: the coarse T-shirt on the body at poses within the joint limits, its
    /// vertices scattered by 1 cm so that many corners and triangles start inside (several
    /// rounds, pushes out of one part into another).
    #[test]
    fn re_evaluating_only_what_moved_changes_nothing() {
        use crate::Resolution;
        use crate::body::capsule_body::CapsuleBody;
        use crate::body::pose::JointLimits;
        use crate::body::sdf::SkinnedBody;
        use crate::garment::template::Garment;
        use crate::rng::SplitMix64;

        let body = CapsuleBody::smpl_neutral();
        let garment = Garment::tshirt(Resolution::Coarse, &body).unwrap();
        let mut rng = SplitMix64::new(11);
        let mut rounds = 0;
        for _ in 0..4 {
            let pose = JointLimits::default().sample(&mut rng, 0.6);
            let posed = body.pose(&pose);
            let t = body.skeleton().skinning_transforms(&pose);
            let start: Vec<Vec3> = garment
                .posed_rest_guess(&t)
                .into_iter()
                .map(|x| x + Vec3::from_fn(|_, _| rng.uniform(-0.01, 0.01)))
                .collect();
            let fixed: Vec<bool> = (0..start.len()).map(|i| i % 17 == 0).collect();
            let (mut a, mut b) = (start.clone(), start);
            let ra = push_rounds(&mut a, &garment.rest.faces, &posed, &fixed, false);
            let rb = push_rounds(&mut b, &garment.rest.faces, &posed, &fixed, true);
            assert_eq!(ra, rb);
            let bits = |x: &[Vec3]| -> Vec<u64> {
                x.iter()
                    .flat_map(|p| p.iter().map(|c| c.to_bits()))
                    .collect()
            };
            assert!(bits(&a) == bits(&b), "the pushed meshes differ");
            assert!(ra.moved > 10, "{ra:?}");
            rounds = rounds.max(ra.rounds);
        }
        assert!(rounds >= 3, "no pose took several rounds ({rounds})");
    }

    #[test]
    fn out_of_range_faces_and_short_fixed_lists_do_not_panic() {
        let s = sphere();
        let mut x = chord_triangle();
        let report = push_mesh_outside(&mut x, &[[0, 1, 7]], &s, &[]);
        assert_eq!(report.deepest, 0.0);
    }
}
