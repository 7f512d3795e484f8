//! The garment template: the procedural T-shirt's rest mesh, its mass-spring network, its
//! body correspondence and its pattern coordinates.
//!
//! The shirt is sewn from two T-shaped panels on regular (u, v) grids (see
//! [`crate::garment::pattern`] for the construction), sized from the body's skeleton with
//! ease, and must sit outside the body's signed distance field in its rest pose
//! ([`Garment::rest_pose`]): [`Pose::a_pose`] for the fitted cut (the default), the T-pose
//! for the boxy one.

use serde::{Deserialize, Serialize};

use crate::body::anchor::BodyAnchor;
use crate::body::posable_body::PosableBody;
use crate::body::pose::Pose;
use crate::body::sdf::{SignedDistance, SkinnedBody};
use crate::body::skeleton::JOINT_COUNT;
use crate::error::{Error, Result};
use crate::garment::openings::{BoundaryLoop, boundary_loops};
use crate::garment::pattern::{Panel, TshirtPattern};
use crate::garment::resolution::Resolution;
use crate::garment::spring::SpringKind;
use crate::garment::spring::{Spring, provot_springs};
use crate::garment::style::GarmentStyle;
use crate::math::{Iso3, Mat3, Real, Vec3};
use crate::mesh::TriMesh;

/// The least distance (metres) between the rest shirt and the rest body.
pub const MIN_BODY_CLEARANCE: Real = 0.005;

/// The garment template a dataset or model was made with: enough to rebuild it
/// ([`Garment::for_template`]) and to refuse another. Dataset manifests and model files
/// store it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct TemplateInfo {
    /// The template's resolution.
    pub resolution: Resolution,
    /// Vertices per garment (`n` of every garment array).
    pub vertex_count: usize,
    /// The template's content hash ([`Garment::template_hash`], 16 hex digits).
    pub hash: String,
}

impl TemplateInfo {
    /// The template description of `garment`.
    #[must_use]
    pub fn of(garment: &Garment) -> Self {
        Self {
            resolution: garment.resolution,
            vertex_count: garment.vertex_count(),
            hash: format!("{:016x}", garment.template_hash()),
        }
    }
}

/// A garment template: rest mesh, springs, body anchors and pattern coordinates.
#[derive(Debug, Clone)]
pub struct Garment {
    /// The rest shape (metres), faces oriented outward, dressed on the body in
    /// [`Garment::rest_pose`].
    pub rest: TriMesh,
    /// The pose the rest mesh is dressed in and fits without stretch: [`Pose::a_pose`] for
    /// the fitted cut, [`Pose::zero`] (the T-pose) for the boxy one. Drapes start here:
    /// [`Garment::posed_rest_guess`] for this pose's skinning transforms is `rest`.
    pub rest_pose: Pose,
    /// The cut.
    pub style: GarmentStyle,
    /// Provot's springs, rest lengths taken from `rest`.
    pub springs: Vec<Spring>,
    /// Each vertex's body correspondence.
    pub anchors: Vec<BodyAnchor>,
    /// Each vertex's pattern coordinates `(u, v)` (metres; u weft, v warp, origin at the
    /// hem's centre).
    pub uv: Vec<[Real; 2]>,
    /// Each vertex's panel ([`Panel::Seam`] for vertices shared by both).
    pub panels: Vec<Panel>,
    /// The mesh resolution.
    pub resolution: Resolution,
    /// The four openings.
    pub boundary: Vec<BoundaryLoop>,
    /// Each vertex's offset from its anchor in the anchor's canonical (unposed) frame
    /// (metres): [`Garment::posed_rest_guess`] rotates it by the posed frame.
    rest_offsets: Vec<Vec3>,
    /// Each vertex's mirror twin (see [`Garment::mirror_twins`]).
    mirror: Vec<u32>,
}

impl Garment {
    /// The procedural T-shirt for `body`, sized from its skeleton: the fitted cut
    /// ([`GarmentStyle::Fitted`]), dressed in [`Pose::a_pose`].
    ///
    /// # Errors
    /// As [`Garment::with_style`].
    pub fn tshirt(resolution: Resolution, body: &(impl PosableBody + ?Sized)) -> Result<Self> {
        Self::with_style(GarmentStyle::Fitted, resolution, body)
    }

    /// The boxy T-shirt of the models shipped up to version 0.3 ([`GarmentStyle::Boxy`]),
    /// dressed in the T-pose; its mesh and [`Garment::template_hash`] are those of earlier
    /// versions.
    ///
    /// # Errors
    /// As [`Garment::with_style`].
    pub fn boxy_tshirt(resolution: Resolution, body: &(impl PosableBody + ?Sized)) -> Result<Self> {
        Self::with_style(GarmentStyle::Boxy, resolution, body)
    }

    /// The T-shirt whose [`Garment::template_hash`] is `hash` (16 hex digits, as model files
    /// and dataset manifests record it) at `resolution`, of whichever [`GarmentStyle`] has it:
    /// a model or dataset made on the boxy shirt keeps working beside fitted ones.
    ///
    /// # Errors
    /// [`Error::Mismatch`] naming the hashes this build makes at `resolution` if no style has
    /// `hash` (a template of another version: regenerate or retrain with this one); as
    /// [`Garment::with_style`].
    pub fn for_template(
        resolution: Resolution,
        hash: &str,
        body: &(impl PosableBody + ?Sized),
    ) -> Result<Self> {
        let mut made = Vec::new();
        for style in GarmentStyle::ALL {
            let garment = Self::with_style(style, resolution, body)?;
            let own = format!("{:016x}", garment.template_hash());
            if own.eq_ignore_ascii_case(hash.trim()) {
                return Ok(garment);
            }
            made.push(format!("{style} {own}"));
        }
        Err(Error::Mismatch {
            what: format!("T-shirt template at {resolution} resolution"),
            expected: made.join(" or "),
            got: hash.to_owned(),
        })
    }

    /// The procedural T-shirt of `style` for `body`, sized from its skeleton and dressed in
    /// the style's rest pose ([`Garment::rest_pose`]). The fitted cut is pushed out to
    /// [`MIN_BODY_CLEARANCE`] plus 3 mm wherever the posed body comes closer, each half
    /// the mirror of the other.
    ///
    /// # Errors
    /// [`Error::NotATPose`] / [`Error::NoRoomForGarment`] if the skeleton is not a usable
    /// T-pose; [`Error::GarmentInsideBody`] / [`Error::GarmentTooTight`] if a shirt vertex
    /// would lie within [`MIN_BODY_CLEARANCE`] of the posed body or move too far to clear it
    /// (the body is much larger than its skeleton suggests); [`Error::InvalidMesh`] if the body's projection or
    /// skin weights are unusable.
    pub fn with_style(
        style: GarmentStyle,
        resolution: Resolution,
        body: &(impl PosableBody + ?Sized),
    ) -> Result<Self> {
        // The boxy shirt of earlier versions was cut from SMPL's measured joints, before the
        // neutral skeleton was made mirror-symmetric: it keeps that cut (and its template
        // hash, which the models shipped up to 0.3 record) on the neutral body.
        let measured = crate::body::skeleton::Skeleton::smpl_neutral_measured();
        let cut_from = if style == GarmentStyle::Boxy
            && *body.skeleton() == crate::body::skeleton::Skeleton::smpl_neutral()
        {
            &measured
        } else {
            body.skeleton()
        };
        let pattern = TshirtPattern::build(cut_from, resolution.grid_spacing(), style)?;
        let rest_pose = match style {
            GarmentStyle::Fitted => Pose::a_pose(),
            GarmentStyle::Boxy => Pose::zero(),
        };
        let mut vertices = pattern.vertices;
        let transforms = body.skeleton().skinning_transforms(&rest_pose);
        let posed = body.posed_field(&rest_pose);
        if style == GarmentStyle::Fitted {
            push_out_symmetric(&mut vertices, &pattern.mirror, &*posed)?;
        }
        let mut springs = provot_springs(&pattern.grid, &vertices);
        if style == GarmentStyle::Fitted {
            floor_rest_lengths(&mut springs, resolution.grid_spacing());
        }
        let mut anchors = Vec::with_capacity(vertices.len());
        let mut rest_offsets = Vec::with_capacity(vertices.len());
        for (k, p) in vertices.iter().enumerate() {
            let distance = match style {
                GarmentStyle::Fitted => posed.distance(p),
                GarmentStyle::Boxy => body.distance(p),
            };
            if distance.is_nan() || distance <= MIN_BODY_CLEARANCE {
                return Err(Error::GarmentInsideBody {
                    vertex: k,
                    position: [p.x, p.y, p.z],
                    distance_mm: distance * 1e3,
                    needed_mm: MIN_BODY_CLEARANCE * 1e3,
                });
            }
            let anchor = match style {
                GarmentStyle::Boxy => {
                    let rest_point = body.project(p);
                    let weights = body.skin_weights(&rest_point);
                    check_weights(k, &weights)?;
                    let anchor = BodyAnchor {
                        rest_point,
                        weights,
                    };
                    rest_offsets.push(p - anchor.rest_point);
                    anchor
                }
                GarmentStyle::Fitted => {
                    let anchor = unposed_anchor(k, body, &transforms, &posed.project(p))?;
                    let offset = p - anchor.posed_point(&transforms);
                    rest_offsets.push(anchor.frame(&transforms).inverse_transform_vector(&offset));
                    anchor
                }
            };
            anchors.push(anchor);
        }
        let rest = TriMesh::new(vertices, pattern.faces)?;
        let boundary = boundary_loops(&rest)?;
        Ok(Self {
            rest,
            rest_pose,
            style,
            springs,
            anchors,
            uv: pattern.uv,
            panels: pattern.panels,
            resolution,
            boundary,
            rest_offsets,
            mirror: pattern.mirror,
        })
    }

    /// Each vertex's mirror twin under x -> -x: the vertex at the mirrored pattern grid
    /// point of the same panel (a centre-line vertex is its own twin). For the fitted cut the
    /// rest mesh is exactly symmetric: twin `mirror_twins()[k]` sits at vertex `k`'s
    /// position with x negated, so a drape's mirror asymmetry is
    /// `|x_k - mirror(x_twin(k))|`.
    #[must_use]
    pub fn mirror_twins(&self) -> &[u32] {
        &self.mirror
    }

    /// The number of vertices.
    #[must_use]
    pub fn vertex_count(&self) -> usize {
        self.rest.vertex_count()
    }

    /// A fingerprint of the template (FNV-1a, 64 bits) over the style's name (left out for
    /// the boxy cut, so its hash is that of earlier versions), the resolution's name, the
    /// rest vertices' bits, the faces and the springs: models trained on one template
    /// refuse another.
    #[must_use]
    pub fn template_hash(&self) -> u64 {
        let mut hash = Fnv1a::new();
        if self.style != GarmentStyle::Boxy {
            hash.write(self.style.name().as_bytes());
            hash.write(b"/");
        }
        hash.write(self.resolution.name().as_bytes());
        for v in &self.rest.vertices {
            for c in v.iter() {
                hash.write(&c.to_bits().to_le_bytes());
            }
        }
        for f in &self.rest.faces {
            for i in f {
                hash.write(&i.to_le_bytes());
            }
        }
        for s in &self.springs {
            hash.write(&s.a.to_le_bytes());
            hash.write(&s.b.to_le_bytes());
            hash.write(&s.rest_length.to_bits().to_le_bytes());
            hash.write(&[s.kind.code()]);
        }
        hash.0
    }

    /// The anchors' posed body points (metres), one per vertex, for skinning `transforms`
    /// ([`crate::Skeleton::skinning_transforms`]).
    #[must_use]
    pub fn body_points(&self, transforms: &[Iso3; JOINT_COUNT]) -> Vec<Vec3> {
        self.anchors
            .iter()
            .map(|a| a.posed_point(transforms))
            .collect()
    }

    /// The rest shirt carried along by the body: each vertex is its posed anchor plus its
    /// rest offset from the anchor, kept in the anchor's canonical frame and rotated by the
    /// posed frame. The solver's starting point for a pose; for the skinning transforms of
    /// [`Garment::rest_pose`] it is the rest mesh (to rounding).
    #[must_use]
    pub fn posed_rest_guess(&self, transforms: &[Iso3; JOINT_COUNT]) -> Vec<Vec3> {
        self.anchors
            .iter()
            .zip(&self.rest_offsets)
            .map(|(a, o)| a.posed_point(transforms) + a.frame(transforms) * o)
            .collect()
    }

    /// Lumped vertex masses (kg) for a fabric of areal `density` (kg/m^2): a third of the
    /// rest area of each incident triangle.
    #[must_use]
    pub fn vertex_masses(&self, density: Real) -> Vec<Real> {
        self.rest
            .vertex_areas()
            .into_iter()
            .map(|a| a * density)
            .collect()
    }
}

/// Moves each vertex of the left half (x >= 0) out to `MIN_BODY_CLEARANCE + 3 mm` of the
/// body mirrored onto itself (the nearer of the body and its mirror image), and sets each
/// right-half vertex to its mirror twin's mirror image: the mesh stays exactly symmetric.
///
/// # Errors
/// [`Error::GarmentTooTight`] if a vertex would move more than [`MAX_FIT_PUSH`]: the body
/// is much larger than its skeleton suggests.
fn push_out_symmetric(
    vertices: &mut [Vec3],
    mirror: &[u32],
    body: &dyn SignedDistance,
) -> Result<()> {
    struct Symmetric<'a>(&'a dyn SignedDistance);
    impl SignedDistance for Symmetric<'_> {
        fn distance_and_gradient(&self, p: &Vec3) -> (Real, Vec3) {
            let (d, g) = self.0.distance_and_gradient(p);
            let (dm, gm) = self.0.distance_and_gradient(&Vec3::new(-p.x, p.y, p.z));
            if dm < d {
                (dm, Vec3::new(-gm.x, gm.y, gm.z))
            } else {
                (d, g)
            }
        }
    }
    let field = Symmetric(body);
    for (k, p) in vertices.iter_mut().enumerate().filter(|(_, p)| p.x >= 0.0) {
        let on_centre = p.x == 0.0;
        let mut pushed = field.push_outside(p, MIN_BODY_CLEARANCE + 0.003);
        if on_centre {
            pushed.x = 0.0;
        }
        let moved = (pushed - *p).norm();
        if moved > MAX_FIT_PUSH {
            return Err(Error::GarmentTooTight {
                vertex: k,
                position: [p.x, p.y, p.z],
                distance_mm: body.distance(p) * 1e3,
                push_mm: moved * 1e3,
                max_push_mm: MAX_FIT_PUSH * 1e3,
            });
        }
        *p = pushed;
    }
    for k in 0..vertices.len() {
        if vertices[k].x < 0.0 {
            let twin = vertices[mirror[k] as usize];
            vertices[k] = Vec3::new(-twin.x, twin.y, twin.z);
        }
    }
    Ok(())
}

/// The farthest (metres) the fitted cut moves a vertex out of the posed body.
pub const MAX_FIT_PUSH: Real = 0.03;

/// The anchor of a garment vertex dressed in a pose with skinning `transforms`: the rest
/// body point whose linear-blend-skinned image is `posed_point` (a point on the posed
/// body), found by fixed-point iteration `r <- M(w(r))^-1 (posed_point - t(w(r)))` over the
/// blended affine map of the weights at `r`. The iteration starts from the rigid preimage
/// under the joint that carries it onto the rest surface best (the one whose preimage is
/// nearest the rest surface among those weighted there), so a sleeve point starts on the
/// arm, not on the torso it passes near in the A-pose.
fn unposed_anchor(
    vertex: usize,
    body: &(impl SkinnedBody + ?Sized),
    transforms: &[Iso3; JOINT_COUNT],
    posed_point: &Vec3,
) -> Result<BodyAnchor> {
    let point = nalgebra::Point3::from(*posed_point);
    let mut rest_point = *posed_point;
    let mut best = Real::INFINITY;
    for (j, t) in transforms.iter().enumerate() {
        let candidate = t.inverse_transform_point(&point).coords;
        let off = body.distance(&candidate).abs();
        if off < best && body.skin_weights(&candidate).iter().any(|w| w.0 == j) {
            best = off;
            rest_point = candidate;
        }
    }
    for _ in 0..UNPOSE_STEPS {
        let weights = body.skin_weights(&rest_point);
        check_weights(vertex, &weights)?;
        let mut linear = Mat3::zeros();
        let mut shift = Vec3::zeros();
        for &(j, w) in &weights {
            linear += transforms[j].rotation.to_rotation_matrix().matrix() * w;
            shift += transforms[j].translation.vector * w;
        }
        let Some(inverse) = linear.try_inverse() else {
            return Err(Error::InvalidMesh(format!(
                "T-shirt vertex {vertex}: the body's blended skinning at {rest_point} cannot \
                 be inverted"
            )));
        };
        let next = inverse * (posed_point - shift);
        let moved = (next - rest_point).norm();
        rest_point = next;
        if moved < 1e-10 {
            break;
        }
    }
    let weights = body.skin_weights(&rest_point);
    check_weights(vertex, &weights)?;
    Ok(BodyAnchor {
        rest_point,
        weights,
    })
}

/// The most fixed-point steps of [`unposed_anchor`].
const UNPOSE_STEPS: usize = 32;

fn check_weights(vertex: usize, weights: &[(usize, Real)]) -> Result<()> {
    let sum: Real = weights.iter().map(|w| w.1).sum();
    let valid = weights
        .iter()
        .all(|&(j, w)| j < JOINT_COUNT && w.is_finite() && w >= 0.0);
    if weights.is_empty() || !valid || (sum - 1.0).abs() > 1e-6 {
        return Err(Error::InvalidMesh(format!(
            "the body's skin weights for T-shirt vertex {vertex} are unusable ({weights:?}): \
             they must name joints below {JOINT_COUNT} with non-negative weights summing to 1"
        )));
    }
    Ok(())
}

/// FNV-1a, 64 bits.
struct Fnv1a(u64);

impl Fnv1a {
    fn new() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

/// The shortest rest length of a fitted shirt's spring, as a fraction of its length in the
/// sewing pattern (`h` for structural springs, `h √2` for shear, `2h` for flexion, `h` the
/// grid spacing). The lofted sleeve tapers by compressing the pattern grid under the arm,
/// down to a tenth of the spacing where the underarm seam meets the side seam, but that is
/// where the cloth is placed when the shirt is dressed, not how much cloth there is: springs
/// that short put all of a raised arm's pull on a few slivers. Measured at default
/// resolution (Tulle, Cotton Jersey, Denim Light and Heavy): with both arms raised the
/// largest stretch was 5.5 on springs of 4 and 7 mm; with a floor of 0.5 the slivers'
/// neighbours still reached 1.4; with 0.7, 0.68. The median spring is 0.85 to 1.0 of its
/// pattern length, so 0.7 lengthens only the compressed tenth or so (0.9 would lengthen
/// every vertical spring of the torso).
pub const FITTED_MIN_REST_FRACTION: Real = 0.7;

/// Raises each spring's rest length to [`FITTED_MIN_REST_FRACTION`] of its pattern length
/// at grid spacing `h`.
fn floor_rest_lengths(springs: &mut [Spring], h: Real) {
    for s in springs {
        let pattern = match s.kind {
            SpringKind::StructuralHorizontal | SpringKind::StructuralVertical => h,
            SpringKind::Shear => h * std::f64::consts::SQRT_2,
            SpringKind::FlexionHorizontal | SpringKind::FlexionVertical => 2.0 * h,
        };
        s.rest_length = s.rest_length.max(FITTED_MIN_REST_FRACTION * pattern);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::capsule_body::CapsuleBody;
    use crate::body::pose::Pose;
    use crate::body::skeleton::Skeleton;
    use crate::garment::openings::Opening;
    use approx::assert_relative_eq;
    use std::collections::{HashMap, HashSet};
    use std::sync::OnceLock;

    fn body() -> &'static CapsuleBody {
        static BODY: OnceLock<CapsuleBody> = OnceLock::new();
        BODY.get_or_init(CapsuleBody::smpl_neutral)
    }

    /// The shirt of `style` at `resolution` on the neutral capsule body, built once.
    fn styled(style: GarmentStyle, resolution: Resolution) -> &'static Garment {
        static SHIRTS: OnceLock<Vec<Vec<Garment>>> = OnceLock::new();
        let all = SHIRTS.get_or_init(|| {
            GarmentStyle::ALL
                .iter()
                .map(|&g| {
                    Resolution::ALL
                        .iter()
                        .map(|&r| Garment::with_style(g, r, body()).unwrap())
                        .collect()
                })
                .collect()
        });
        let g = GarmentStyle::ALL.iter().position(|&g| g == style).unwrap();
        let r = Resolution::ALL
            .iter()
            .position(|&r| r == resolution)
            .unwrap();
        &all[g][r]
    }

    fn shirt(resolution: Resolution) -> &'static Garment {
        styled(GarmentStyle::Fitted, resolution)
    }

    fn edge_face_counts(mesh: &TriMesh) -> HashMap<(u32, u32), usize> {
        let mut count = HashMap::new();
        for f in &mesh.faces {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                *count.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        count
    }

    #[test]
    fn vertex_counts_match_the_resolutions() {
        let ranges = [(500, 900), (2000, 3000), (4000, 4600)];
        for (r, (lo, hi)) in Resolution::ALL.into_iter().zip(ranges) {
            let n = shirt(r).vertex_count();
            assert!(
                (lo..=hi).contains(&n),
                "{r}: {n} vertices, expected {lo}..={hi}"
            );
        }
    }

    #[test]
    fn mesh_is_manifold_with_four_openings() {
        for r in Resolution::ALL {
            let g = shirt(r);
            let count = edge_face_counts(&g.rest);
            assert!(
                count.values().all(|&c| c <= 2),
                "{r}: an edge has more than 2 faces"
            );
            // Union-find over boundary edges counts the loops independently of the garment.
            let boundary: Vec<(u32, u32)> = count
                .iter()
                .filter(|(_, c)| **c == 1)
                .map(|(e, _)| *e)
                .collect();
            let mut parent: HashMap<u32, u32> = HashMap::new();
            fn find(p: &mut HashMap<u32, u32>, x: u32) -> u32 {
                let up = *p.entry(x).or_insert(x);
                if up == x {
                    x
                } else {
                    let r = find(p, up);
                    p.insert(x, r);
                    r
                }
            }
            for &(a, b) in &boundary {
                let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
                parent.insert(ra, rb);
            }
            let keys: Vec<u32> = parent.keys().copied().collect();
            let roots: HashSet<u32> = keys.into_iter().map(|k| find(&mut parent, k)).collect();
            assert_eq!(roots.len(), 4, "{r}: boundary loops");
            let openings: HashSet<Opening> = g.boundary.iter().map(|b| b.opening).collect();
            assert_eq!(openings.len(), 4, "{r}: each opening once");
            let looped: usize = g.boundary.iter().map(|b| b.vertices.len()).sum();
            assert_eq!(
                looped,
                boundary.len(),
                "{r}: loops cover the boundary edges"
            );
        }
    }

    #[test]
    fn openings_are_where_a_shirt_has_them() {
        let g = styled(GarmentStyle::Boxy, Resolution::Coarse);
        for b in &g.boundary {
            let pts: Vec<Vec3> = b
                .vertices
                .iter()
                .map(|&i| g.rest.vertices[i as usize])
                .collect();
            let mean = pts.iter().sum::<Vec3>() / pts.len() as Real;
            match b.opening {
                Opening::Hem => assert!((-0.31..-0.24).contains(&mean.y), "hem at {mean}"),
                Opening::Neck => assert!(mean.y > 0.22 && mean.x.abs() < 0.02, "neck at {mean}"),
                Opening::LeftCuff => assert!((0.33..0.42).contains(&mean.x), "cuff at {mean}"),
                Opening::RightCuff => assert!((-0.42..-0.33).contains(&mean.x), "cuff at {mean}"),
            }
        }
    }

    #[test]
    fn springs_are_valid_and_unique() {
        for r in Resolution::ALL {
            let g = shirt(r);
            let h = r.grid_spacing();
            let kinds: HashSet<SpringKind> = g.springs.iter().map(|s| s.kind).collect();
            assert_eq!(kinds.len(), 5, "{r}: all spring kinds");
            let mut pairs = HashSet::new();
            let mut floored = 0;
            for s in &g.springs {
                assert!(s.a != s.b && (s.a as usize) < g.vertex_count());
                assert!((s.b as usize) < g.vertex_count());
                assert!(
                    pairs.insert((s.a.min(s.b), s.a.max(s.b))),
                    "{r}: duplicate {s:?}"
                );
                // Known gap: the armpit and the chest below the shoulder cap stretch the grid
                // up to ~1.8x (boxy) or ~2.4x (fitted, over the shoulder where the sleeve
                // turns down), so flexion springs reach ~4.5 spacings (target: 3).
                assert!(
                    s.rest_length > 0.0 && s.rest_length <= 5.0 * h,
                    "{r}: {s:?}"
                );
                // A spring is as long as in the rest shape, or (fitted) at least
                // FITTED_MIN_REST_FRACTION of its length in the pattern.
                let d = (g.rest.vertices[s.a as usize] - g.rest.vertices[s.b as usize]).norm();
                let pattern = match s.kind {
                    SpringKind::StructuralHorizontal | SpringKind::StructuralVertical => h,
                    SpringKind::Shear => h * std::f64::consts::SQRT_2,
                    _ => 2.0 * h,
                };
                assert_relative_eq!(s.rest_length, d.max(FITTED_MIN_REST_FRACTION * pattern));
                floored += usize::from(s.rest_length > d);
            }
            // The floor lengthens the springs the sleeve's loft compressed, not the shirt.
            assert!(
                floored > 0 && floored * 10 < g.springs.len(),
                "{r}: {floored} of {} springs floored",
                g.springs.len()
            );
            // Every mesh edge is a structural or shear spring.
            for &(a, b) in edge_face_counts(&g.rest).keys() {
                assert!(
                    pairs.contains(&(a, b)),
                    "{r}: mesh edge {a}-{b} has no spring"
                );
            }
        }
    }

    #[test]
    fn flexion_springs_fold_over_seams_but_not_openings() {
        let g = shirt(Resolution::Coarse);
        let crossing = g.springs.iter().filter(|s| {
            let pa = g.panels[s.a as usize];
            let pb = g.panels[s.b as usize];
            matches!(
                (pa, pb),
                (Panel::Front, Panel::Back) | (Panel::Back, Panel::Front)
            )
        });
        let mut n = 0;
        for s in crossing {
            n += 1;
            assert!(matches!(
                s.kind,
                SpringKind::FlexionVertical | SpringKind::FlexionHorizontal
            ));
        }
        assert!(n > 0, "no flexion spring crosses a seam");
        // Every front-back spring folds over a seam: some seam vertex is a mesh neighbour of
        // both ends (so none jumps across the neck, hem or cuffs).
        let mut neighbours: HashMap<u32, HashSet<u32>> = HashMap::new();
        for &(a, b) in edge_face_counts(&g.rest).keys() {
            neighbours.entry(a).or_default().insert(b);
            neighbours.entry(b).or_default().insert(a);
        }
        for s in &g.springs {
            if g.panels[s.a as usize] != Panel::Seam
                && g.panels[s.b as usize] != Panel::Seam
                && g.panels[s.a as usize] != g.panels[s.b as usize]
            {
                let folds = neighbours[&s.a]
                    .intersection(&neighbours[&s.b])
                    .any(|&m| g.panels[m as usize] == Panel::Seam);
                assert!(folds, "{s:?} connects the panels without a seam between");
            }
        }
    }

    #[test]
    fn faces_point_away_from_the_body() {
        for (style, r) in GarmentStyle::ALL
            .into_iter()
            .flat_map(|g| Resolution::ALL.map(|r| (g, r)))
        {
            let g = styled(style, r);
            let v = &g.rest.vertices;
            let t = Skeleton::smpl_neutral().skinning_transforms(&g.rest_pose);
            let on_body = g.body_points(&t);
            let outward = g
                .rest
                .faces
                .iter()
                .filter(|f| {
                    let [a, b, c] = f.map(|i| v[i as usize]);
                    let anchor: Vec3 = f.iter().map(|&i| on_body[i as usize]).sum::<Vec3>() / 3.0;
                    (b - a).cross(&(c - a)).dot(&((a + b + c) / 3.0 - anchor)) > 0.0
                })
                .count();
            let share = outward as Real / g.rest.face_count() as Real;
            assert!(
                share > 0.97,
                "{style} {r}: only {share:.3} of the faces point outward"
            );
        }
    }

    #[test]
    fn shirt_clears_the_body_and_anchors_are_on_it() {
        for (style, r) in GarmentStyle::ALL
            .into_iter()
            .flat_map(|g| Resolution::ALL.map(|r| (g, r)))
        {
            let g = styled(style, r);
            let posed = body().pose(&g.rest_pose);
            let min = g
                .rest
                .vertices
                .iter()
                .map(|p| posed.distance(p))
                .fold(Real::MAX, Real::min);
            assert!(min > MIN_BODY_CLEARANCE, "{r}: min body distance {min}");
            // The fitted shirt's anchors are the rest points the A-pose carries onto the posed
            // body (checked by `rest_pose_guess_reproduces_the_rest_mesh`); where the posed
            // union's blends differ from the skinned rest surface they sit off it.
            let tolerance = match style {
                GarmentStyle::Boxy => 3e-3,
                GarmentStyle::Fitted => 2.5e-2,
            };
            for a in &g.anchors {
                let off = body().distance(&a.rest_point).abs();
                // Two Newton steps on a smooth union of capsules (not an exact distance).
                assert!(
                    off < tolerance,
                    "{style} {r}: anchor {off} m off the body at {:?} weights {:?}",
                    a.rest_point,
                    a.weights
                );
                assert_relative_eq!(
                    a.weights.iter().map(|w| w.1).sum::<Real>(),
                    1.0,
                    epsilon = 1e-12
                );
            }
        }
    }

    #[test]
    fn a_body_too_big_for_its_skeleton_is_refused() {
        struct Fat(CapsuleBody);
        struct FatField(Box<dyn SignedDistance>);
        impl SignedDistance for FatField {
            fn distance_and_gradient(&self, p: &Vec3) -> (Real, Vec3) {
                let (d, g) = self.0.distance_and_gradient(p);
                (d - 0.06, g)
            }
        }
        impl PosableBody for Fat {
            fn posed_field(&self, pose: &Pose) -> Box<dyn SignedDistance + '_> {
                Box::new(FatField(Box::new(self.0.pose(pose))))
            }
        }
        impl SignedDistance for Fat {
            fn distance_and_gradient(&self, p: &Vec3) -> (Real, Vec3) {
                let (d, g) = self.0.distance_and_gradient(p);
                (d - 0.06, g)
            }
        }
        impl SkinnedBody for Fat {
            fn skeleton(&self) -> &Skeleton {
                self.0.skeleton()
            }
            fn skin_weights(&self, p: &Vec3) -> Vec<(usize, Real)> {
                self.0.skin_weights(p)
            }
        }
        for style in GarmentStyle::ALL {
            let fat = Fat(CapsuleBody::smpl_neutral());
            let err = Garment::with_style(style, Resolution::Coarse, &fat).unwrap_err();
            assert!(
                matches!(
                    err,
                    Error::GarmentInsideBody { .. } | Error::GarmentTooTight { .. }
                ) && err.to_string().contains("mm from the body"),
                "{style}: {err}"
            );
        }
    }

    #[test]
    fn boxy_hash_is_stable() {
        // Models trained on the boxy shirt (the revision-2 model shipped up to version 0.3)
        // record this hash; `Garment::for_template` must keep finding it.
        let g = styled(GarmentStyle::Boxy, Resolution::Default);
        assert_eq!(format!("{:016x}", g.template_hash()), "ceb0ce1e9253e424");
        assert_eq!(g.vertex_count(), 2687);
        assert_ne!(
            shirt(Resolution::Default).template_hash(),
            g.template_hash()
        );
    }

    #[test]
    fn fitted_mesh_is_mirror_symmetric() {
        use std::collections::BTreeSet;
        for r in Resolution::ALL {
            let g = shirt(r);
            let twin = g.mirror_twins();
            let v = &g.rest.vertices;
            for (k, &t) in twin.iter().enumerate() {
                assert_eq!(twin[t as usize] as usize, k, "{r}: twins pair up");
                let m = v[t as usize];
                assert!(
                    v[k].x == -m.x && v[k].y == m.y && v[k].z == m.z,
                    "{r}: vertex {k} {} is not the mirror of {t} {m}",
                    v[k]
                );
                assert_eq!(g.panels[k], g.panels[t as usize]);
            }
            // Mirroring reverses the winding, so compare faces as vertex sets.
            let key = |f: [u32; 3]| {
                let mut f = f;
                f.sort_unstable();
                f
            };
            let faces: BTreeSet<[u32; 3]> = g.rest.faces.iter().map(|&f| key(f)).collect();
            let mirrored: BTreeSet<[u32; 3]> = g
                .rest
                .faces
                .iter()
                .map(|f| key(f.map(|i| twin[i as usize])))
                .collect();
            assert_eq!(faces, mirrored, "{r}: triangulation is not symmetric");
            let springs: HashMap<(u32, u32), (SpringKind, u64)> = g
                .springs
                .iter()
                .map(|s| {
                    (
                        (s.a.min(s.b), s.a.max(s.b)),
                        (s.kind, s.rest_length.to_bits()),
                    )
                })
                .collect();
            for s in &g.springs {
                let (a, b) = (twin[s.a as usize], twin[s.b as usize]);
                assert_eq!(
                    springs.get(&(a.min(b), a.max(b))),
                    Some(&(s.kind, s.rest_length.to_bits())),
                    "{r}: spring {s:?} has no mirror twin"
                );
            }
        }
    }

    /// The neck opening's boundary loop.
    fn neck_loop(g: &Garment) -> &BoundaryLoop {
        g.boundary
            .iter()
            .find(|b| b.opening == Opening::Neck)
            .unwrap()
    }

    /// Each neck-loop vertex's distance to `posed` (metres).
    fn neck_gaps(g: &Garment, posed: &impl SignedDistance) -> Vec<Real> {
        neck_loop(g)
            .vertices
            .iter()
            .map(|&i| posed.distance(&g.rest.vertices[i as usize]))
            .collect()
    }

    #[test]
    fn neckline_hugs_the_neck() {
        for r in Resolution::ALL {
            let g = shirt(r);
            let posed = body().pose(&g.rest_pose);
            let gaps = neck_gaps(g, &posed);
            let max = gaps.iter().copied().fold(0.0, Real::max);
            let mean = gaps.iter().sum::<Real>() / gaps.len() as Real;
            assert!(
                gaps.iter().all(|&d| d > MIN_BODY_CLEARANCE),
                "{r}: neckline touches"
            );
            // Measured: mean ~20 mm, max ~42 mm (the front's lowest point, on the chest).
            assert!(
                mean < 0.025 && max < 0.05,
                "{r}: neckline gap mean {mean}, max {max} m"
            );
        }
    }

    #[test]
    fn template_hash_is_stable_and_tells_resolutions_apart() {
        let hashes: Vec<u64> = Resolution::ALL
            .iter()
            .map(|&r| shirt(r).template_hash())
            .collect();
        assert_eq!(hashes[0], shirt(Resolution::Coarse).template_hash());
        let rebuilt = Garment::tshirt(Resolution::Coarse, body()).unwrap();
        assert_eq!(
            rebuilt.template_hash(),
            hashes[0],
            "hash must not depend on the run"
        );
        assert_eq!(hashes.iter().collect::<HashSet<_>>().len(), 3);
    }

    #[test]
    fn zero_pose_keeps_the_boxy_rest_shape() {
        let g = styled(GarmentStyle::Boxy, Resolution::Coarse);
        assert_eq!(g.rest_pose, Pose::zero());
        let t = Skeleton::smpl_neutral().skinning_transforms(&Pose::zero());
        for (p, v) in g.posed_rest_guess(&t).iter().zip(&g.rest.vertices) {
            assert_relative_eq!(p, v, epsilon = 1e-12);
        }
        for (p, a) in g.body_points(&t).iter().zip(&g.anchors) {
            assert_relative_eq!(p, &a.rest_point, epsilon = 1e-12);
        }
    }

    #[test]
    fn rest_pose_guess_reproduces_the_rest_mesh() {
        let skeleton = Skeleton::smpl_neutral();
        for (style, r) in GarmentStyle::ALL
            .into_iter()
            .flat_map(|g| Resolution::ALL.map(|r| (g, r)))
        {
            let g = styled(style, r);
            let t = skeleton.skinning_transforms(&g.rest_pose);
            let worst = g
                .posed_rest_guess(&t)
                .iter()
                .zip(&g.rest.vertices)
                .map(|(p, v)| (p - v).norm())
                .fold(0.0, Real::max);
            assert!(
                worst < 1e-6,
                "{style} {r}: rest guess {worst} m off the rest mesh"
            );
            // Each anchor's rest point is the T-pose body point the rest pose carries onto
            // the posed body's surface.
            let posed = body().pose(&g.rest_pose);
            for p in g.body_points(&t) {
                let off = posed.distance(&p).abs();
                assert!(off < 3e-3, "{style} {r}: posed anchor {off} m off the body");
            }
        }
        assert_eq!(shirt(Resolution::Coarse).rest_pose, Pose::a_pose());
    }

    #[test]
    fn posing_moves_the_sleeves() {
        let g = shirt(Resolution::Coarse);
        let skeleton = Skeleton::smpl_neutral();
        let mut pose = g.rest_pose.clone();
        pose.set_joint(16, Vec3::new(0.0, 0.0, -1.3));
        let posed = g.posed_rest_guess(&skeleton.skinning_transforms(&pose));
        // The arm turns 0.5 rad further down about the shoulder: the cuff's centre drops
        // about 5 cm and swings in about 7 cm; the right cuff stays.
        let centre = |x: &[Vec3], opening: Opening| {
            let ring = &g
                .boundary
                .iter()
                .find(|b| b.opening == opening)
                .unwrap()
                .vertices;
            ring.iter().map(|&i| x[i as usize]).sum::<Vec3>() / ring.len() as Real
        };
        let moved = centre(&posed, Opening::LeftCuff) - centre(&g.rest.vertices, Opening::LeftCuff);
        assert!(
            moved.y < -0.03 && moved.x < -0.04,
            "left cuff moved {moved}"
        );
        let still =
            centre(&posed, Opening::RightCuff) - centre(&g.rest.vertices, Opening::RightCuff);
        assert!(still.norm() < 1e-9, "right cuff moved {still}");
    }

    #[test]
    #[ignore = "prints the fitted shirt's fit"]
    fn print_fit() {
        let posed = body().pose(&Pose::a_pose());
        for r in Resolution::ALL {
            let g = shirt(r);
            let d: Vec<Real> = g.rest.vertices.iter().map(|p| posed.distance(p)).collect();
            let min = d.iter().copied().fold(Real::MAX, Real::min);
            let max = d.iter().copied().fold(0.0, Real::max);
            let mut ratio: Vec<Real> = g
                .springs
                .iter()
                .filter(|s| {
                    s.kind == SpringKind::StructuralHorizontal
                        || s.kind == SpringKind::StructuralVertical
                })
                .map(|s| s.rest_length / r.grid_spacing())
                .collect();
            ratio.sort_by(Real::total_cmp);
            let neck = neck_loop(g);
            let gaps = neck_gaps(g, &posed);
            println!(
                "neck gap mean {:.1} max {:.1} mm, neck loop length {:.3} m",
                gaps.iter().sum::<Real>() / gaps.len() as Real * 1e3,
                gaps.iter().copied().fold(0.0, Real::max) * 1e3,
                neck.vertices
                    .iter()
                    .zip(neck.vertices.iter().cycle().skip(1))
                    .map(
                        |(&a, &b)| (g.rest.vertices[a as usize] - g.rest.vertices[b as usize])
                            .norm()
                    )
                    .sum::<Real>()
            );
            println!(
                "{r}: {} v, clearance {:.1}..{:.1} mm, structural/h {:.2} {:.2} {:.2} {:.2}",
                g.vertex_count(),
                min * 1e3,
                max * 1e3,
                ratio[0],
                ratio[ratio.len() / 100],
                ratio[ratio.len() * 99 / 100],
                ratio[ratio.len() - 1]
            );
            for b in &g.boundary {
                let c = b
                    .vertices
                    .iter()
                    .map(|&i| g.rest.vertices[i as usize])
                    .sum::<Vec3>()
                    / b.vertices.len() as Real;
                println!("  {:?} at {c:?}, {} vertices", b.opening, b.vertices.len());
            }
        }
        let g = shirt(Resolution::Default);
        crate::io::files::write_obj(std::path::Path::new("/tmp/fitted_default.obj"), &g.rest)
            .unwrap();
        for s in &g.springs {
            let ratio = s.rest_length / Resolution::Default.grid_spacing();
            if matches!(
                s.kind,
                SpringKind::StructuralHorizontal | SpringKind::StructuralVertical
            ) && !(0.5..=2.0).contains(&ratio)
                && g.rest.vertices[s.a as usize].x >= 0.0
            {
                let (ua, ub) = (g.uv[s.a as usize], g.uv[s.b as usize]);
                let h = Resolution::Default.grid_spacing();
                println!(
                    "{:?} {ratio:.2} ({:.0},{:.0})-({:.0},{:.0}) {:?} at {:.3?}",
                    s.kind,
                    ua[0] / h,
                    ua[1] / h,
                    ub[0] / h,
                    ub[1] / h,
                    g.panels[s.a as usize],
                    g.rest.vertices[s.a as usize]
                );
            }
        }
        use crate::io::render::*;
        let body_mesh = posed.mesh();
        for (view, yaw) in [
            ("front", 0.0),
            ("side", std::f64::consts::FRAC_PI_2),
            ("back", std::f64::consts::PI),
        ] {
            let items = [
                RenderItem {
                    mesh: &body_mesh,
                    shading: Shading::Uniform(BODY_COLOR),
                },
                RenderItem {
                    mesh: &g.rest,
                    shading: Shading::Uniform(GARMENT_COLOR),
                },
            ];
            let cam = Camera::framing(Vec3::new(-0.5, -0.4, -0.3), Vec3::new(0.5, 0.5, 0.3), yaw);
            let img = render(&items, &cam, &RenderSettings::default()).unwrap();
            save_png(
                std::path::Path::new(&format!("/tmp/fitted_rest_{view}.png")),
                &img,
            )
            .unwrap();
        }
    }

    #[test]
    fn masses_sum_to_density_times_area() {
        let g = shirt(Resolution::Coarse);
        let m = g.vertex_masses(0.2);
        assert!(m.iter().all(|&x| x > 0.0));
        let v = &g.rest.vertices;
        let area: Real = g
            .rest
            .faces
            .iter()
            .map(|f| {
                (v[f[1] as usize] - v[f[0] as usize])
                    .cross(&(v[f[2] as usize] - v[f[0] as usize]))
                    .norm()
                    / 2.0
            })
            .sum();
        assert_relative_eq!(m.iter().sum::<Real>(), 0.2 * area, epsilon = 1e-12);
        assert!((0.6..1.6).contains(&area), "a T-shirt of {area} m^2");
    }

    #[test]
    fn resolution_parses_and_prints() {
        for r in Resolution::ALL {
            assert_eq!(r.to_string().parse::<Resolution>().unwrap(), r);
            let json = serde_json::to_string(&r).unwrap();
            assert_eq!(serde_json::from_str::<Resolution>(&json).unwrap(), r);
        }
        assert_eq!(" Paper ".parse::<Resolution>().unwrap(), Resolution::Paper);
        assert!("fine".parse::<Resolution>().is_err());
    }

    /// Triangle quality and counts, for the report: `cargo test -p garmatnet-core --release
    /// -- --ignored --nocapture write_default_shirt_obj`.
    #[test]
    #[ignore = "writes /tmp/shirt_default.obj for inspection"]
    fn write_default_shirt_obj() {
        use std::fmt::Write as _;
        let body = body();
        for r in Resolution::ALL {
            let g = shirt(r);
            let min = g
                .rest
                .vertices
                .iter()
                .map(|p| body.distance(p))
                .fold(Real::MAX, Real::min);
            let mut per_kind = HashMap::new();
            for s in &g.springs {
                *per_kind.entry(format!("{:?}", s.kind)).or_insert(0) += 1;
            }
            let v = &g.rest.vertices;
            let mut worst_angle = Real::MAX;
            let (mut e_min, mut e_max) = (Real::MAX, 0.0 as Real);
            for f in &g.rest.faces {
                let p = f.map(|i| v[i as usize]);
                for k in 0..3 {
                    let (a, b, c) = (p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
                    worst_angle = worst_angle.min((b - a).angle(&(c - a)).to_degrees());
                    e_min = e_min.min((b - a).norm());
                    e_max = e_max.max((b - a).norm());
                }
            }
            println!(
                "{r}: {} vertices, {} faces, {} springs {per_kind:?}, min body distance \
                 {:.1} mm, min angle {worst_angle:.1} deg, edges {e_min:.4}..{e_max:.4} m",
                g.vertex_count(),
                g.rest.face_count(),
                g.springs.len(),
                min * 1e3
            );
        }
        let g = shirt(Resolution::Default);
        let mut obj = String::new();
        for p in &g.rest.vertices {
            writeln!(obj, "v {} {} {}", p.x, p.y, p.z).unwrap();
        }
        for f in &g.rest.faces {
            writeln!(obj, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1).unwrap();
        }
        std::fs::write("/tmp/shirt_default.obj", obj).unwrap();
    }
}
