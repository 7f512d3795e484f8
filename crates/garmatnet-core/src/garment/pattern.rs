//! The procedural T-shirt's sewing pattern and its rest shape in the T-pose.
//!
//! # Construction
//! Each of the two panels (front, back) is a T-shaped mask of square cells on one regular
//! pattern grid: `u` (weft) runs horizontally, `v` (warp) vertically, both in metres of
//! pattern length, spacing `h`. The torso is the rectangle `|u| <= Ut`, `0 <= v <= V`; the
//! sleeves are rectangles `Ut <= |u| <= Uc` in the top band `V - Hs <= v <= V`; a rectangular
//! neck cut-out at top centre is deeper in front than at the back. The outline of the T,
//! except the hem (`v = 0`), the cuffs (`|u| = Uc`) and the neck, is sewn: its vertices are
//! shared by both panels (side, underarm and shoulder/sleeve-top seams).
//!
//! The rest shape maps a pattern point to `(x, y, zm ± z)` (front `+`, back `-`), with
//! `z = 0` on every seam so that both panels agree there. It blends two maps:
//! - the torso map wraps an elliptic cylinder (arc-length parametrised in `u`) around the
//!   spine, rounding over the shoulders in a cap down from the shoulder ridge;
//! - the sleeve map wraps a circular cylinder around each upper-arm bone, `u` along the arm
//!   and `v` around it (top seam to underarm seam).
//!
//! The sleeve map takes over smoothly across the armhole (`Ut - B <= |u| <= Ut`), from a
//! little above the underarm seam, so the shoulder is covered by the sleeve tube and the
//! armpit is a saddle where the side seam meets the underarm seam. All sizes come from the
//! skeleton's joints plus ease, never from a body surface.
//!
//! # The two cuts
//! - **Boxy** ([`GarmentStyle::Boxy`]): the construction above with generous ease (about
//!   25 cm round the chest), a rectangular neck cut-out and sleeves along the T-pose arms.
//!   Its mesh is bit-identical to earlier versions (the template of the models shipped up
//!   to version 0.3, revision 2's the last).
//! - **Fitted** ([`GarmentStyle::Fitted`], the default), on the skeleton made left-right
//!   symmetric and built for `u >= 0` then mirrored, so the mesh is exactly symmetric:
//!   - about 2.2 cm of ease all round the chest (about 10 cm of circumference);
//!   - a crew neck: the cells inside a half-ellipse under the top edge, as wide as the
//!     neck plus ease and deeper in front (10 cm of pattern) than at the back (8 cm);
//!   - a shoulder ridge sloping 12° from the neck's side down to the shoulder point;
//!   - sleeves for the A-pose ([`crate::Pose::a_pose`]): each band column is a ring
//!     lofted from the armhole (shoulder point over the top, armpit under it, 7 cm below
//!     the sleeve's T-pose underarm line) to a cuff square to the A-posed upper arm at 80 %
//!     of its length; the top seam bows out over the shoulder. The band is 26 cm tall (half
//!     the armhole), so the sleeve tapers from the armhole to the cuff by compressing the
//!     grid; the underarm seam is about half the pattern's length in 3-D and the top seam
//!     about 1.3 times, which is what an angled sleeve would cut into the pattern's outline.

use std::collections::{HashMap, HashSet};

use serde::{Deserialize, Serialize};

use crate::body::skeleton::Skeleton;
use crate::error::{Error, Result};
use crate::garment::shape::{FittedShape, SHOULDER_SLOPE, ShirtShape};
use crate::garment::style::GarmentStyle;
use crate::math::{Real, Vec3};

/// Which pattern panel a garment vertex belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Panel {
    /// The front panel (faces +z).
    Front,
    /// The back panel (faces -z).
    Back,
    /// A seam vertex, shared by both panels.
    Seam,
}

/// Cumulative arc length of the quarter ellipse `(a sin t, c cos t)`, `t` in `[0, pi/2]`,
/// inverted by table look-up so torso columns are evenly spaced in 3D.
struct QuarterEllipse {
    arc: Vec<Real>,
    step: Real,
}

impl QuarterEllipse {
    const SAMPLES: usize = 1024;

    fn new(a: Real, c: Real) -> Self {
        let step = std::f64::consts::FRAC_PI_2 / Self::SAMPLES as Real;
        let speed = |t: Real| (a * a * t.cos().powi(2) + c * c * t.sin().powi(2)).sqrt();
        let mut arc = vec![0.0; Self::SAMPLES + 1];
        for k in 1..=Self::SAMPLES {
            let (t0, t1) = ((k - 1) as Real * step, k as Real * step);
            arc[k] = arc[k - 1] + 0.5 * step * (speed(t0) + speed(t1));
        }
        Self { arc, step }
    }

    fn length(&self) -> Real {
        self.arc[Self::SAMPLES]
    }

    /// The angle at arc length `s` (clamped to the quarter).
    fn angle_at(&self, s: Real) -> Real {
        let s = s.clamp(0.0, self.length());
        let k = self.arc.partition_point(|&x| x < s).clamp(1, Self::SAMPLES);
        let (s0, s1) = (self.arc[k - 1], self.arc[k]);
        let f = if s1 > s0 { (s - s0) / (s1 - s0) } else { 0.0 };
        ((k - 1) as Real + f) * self.step
    }

    /// The arc length at angle `t`.
    fn arc_at(&self, t: Real) -> Real {
        let x = (t / self.step).clamp(0.0, Self::SAMPLES as Real);
        let k = (x.floor() as usize).min(Self::SAMPLES - 1);
        self.arc[k] + (x - k as Real) * (self.arc[k + 1] - self.arc[k])
    }
}

/// A smooth maximum of two non-negative numbers that is 0 when both are 0 and at most
/// 5 mm below the true maximum.
fn smooth_max(a: Real, b: Real) -> Real {
    const K: Real = 0.01;
    0.5 * (a + b + ((a - b).powi(2) + K * K).sqrt() - K)
}

fn smoothstep(t: Real) -> Real {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// A grid point `(i, j)`: pattern position `(i h, j h)`.
pub(crate) type GridPoint = (i32, i32);

/// The two panels' cells on the shared grid, their vertex numbering and the seams.
#[derive(Debug, Clone)]
pub(crate) struct PanelGrid {
    /// Grid index ranges: `i` in `-ic..=ic`, `j` in `0..=jt`.
    pub ic: i32,
    pub jt: i32,
    /// Cells (by lower-left corner) present in the front (0) and back (1) panel.
    cells: [HashSet<GridPoint>; 2],
    /// Sewn outline edges (normalised, lower endpoint first).
    seam_edges: HashSet<(GridPoint, GridPoint)>,
    /// Vertex number of a panel's grid point (seam points map to the same number in both).
    index: [HashMap<GridPoint, u32>; 2],
}

impl PanelGrid {
    pub fn has_cell(&self, side: usize, (i, j): GridPoint) -> bool {
        self.cells[side].contains(&(i, j))
    }

    pub fn vertex(&self, side: usize, p: GridPoint) -> Option<u32> {
        self.index[side].get(&p).copied()
    }

    /// Whether the unit grid edge `p`-`q` is cloth of panel `side` (a present cell has it).
    pub fn has_edge(&self, side: usize, p: GridPoint, q: GridPoint) -> bool {
        let (lo, hi) = if p <= q { (p, q) } else { (q, p) };
        if hi.0 - lo.0 == 1 && hi.1 == lo.1 {
            self.has_cell(side, lo) || self.has_cell(side, (lo.0, lo.1 - 1))
        } else if hi.1 - lo.1 == 1 && hi.0 == lo.0 {
            self.has_cell(side, lo) || self.has_cell(side, (lo.0 - 1, lo.1))
        } else {
            false
        }
    }

    pub fn is_seam_edge(&self, p: GridPoint, q: GridPoint) -> bool {
        let key = if p <= q { (p, q) } else { (q, p) };
        self.seam_edges.contains(&key)
    }
}

/// The T-shirt pattern and its rest shape.
#[derive(Debug, Clone)]
pub(crate) struct TshirtPattern {
    pub vertices: Vec<Vec3>,
    pub uv: Vec<[Real; 2]>,
    pub panels: Vec<Panel>,
    pub faces: Vec<[u32; 3]>,
    pub grid: PanelGrid,
    /// Each vertex's mirror twin: the vertex at the same panel's grid point `(-i, j)`.
    pub mirror: Vec<u32>,
}

impl TshirtPattern {
    /// Builds the pattern of `style` on a grid of `spacing` metres for `skeleton`.
    pub fn build(skeleton: &Skeleton, spacing: Real, style: GarmentStyle) -> Result<Self> {
        if !(0.003..=0.1).contains(&spacing) {
            return Err(Error::OutOfRange {
                what: "T-shirt grid spacing (m)".into(),
                value: spacing,
                min: 0.003,
                max: 0.1,
                hint: String::new(),
            });
        }
        let shape = ShirtShape::from_skeleton(skeleton, style)?;
        let ellipse = QuarterEllipse::new(shape.a, shape.c);
        let h = spacing;
        let cells_of = |len: Real| ((len / h).round() as i32).max(1);
        let it = cells_of(ellipse.length());
        let ic = it + cells_of(shape.x_cuff - shape.a);
        // The fitted sleeve's band is as tall as the torso's path from the armpit over the
        // shoulder to the seam (its armhole), less the taper to the cuff.
        let js = match &shape.fitted {
            None => cells_of(std::f64::consts::PI * shape.sleeve_radius),
            Some(f) => cells_of(f.sleeve_band),
        };
        let cap_arc = QuarterEllipse::new(shape.c, shape.cap_height).length();
        let jt = cells_of(cap_arc + shape.y_ridge_centre - shape.cap_height - shape.y_hem);
        let i_neck = cells_of(ellipse.arc_at((shape.x_neck / shape.a).clamp(-1.0, 1.0).asin()));
        let drops = [
            cells_of(shape.neck_drop_front),
            cells_of(shape.neck_drop_back),
        ];
        if jt <= js + drops[0] || i_neck >= it || Real::from(js) * h <= cap_arc {
            return Err(Error::NoRoomForGarment);
        }

        let in_t = |(i, j): GridPoint| {
            let torso = (-it..it).contains(&i) && (0..jt).contains(&j);
            let sleeve = (-ic..ic).contains(&i) && (jt - js..jt).contains(&j);
            torso || sleeve
        };
        // The crew neck: cells whose centre lies inside a half-ellipse under the top edge,
        // as wide as the neck opening and as deep as the side's drop.
        let neck_width = Real::from(i_neck) * h;
        let round_neck = shape.fitted.is_some();
        let neck_depths = [shape.neck_drop_front, shape.neck_drop_back];
        let in_neck = |side: usize, (i, j): GridPoint| {
            if round_neck {
                let across = (Real::from(i) + 0.5) * h / neck_width;
                let down = (Real::from(jt - j) - 0.5) * h / neck_depths[side];
                across * across + down * down < 1.0
            } else {
                (-i_neck..i_neck).contains(&i) && j >= jt - drops[side]
            }
        };
        let in_panel = |side: usize, p: GridPoint| in_t(p) && !in_neck(side, p);
        let mut cells = [HashSet::new(), HashSet::new()];
        let mut seam_edges = HashSet::new();
        for j in 0..jt {
            for i in -ic..ic {
                for (side, set) in cells.iter_mut().enumerate() {
                    if in_panel(side, (i, j)) {
                        set.insert((i, j));
                    }
                }
                if !in_t((i, j)) {
                    continue;
                }
                // Outline edges of the T, minus the openings, are the seams.
                let neck_top = j == jt - 1 && (in_neck(0, (i, j)) || in_neck(1, (i, j)));
                if j > 0 && !in_t((i, j - 1)) {
                    seam_edges.insert(((i, j), (i + 1, j)));
                }
                if !in_t((i, j + 1)) && !neck_top {
                    seam_edges.insert(((i, j + 1), (i + 1, j + 1)));
                }
                if i > -ic && !in_t((i - 1, j)) {
                    seam_edges.insert(((i, j), (i, j + 1)));
                }
                if i + 1 < ic && !in_t((i + 1, j)) {
                    seam_edges.insert(((i + 1, j), (i + 1, j + 1)));
                }
            }
        }
        let seam_points: HashSet<GridPoint> =
            seam_edges.iter().flat_map(|&(p, q)| [p, q]).collect();

        let geometry = Geometry {
            shape: &shape,
            ellipse: &ellipse,
            h,
            it,
            js,
            jt,
            cap_arc,
        };
        let mut index = [HashMap::new(), HashMap::new()];
        let mut vertices = Vec::new();
        let mut uv = Vec::new();
        let mut panels = Vec::new();
        let mut faces = Vec::new();
        for side in 0..2 {
            for j in 0..jt {
                for i in -ic..ic {
                    if !cells[side].contains(&(i, j)) {
                        continue;
                    }
                    let mut corner = [0u32; 4];
                    for (k, p) in [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]
                        .into_iter()
                        .enumerate()
                    {
                        if let Some(&v) = index[side].get(&p) {
                            corner[k] = v;
                            continue;
                        }
                        let shared = seam_points.contains(&p);
                        let v = match shared.then(|| index[1 - side].get(&p)).flatten() {
                            Some(&v) => v,
                            None => {
                                let v = u32::try_from(vertices.len())
                                    .expect("a T-shirt has far fewer than 2^32 vertices");
                                vertices.push(geometry.position(side, p, shared));
                                uv.push([Real::from(p.0) * h, Real::from(p.1) * h]);
                                panels.push(if shared {
                                    Panel::Seam
                                } else if side == 0 {
                                    Panel::Front
                                } else {
                                    Panel::Back
                                });
                                v
                            }
                        };
                        index[side].insert(p, v);
                        corner[k] = v;
                    }
                    let [v00, v10, v11, v01] = corner;
                    // Alternate the diagonal so the triangulation has no preferred shear.
                    let mut tris = if (i + j).rem_euclid(2) == 0 {
                        [[v00, v10, v11], [v00, v11, v01]]
                    } else {
                        [[v00, v10, v01], [v10, v11, v01]]
                    };
                    // Counter-clockwise in (u, v) faces +z: right for the front only.
                    if side == 1 {
                        for t in &mut tris {
                            t.swap(1, 2);
                        }
                    }
                    faces.extend(tris);
                }
            }
        }
        let mut mirror = vec![u32::MAX; vertices.len()];
        for side in &index {
            for (&(i, j), &v) in side {
                mirror[v as usize] = *side.get(&(-i, j)).ok_or_else(|| {
                    Error::InvalidMesh(format!("the pattern has no mirror twin of ({i}, {j})"))
                })?;
            }
        }
        let grid = PanelGrid {
            ic,
            jt,
            cells,
            seam_edges,
            index,
        };
        Ok(Self {
            vertices,
            uv,
            panels,
            faces,
            grid,
            mirror,
        })
    }
}

/// The pattern-to-3D map (see the module documentation).
struct Geometry<'a> {
    shape: &'a ShirtShape,
    ellipse: &'a QuarterEllipse,
    h: Real,
    it: i32,
    js: i32,
    jt: i32,
    cap_arc: Real,
}

impl Geometry<'_> {
    fn position(&self, side: usize, (i, j): GridPoint, seam: bool) -> Vec3 {
        match &self.shape.fitted {
            None => self.boxy_position(side, (i, j), seam),
            Some(_) => {
                // One half, mirrored bit for bit: the fitted shirt is exactly symmetric.
                let p = self.boxy_position(side, (i.abs(), j), seam);
                if i < 0 { Vec3::new(-p.x, p.y, p.z) } else { p }
            }
        }
    }

    /// The fitted sleeve's point at unrolled `x` (left half) and `round` in `[0, 1]` (top
    /// seam to underarm seam): a ring lofted from the armhole (over the torso's side) to the
    /// cuff (square to the A-posed arm), carried flat inward past the armhole. Returns x and
    /// y, and the half-depth off the seam plane in z (never thinner than `torso_depth`).
    fn fitted_sleeve(&self, f: &FittedShape, x: Real, round: Real, torso_depth: Real) -> Vec3 {
        let s = self.shape;
        let length = s.x_cuff - s.a;
        let t = (x - s.a) / length;
        let (top, under) = if t < 0.0 {
            let inward = Vec3::new(x - s.a, 0.0, 0.0);
            (f.top_start + inward, f.under_start + inward)
        } else {
            // The top seam bows out over the round of the shoulder.
            let bow = f.shoulder_bow * 4.0 * t.min(1.0) * (1.0 - t).max(0.0);
            (
                f.top_start + (f.top_end - f.top_start) * t + f.arm_up * bow,
                f.under_start + (f.under_end - f.under_start) * t,
            )
        };
        let t = t.clamp(0.0, 1.0);
        let half_depth = f.armhole_half_depth + (f.cuff_radius - f.armhole_half_depth) * t;
        let phi = std::f64::consts::PI * round;
        let centre = (top + under) * 0.5;
        let p = centre + (top - under) * (0.5 * phi.cos());
        Vec3::new(
            p.x,
            p.y,
            smooth_max(torso_depth, half_depth * phi.sin().max(0.0)),
        )
    }

    fn boxy_position(&self, side: usize, (i, j): GridPoint, seam: bool) -> Vec3 {
        let s = self.shape;
        let (u, v) = (Real::from(i) * self.h, Real::from(j) * self.h);
        let sign = if u < 0.0 { -1.0 } else { 1.0 };
        let ut = Real::from(self.it) * self.h;
        let v_top = Real::from(self.jt) * self.h;
        let band = Real::from(self.js) * self.h;
        let v_armpit = v_top - band;
        let depth_down = v_top - v;

        // Torso: elliptic cylinder, columns evenly spaced in arc length, extended flat
        // beyond the side line so it can be blended with the sleeve.
        let theta = sign * self.ellipse.angle_at(u.abs() / ut * self.ellipse.length());
        let x_torso = s.a * theta.sin() + sign * (u.abs() - ut).max(0.0);
        let x_rel = (x_torso / s.a).clamp(-1.0, 1.0);
        let ridge = match &s.fitted {
            None => {
                s.sleeve_top(sign) + (s.y_ridge_centre - s.sleeve_top(sign)) * (1.0 - x_rel * x_rel)
            }
            Some(f) => {
                let beyond_neck = (x_torso.abs().min(s.a) - s.x_neck).max(0.0);
                f.y_ridge_neck - SHOULDER_SLOPE.tan() * beyond_neck
            }
        };
        let psi = std::f64::consts::FRAC_PI_2 * (depth_down / self.cap_arc).min(1.0);
        // Below the cap the torso is straight, piecewise linear in v so the armpit row
        // and the hem are level: the armpit sits below the sleeve's underarm line.
        let cap_end = ridge - s.cap_height;
        let y_armpit = s.arm_axis(sign * s.a).y - s.sleeve_radius - s.armpit_drop;
        let below_cap = depth_down - self.cap_arc;
        let y_torso = if below_cap <= 0.0 {
            ridge - s.cap_height * (1.0 - psi.cos())
        } else if depth_down <= band {
            cap_end + (y_armpit - cap_end) * below_cap / (band - self.cap_arc)
        } else {
            y_armpit + (s.y_hem - y_armpit) * (depth_down - band) / (v_top - band)
        };
        let z_torso = s.c * theta.cos().max(0.0) * psi.sin();
        let torso = (Vec3::new(x_torso, y_torso, s.zc), z_torso);

        let weight = if v < v_armpit {
            0.0
        } else {
            let blend = 1.8 * s.sleeve_radius;
            // Full sleeve from halfway across the blend: the shoulder is as thick as the arm.
            let across = smoothstep((u.abs() - (ut - blend)) / (0.5 * blend));
            let above_armpit = smoothstep((v - v_armpit) / (band / 3.0));
            let past_side = smoothstep((u.abs() - ut) / (band / 3.0));
            across * (above_armpit + past_side).min(1.0)
        };
        if let Some(f) = &s.fitted
            && weight > 0.0
        {
            // Seams lie where the panels meet: the torso's mid-plane blended to the arm's.
            let front = if side == 0 { 1.0 } else { -1.0 };
            let torso_point = Vec3::new(torso.0.x, torso.0.y, s.zc + front * torso.1);
            let sleeve = self.fitted_sleeve(f, x_torso, depth_down / band, torso.1);
            let sleeve_point = Vec3::new(sleeve.x, sleeve.y, f.arm_z + front * sleeve.z);
            let mut p = torso_point + (sleeve_point - torso_point) * weight;
            if seam {
                p.z = s.zc + (f.arm_z - s.zc) * weight;
            }
            return p;
        }
        let (centre, half_depth) = if weight > 0.0 {
            // Sleeve: circular cylinder around the arm bone, v going round it from the
            // top seam (phi = 0) over the front/back to the underarm seam (phi = pi). It
            // shares the torso's x so the armhole is not squeezed sideways, and it never
            // makes the shirt thinner than the torso map (the shoulder is wider than the
            // arm).
            let axis = s.arm_axis(x_torso);
            let phi = std::f64::consts::PI * depth_down / band;
            let y_sleeve = axis.y + s.sleeve_radius * phi.cos();
            let centre_z = s.zc + (axis.z - s.zc) * weight;
            // Off the arm's axis, the sleeve must widen by the offset to still enclose it.
            let reach = s.sleeve_radius + (centre_z - axis.z).abs();
            let half_sleeve = smooth_max(torso.1, reach * phi.sin().max(0.0));
            let centre = Vec3::new(x_torso, y_torso + (y_sleeve - y_torso) * weight, centre_z);
            (centre, torso.1 + (half_sleeve - torso.1) * weight)
        } else {
            torso
        };
        // Seam points lie on the panels' common plane exactly, whatever rounding says.
        let half_depth = if seam { 0.0 } else { half_depth };
        let z = if side == 0 {
            centre.z + half_depth
        } else {
            centre.z - half_depth
        };
        Vec3::new(centre.x, centre.y, z)
    }
}
