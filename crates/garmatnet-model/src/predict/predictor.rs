//! The typed prediction API: pose + material in, garment mesh out.
//!
//! A garment vertex is its body anchor posed with the skeleton (linear blend skinning) plus
//! the predicted displacement D_fitting (+ D_local at full detail), paper eq. (1). With a
//! canonical-frame model the displacement is rotated into the world by the anchor's frame.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};

use burn::prelude::*;
use garmatnet_core::{
    BodyAnchor, CapsuleBody, DisplacementFrame, Garment, Iso3, JOINT_COUNT, Material, POSE_DIM,
    Pose, Real, Skeleton, SkinnedBody, TriMesh, Vec3,
};

use crate::error::{Error, Result};
use crate::file::model_file::GarMatNetModel;
use crate::net::garmatnet_net::MATERIAL_DIM;
use crate::net::tensor_util::{matrix, to_f32};
use crate::predict::material_range::{MaterialRange, TrainingFabric, nearest};
use crate::predict::push_out::PushOut;
use garmatnet_core::error::ensure_finite;

/// How much of the model to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, PartialOrd, Ord)]
pub enum Detail {
    /// The generally-fitting net only: a smooth garment (about half the cost).
    Smooth,
    /// Both nets: the smooth garment plus its wrinkles.
    #[default]
    Full,
}

impl std::fmt::Display for Detail {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Detail::Smooth => "smooth",
            Detail::Full => "full",
        })
    }
}

impl std::str::FromStr for Detail {
    type Err = Error;

    /// `full` or `smooth` (case-insensitive).
    ///
    /// # Errors
    /// [`Error::UnknownName`] for anything else.
    fn from_str(s: &str) -> Result<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "full" => Ok(Detail::Full),
            "smooth" => Ok(Detail::Smooth),
            _ => Err(Error::UnknownName {
                kind: "detail level",
                name: s.to_owned(),
                options: "full (both nets) or smooth (the fitting net only)",
            }),
        }
    }
}

/// A predicted garment: the template's topology with posed vertex positions (metres).
#[derive(Debug, Clone, PartialEq)]
pub struct GarmentMesh {
    /// Vertex positions (metres, world frame); never NaN.
    pub vertices: Vec<Vec3>,
    /// Triangles, counter-clockwise seen from outside: the template's, shared by every mesh
    /// a [`Predictor`] returns (a long sequence holds one copy, not one per frame).
    pub faces: Arc<[[u32; 3]]>,
}

impl GarmentMesh {
    /// The garment as a checked [`TriMesh`], for writing, rendering and measuring.
    ///
    /// # Errors
    /// As [`TriMesh::new`] (which a prediction always passes: finite vertices, the
    /// template's faces).
    pub fn into_tri_mesh(self) -> Result<TriMesh> {
        Ok(TriMesh::new(self.vertices, self.faces.to_vec())?)
    }
}

/// Distinguishes predictors, so caches built against one model are not reused with another.
static NEXT_PREDICTOR_ID: AtomicU64 = AtomicU64::new(1);

/// Predicts garments for one garment template with one trained model.
#[derive(Debug)]
pub struct Predictor {
    model: GarMatNetModel,
    faces: Arc<[[u32; 3]]>,
    anchors: Vec<BodyAnchor>,
    skeleton: Skeleton,
    device: Device,
    push_out: PushOut,
    body: Option<CapsuleBody>,
    /// Each vertex's mirror twin across the sagittal plane, when known.
    twins: Option<Arc<[u32]>>,
    /// Whether predictions are averaged with the mirror image of the mirrored pose's.
    mirror_averaging: bool,
    id: u64,
    /// [`GarMatNetModel::weights_fingerprint`], computed on first use.
    fingerprint: OnceLock<String>,
}

impl Predictor {
    /// A predictor for the garment template with `faces`, per-vertex body `anchors` and
    /// content hash `template_hash`, on `skeleton`, running on `device`.
    ///
    /// # Errors
    /// [`Error::TemplateMismatch`] if the model was trained for another template;
    /// [`Error::Core`] (invalid mesh) for faces past the vertices; [`Error::InvalidAnchor`]
    /// for an unusable anchor; [`Error::InvalidConfig`] for an inconsistent model.
    pub fn new(
        model: GarMatNetModel,
        faces: Vec<[u32; 3]>,
        anchors: Vec<BodyAnchor>,
        template_hash: &str,
        skeleton: Skeleton,
        device: &Device,
    ) -> Result<Self> {
        model.validate()?;
        model.ensure_template(template_hash, anchors.len())?;
        let n = anchors.len();
        if let Some((f, face)) = faces
            .iter()
            .enumerate()
            .find(|(_, f)| f.iter().any(|&i| i as usize >= n))
        {
            return Err(garmatnet_core::Error::InvalidMesh(format!(
                "face {f} = {face:?} indexes past the template's {n} vertices"
            ))
            .into());
        }
        for (i, a) in anchors.iter().enumerate() {
            let bad_joint = a
                .weights
                .iter()
                .any(|&(j, w)| j >= JOINT_COUNT || !w.is_finite());
            if a.weights.is_empty() || bad_joint || !a.rest_point.iter().all(|v| v.is_finite()) {
                return Err(Error::InvalidAnchor {
                    anchor: i,
                    joints: JOINT_COUNT,
                });
            }
        }
        let model = GarMatNetModel {
            fitting: model.fitting.valid().to_device(device),
            local: model.local.valid().to_device(device),
            ..model
        };
        let id = NEXT_PREDICTOR_ID.fetch_add(1, Ordering::Relaxed);
        Ok(Self {
            model,
            faces: faces.into(),
            anchors,
            skeleton,
            device: device.clone(),
            push_out: PushOut::default(),
            body: None,
            twins: None,
            mirror_averaging: false,
            id,
            fingerprint: OnceLock::new(),
        })
    }

    /// A predictor for `garment` worn by `body`: the usual way to build one. Predictions from
    /// [`Predictor::predict`] are pushed out of the posed body (on by default; see
    /// [`Predictor::with_push_out`]), and every prediction is mirror-averaged with the
    /// garment's mirror twins (on by default; see [`Predictor::with_mirror_averaging`]).
    ///
    /// # Errors
    /// [`Error::TemplateMismatch`] if the model was trained on another template, and the
    /// errors of [`Predictor::new`] and [`Predictor::with_mirror_twins`].
    pub fn for_garment(
        model: GarMatNetModel,
        garment: &Garment,
        body: CapsuleBody,
        device: &Device,
    ) -> Result<Self> {
        let mut predictor = Self::new(
            model,
            garment.rest.faces.clone(),
            garment.anchors.clone(),
            &garmatnet_core::TemplateInfo::of(garment).hash,
            body.skeleton().clone(),
            device,
        )?
        .with_mirror_twins(garment.mirror_twins())?;
        predictor.body = Some(body);
        Ok(predictor)
    }

    /// Gives the predictor the template's mirror twins (`twins[i]` is the vertex at vertex
    /// `i`'s mirror image across the sagittal plane x = 0, as [`Garment::mirror_twins`]
    /// lists them) and turns mirror averaging on. [`Predictor::for_garment`] does this
    /// itself; a predictor built with [`Predictor::new`] needs it for mirror averaging.
    ///
    /// # Errors
    /// [`Error::Core`] unless there is one twin per vertex; [`Error::InvalidMirrorTwins`]
    /// for a twin past the vertices or one whose own twin is another vertex.
    pub fn with_mirror_twins(mut self, twins: &[u32]) -> Result<Self> {
        let n = self.vertex_count();
        if twins.len() != n {
            return Err(garmatnet_core::Error::Mismatch {
                what: "mirror twins (one per template vertex)".into(),
                expected: format!("{n} twins"),
                got: format!("{} twins", twins.len()),
            }
            .into());
        }
        // A twin past the vertices is named before any pairing it breaks.
        let past = twins.iter().position(|&t| t as usize >= n);
        let unpaired = || (0..n).find(|&v| twins[twins[v] as usize] as usize != v);
        let wrong = past
            .map(|v| (v, "is past the template's vertices"))
            .or_else(|| unpaired().map(|v| (v, "has another vertex as its twin")));
        if let Some((vertex, problem)) = wrong {
            return Err(Error::InvalidMirrorTwins {
                vertex,
                twin: twins[vertex] as usize,
                vertices: n,
                problem,
            });
        }
        self.twins = Some(twins.into());
        self.with_mirror_averaging(true)
    }

    /// Turns mirror averaging on or off. With it on, every prediction at a pose θ is the
    /// mean of the nets' garment at θ and the mirror image (x → −x, each vertex taking its
    /// twin's displacement) of their garment at the mirrored pose ([`Pose::mirrored`]),
    /// each displacement measured from its own posed body anchor; push-out comes after the
    /// mean. A left-right symmetric pose then gets a left-right symmetric garment (to
    /// float rounding, on the library's mirror-symmetric body), and the mirrored pose the
    /// mirror image, at the
    /// cost of running the nets on twice the poses. [`Predictor::for_garment`] turns it on
    /// (for the fitted shirt's exact twins; a boxy-shirt model of versions up to 0.3 gets it
    /// too, where twins sit up to 6 mm from each other's mirror image at rest);
    /// its effect on accuracy is measured in book/src/experiments/everyday-symmetry.md. The
    /// result counts as a new predictor, as [`Predictor::with_push_out`]'s does.
    ///
    /// # Errors
    /// [`Error::NoMirrorTwins`] to turn it on for a predictor without mirror twins
    /// ([`Predictor::with_mirror_twins`]).
    pub fn with_mirror_averaging(mut self, on: bool) -> Result<Self> {
        if on && self.twins.is_none() {
            return Err(Error::NoMirrorTwins);
        }
        self.mirror_averaging = on;
        self.id = NEXT_PREDICTOR_ID.fetch_add(1, Ordering::Relaxed);
        Ok(self)
    }

    /// Whether predictions are mirror-averaged ([`Predictor::with_mirror_averaging`]).
    #[must_use]
    pub fn mirror_averaging(&self) -> bool {
        self.mirror_averaging
    }

    /// The mirror twins when mirror averaging is on.
    pub(crate) fn averaging_twins(&self) -> Option<&[u32]> {
        self.twins.as_deref().filter(|_| self.mirror_averaging)
    }

    /// Predicts the garment for `pose` in `material`, pushed out of the posed body when the
    /// predictor knows the body ([`Predictor::for_garment`]) and push-out is enabled.
    ///
    /// # Errors
    /// [`Error::Core`] for a non-finite pose or a material that is not finite or outside the
    /// material bounds (the message names the component and its range);
    /// [`Error::NonFiniteOutput`] if the nets produce NaN.
    pub fn predict(&self, pose: &Pose, material: &Material, detail: Detail) -> Result<GarmentMesh> {
        material.validate()?;
        let normalized = material.to_normalized();
        match &self.body {
            Some(body) => Ok(self
                .predict_on_body(pose, &normalized, detail, &body.pose(pose))?
                .0),
            None => self.predict_normalized(pose, &normalized, detail),
        }
    }

    /// The body this predictor's garment is worn by, if it was built with
    /// [`Predictor::for_garment`].
    #[must_use]
    pub fn body(&self) -> Option<&CapsuleBody> {
        self.body.as_ref()
    }

    /// Sets the body push-out of [`Predictor::predict`], the sequences, [`crate::Scene`]
    /// and [`Predictor::predict_on_body`]. The result counts as a new predictor: a scene
    /// updated with it recomputes every character, so none keeps the old setting's output.
    ///
    /// # Errors
    /// [`Error::Core`] for a clearance outside [`PushOut::validate`]'s range.
    pub fn with_push_out(mut self, push_out: PushOut) -> Result<Self> {
        push_out.validate()?;
        self.push_out = push_out;
        self.id = NEXT_PREDICTOR_ID.fetch_add(1, Ordering::Relaxed);
        Ok(self)
    }

    /// The body push-out [`Predictor::predict`] applies when the predictor knows its body
    /// ([`Predictor::with_push_out`] sets it; on by default, 2 mm at the vertices).
    #[must_use]
    pub fn push_out_settings(&self) -> PushOut {
        self.push_out
    }

    /// The model.
    #[must_use]
    pub fn model(&self) -> &GarMatNetModel {
        &self.model
    }

    /// The box of normalised materials the model was trained on, when its file records it
    /// (models trained before it was recorded do not). A
    /// material outside it ([`MaterialRange::outside`]) is an extrapolation: expect larger
    /// errors there.
    #[must_use]
    pub fn material_range(&self) -> Option<&MaterialRange> {
        self.model.meta.provenance.material_range.as_ref()
    }

    /// The fabrics the model was trained on, in its training dataset's order; empty when its
    /// file does not record them (models trained before they were recorded).
    #[must_use]
    pub fn training_fabrics(&self) -> &[TrainingFabric] {
        &self.model.meta.provenance.training_fabrics
    }

    /// The training fabric nearest to `material` in normalised ω, with its distance (the
    /// first on a tie; `None` when the file records no training fabrics). The model has
    /// learned the drapes of its training fabrics; between them it interpolates, and its
    /// error can grow with the distance to the nearest one. On revision 2's walks, Table 2's
    /// four targets erred 8.2 mm at 0.07 and 16–21 mm at 0.33–0.46, against 8.2 mm for the
    /// training fabrics themselves at poses the model never saw, and about twice the error
    /// at [`crate::FAR_FROM_TRAINING`] and beyond (book/src/api.md). On revision 3's
    /// independent poses the error is flat in the distance up to 0.40 and grows beyond it
    /// (book/src/results.md).
    #[must_use]
    pub fn nearest_training_fabric(&self, material: &Material) -> Option<(&TrainingFabric, Real)> {
        let omega = material.to_normalized();
        nearest(&omega, self.training_fabrics().iter().map(|f| (f, f.omega)))
    }

    /// The device the nets run on.
    #[must_use]
    pub fn device(&self) -> &Device {
        &self.device
    }

    /// The garment template's faces.
    #[must_use]
    pub fn faces(&self) -> &[[u32; 3]] {
        &self.faces
    }

    /// The number of garment vertices n.
    #[must_use]
    pub fn vertex_count(&self) -> usize {
        self.anchors.len()
    }

    pub(crate) fn id(&self) -> u64 {
        self.id
    }

    /// Gives a test predictor a body to push out of, as [`Predictor::for_garment`] does.
    #[cfg(test)]
    pub(crate) fn set_test_body(&mut self, body: CapsuleBody) {
        self.body = Some(body);
    }

    /// The model's [`GarMatNetModel::weights_fingerprint`], computed once per predictor. A
    /// [`crate::FabricCalibration`] records it and is refused by a model with other weights.
    #[must_use]
    pub fn model_fingerprint(&self) -> &str {
        self.fingerprint
            .get_or_init(|| self.model.weights_fingerprint())
    }

    /// Predicts the garment for `pose` and normalised material coordinates ω ∈ [0, 1]⁶.
    ///
    /// # Errors
    /// [`Error::Core`] for a non-finite pose or a material coordinate that is NaN or outside
    /// [0, 1]; [`Error::NonFiniteOutput`] if the nets produce NaN.
    pub fn predict_normalized(
        &self,
        pose: &Pose,
        material: &[Real; MATERIAL_DIM],
        detail: Detail,
    ) -> Result<GarmentMesh> {
        let mut out = self.predict_batch(&[(pose.clone(), *material)], detail)?;
        Ok(out.remove(0))
    }

    /// Predicts many garments in one batched forward pass per net.
    ///
    /// # Errors
    /// As [`Predictor::predict_normalized`], for the first bad item.
    pub fn predict_batch(
        &self,
        items: &[(Pose, [Real; MATERIAL_DIM])],
        detail: Detail,
    ) -> Result<Vec<GarmentMesh>> {
        if items.is_empty() {
            return Ok(Vec::new());
        }
        for (pose, material) in items {
            validate_inputs(pose, material)?;
        }
        let poses: Vec<&Pose> = items.iter().map(|(p, _)| p).collect();
        let mirrored = self.mirrored_poses(&poses);
        let rows: Vec<(&Pose, &[Real; MATERIAL_DIM])> = items
            .iter()
            .map(|(p, m)| (p, m))
            .chain(mirrored.iter().zip(items.iter().map(|(_, m)| m)))
            .collect();
        let (pose_t, material_t) = self.input_tensors(rows.into_iter());
        let fitting = to_f32(
            self.model
                .fitting
                .forward(pose_t.clone(), material_t.clone()),
        );
        let local = match detail {
            Detail::Full => Some(to_f32(self.model.local.forward(pose_t, material_t))),
            Detail::Smooth => None,
        };
        self.garments_from_rows(
            &poses,
            &mirrored,
            (&fitting, local.as_deref()),
            "batch item",
        )
    }

    /// `poses`' mirror images when mirror averaging is on (the nets' rows B..2B), else none.
    pub(crate) fn mirrored_poses(&self, poses: &[&Pose]) -> Vec<Pose> {
        match self.averaging_twins() {
            Some(_) => poses.iter().map(|p| p.mirrored()).collect(),
            None => Vec::new(),
        }
    }

    /// The whole garments of `poses` from the nets' normalised outputs (`[rows, 3n]`: row `b`
    /// for `poses[b]`, then, with mirror averaging, row `B + b` for `mirrored[b]`), each
    /// mirror-averaged when `mirrored` is not empty; `what` names an item in errors.
    pub(crate) fn garments_from_rows(
        &self,
        poses: &[&Pose],
        mirrored: &[Pose],
        (fitting, local): (&[f32], Option<&[f32]>),
        what: &str,
    ) -> Result<Vec<GarmentMesh>> {
        let n3 = 3 * self.vertex_count();
        // Row `row`'s denormalised displacements (fitting, local).
        let row = |row: usize| {
            let range = row * n3..(row + 1) * n3;
            (
                self.model.fitting_norm.denormalize(&fitting[range.clone()]),
                local.map(|l| self.model.local_norm.denormalize(&l[range])),
            )
        };
        poses
            .iter()
            .enumerate()
            .map(|(b, pose)| {
                let own = row(b);
                let other = (!mirrored.is_empty()).then(|| row(poses.len() + b));
                let vertices = self.assemble(
                    pose,
                    (&own.0, own.1.as_deref()),
                    other.as_ref().map(|(f, l)| (f.as_slice(), l.as_deref())),
                    None,
                    &format!("{what} {b}"),
                )?;
                Ok(GarmentMesh {
                    vertices,
                    faces: Arc::clone(&self.faces),
                })
            })
            .collect()
    }

    /// The garment's body points for `pose`: every anchor posed by linear blend skinning.
    #[must_use]
    pub fn body_points(&self, pose: &Pose) -> Vec<Vec3> {
        let t = self.skeleton.skinning_transforms(pose);
        self.anchors.iter().map(|a| a.posed_point(&t)).collect()
    }

    /// `[B, 72]` pose and `[B, 6]` material tensors on the predictor's device.
    pub(crate) fn input_tensors<'a>(
        &self,
        items: impl ExactSizeIterator<Item = (&'a Pose, &'a [Real; MATERIAL_DIM])>,
    ) -> (Tensor<2>, Tensor<2>) {
        let b = items.len();
        let mut poses = Vec::with_capacity(b * POSE_DIM);
        let mut materials = Vec::with_capacity(b * MATERIAL_DIM);
        for (p, m) in items {
            poses.extend(p.to_vec().iter().map(|&v| v as f32));
            materials.extend(m.iter().map(|&v| v as f32));
        }
        (
            matrix(poses, b, POSE_DIM, &self.device),
            matrix(materials, b, MATERIAL_DIM, &self.device),
        )
    }

    /// Garment vertices at `pose` from denormalised displacements `own` (fitting, local;
    /// metres, the model's frame), for all vertices or the subset `vertices` (then
    /// `fitting[3i..3i+3]` belongs to `vertices[i]`). With `mirrored`, the nets'
    /// displacements at the mirrored pose (of the subset's twins, in the subset's order, or of
    /// every vertex), and mirror averaging on, each vertex's world displacement is the mean of
    /// its own and the mirror image of its twin's there ([`Predictor::with_mirror_averaging`]).
    pub(crate) fn assemble(
        &self,
        pose: &Pose,
        own: (&[Real], Option<&[Real]>),
        mirrored: Option<(&[Real], Option<&[Real]>)>,
        vertices: Option<&[usize]>,
        what: &str,
    ) -> Result<Vec<Vec3>> {
        let transforms: [Iso3; JOINT_COUNT] = self.skeleton.skinning_transforms(pose);
        let mut d = self.world_displacements(&transforms, own, vertices, what)?;
        if let (Some(twins), Some(mirrored)) = (self.averaging_twins(), mirrored) {
            let at = self.skeleton.skinning_transforms(&pose.mirrored());
            let twin_ids: Option<Vec<usize>> =
                vertices.map(|s| s.iter().map(|&v| twins[v] as usize).collect());
            let what = format!("{what}, at the mirrored pose");
            let e = self.world_displacements(&at, mirrored, twin_ids.as_deref(), &what)?;
            for (k, dk) in d.iter_mut().enumerate() {
                let ek = if vertices.is_some() {
                    e[k]
                } else {
                    e[twins[k] as usize]
                };
                *dk = 0.5 * (*dk + Vec3::new(-ek.x, ek.y, ek.z));
            }
        }
        Ok(d.into_iter()
            .enumerate()
            .map(|(k, dk)| self.anchors[vertices.map_or(k, |s| s[k])].posed_point(&transforms) + dk)
            .collect())
    }

    /// World-frame displacements (metres) from the nets' denormalised ones at the pose with
    /// skinning `transforms`, as [`Predictor::assemble`] reads them.
    ///
    /// # Errors
    /// [`Error::NonFiniteOutput`] naming `what` and the first vertex that is not finite.
    fn world_displacements(
        &self,
        transforms: &[Iso3; JOINT_COUNT],
        (fitting, local): (&[Real], Option<&[Real]>),
        vertices: Option<&[usize]>,
        what: &str,
    ) -> Result<Vec<Vec3>> {
        let frame = self.model.displacement_frame();
        let count = vertices.map_or(self.vertex_count(), <[usize]>::len);
        let mut out = Vec::with_capacity(count);
        for i in 0..count {
            let v = vertices.map_or(i, |s| s[i]);
            let mut d = Vec3::new(fitting[3 * i], fitting[3 * i + 1], fitting[3 * i + 2]);
            if let Some(l) = local {
                d += Vec3::new(l[3 * i], l[3 * i + 1], l[3 * i + 2]);
            }
            if frame == DisplacementFrame::Canonical {
                d = self.anchors[v].from_frame(&d, frame, transforms);
            }
            if !d.iter().all(|c| c.is_finite()) {
                return Err(Error::NonFiniteOutput {
                    what: what.to_owned(),
                    vertex: v,
                });
            }
            out.push(d);
        }
        Ok(out)
    }
}

/// A finite pose and a material inside the unit cube.
pub(crate) fn validate_inputs(
    pose: &Pose,
    material: &[Real; MATERIAL_DIM],
) -> garmatnet_core::Result<()> {
    pose.validate()?;
    validate_material(material)
}

/// Checks every pose of a sequence before any prediction.
///
/// # Errors
/// [`Error::InvalidPose`] for the first unusable pose, with its index.
pub(crate) fn validate_poses(poses: &[Pose]) -> Result<()> {
    for (index, pose) in poses.iter().enumerate() {
        pose.validate()
            .map_err(|source| Error::InvalidPose { index, source })?;
    }
    Ok(())
}

/// Checks a normalised material: six finite values in [0, 1].
pub(crate) fn validate_material(material: &[Real; MATERIAL_DIM]) -> garmatnet_core::Result<()> {
    ensure_finite("normalised material coordinates", material.iter().copied())?;
    if let Some((i, &v)) = material
        .iter()
        .enumerate()
        .find(|(_, v)| !(0.0..=1.0).contains(*v))
    {
        return Err(garmatnet_core::Error::OutOfRange {
            what: format!("normalised material coordinate {i}"),
            value: v,
            min: 0.0,
            max: 1.0,
            hint: "; normalise the material with Material::to_normalized".into(),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::small_predictor as predictor;
    use crate::test_util::{
        cpu, small_model, test_anchors, test_faces, test_predictor, test_twins,
    };
    use crate::{GarMatNetConfig, GarMatNetModel};
    use approx::assert_relative_eq;
    use garmatnet_core::{JointLimits, Resolution, SplitMix64, TemplateInfo};

    /// Untrained nets (random weights: a garment far from symmetric) for the coarse fitted
    /// T-shirt, whose template is mirror-symmetric, with mirror averaging as built.
    fn tshirt_predictor(frame: DisplacementFrame) -> (Predictor, Garment) {
        let dev = cpu();
        let body = CapsuleBody::smpl_neutral();
        let garment = Garment::tshirt(Resolution::Coarse, &body).unwrap();
        let mut config = GarMatNetConfig::new(garment.vertex_count(), 8, 4, 8);
        config.displacement_frame = frame;
        let model = GarMatNetModel::untrained(&config, TemplateInfo::of(&garment), &dev);
        let p = Predictor::for_garment(model, &garment, body, &dev).unwrap();
        (p, garment)
    }

    /// Each vertex's displacement (metres) from its posed body anchor, without push-out.
    fn displacements(p: &Predictor, pose: &Pose, omega: &[Real; 6]) -> Vec<Vec3> {
        let mesh = p.predict_normalized(pose, omega, Detail::Full).unwrap();
        p.body_points(pose)
            .iter()
            .zip(&mesh.vertices)
            .map(|(a, v)| v - a)
            .collect()
    }

    /// Mean over vertices of |d_i - mirror(e_twin(i))| (metres).
    fn mirror_gap(d: &[Vec3], e: &[Vec3], twins: &[u32]) -> Real {
        let total: Real = d
            .iter()
            .zip(twins)
            .map(|(di, &t)| {
                let et = e[t as usize];
                (di - Vec3::new(-et.x, et.y, et.z)).norm()
            })
            .sum();
        total / d.len() as Real
    }

    #[test]
    fn mirror_averaging_gives_the_mirrored_pose_the_mirror_image() {
        let omega = [0.3, 0.7, 0.2, 0.5, 0.9, 0.4];
        let theta = JointLimits::default().sample(&mut SplitMix64::new(3), 1.0);
        let symmetric = Pose::a_pose();
        assert_eq!(symmetric.mirrored(), symmetric);
        for frame in [DisplacementFrame::World, DisplacementFrame::Canonical] {
            let (on, garment) = tshirt_predictor(frame);
            assert!(on.mirror_averaging(), "for_garment turns it on");
            let twins = garment.mirror_twins();
            let d = displacements(&on, &theta, &omega);
            let scale = d.iter().map(Vec3::norm).sum::<Real>() / d.len() as Real;
            assert!(scale > 1e-3, "{scale}");
            let gap = mirror_gap(&d, &displacements(&on, &theta.mirrored(), &omega), twins);
            assert!(gap < 1e-5 * scale, "{frame:?}: {gap} against {scale}");
            let sym = displacements(&on, &symmetric, &omega);
            assert!(mirror_gap(&sym, &sym, twins) < 1e-5 * scale, "{frame:?}");

            // Without it the random nets are far from symmetric, so the checks above can fail.
            let off = on.with_mirror_averaging(false).unwrap();
            assert!(!off.mirror_averaging());
            let raw = displacements(&off, &symmetric, &omega);
            assert!(mirror_gap(&raw, &raw, twins) > 0.05 * scale, "{frame:?}");
            // The average is the mean of the raw garment and its mirrored pose's mirror image.
            for (i, &t) in twins.iter().enumerate().step_by(97) {
                let r = raw[t as usize];
                let expected = 0.5 * (raw[i] + Vec3::new(-r.x, r.y, r.z));
                assert_relative_eq!(sym[i], expected, epsilon = 1e-5 * scale);
            }
        }
    }

    #[test]
    fn mirror_averaging_needs_twins_that_pair_the_vertices() {
        let p = || predictor(1, DisplacementFrame::World);
        assert!(!p().mirror_averaging(), "Predictor::new knows no twins");
        assert!(matches!(
            p().with_mirror_averaging(true),
            Err(Error::NoMirrorTwins)
        ));
        assert!(matches!(
            p().with_mirror_twins(&[0, 1]),
            Err(Error::Core(garmatnet_core::Error::Mismatch { .. }))
        ));
        let mut unpaired = test_twins();
        unpaired[0] = 2;
        match p().with_mirror_twins(&unpaired) {
            Err(Error::InvalidMirrorTwins {
                vertex: 0,
                twin: 2,
                problem,
                ..
            }) => assert!(problem.contains("another vertex"), "{problem}"),
            other => panic!("{other:?}"),
        }
        let mut past = test_twins();
        past[5] = 1000;
        assert!(matches!(
            p().with_mirror_twins(&past),
            Err(Error::InvalidMirrorTwins {
                vertex: 5,
                twin: 1000,
                ..
            })
        ));
        let on = p().with_mirror_twins(&test_twins()).unwrap();
        assert!(on.mirror_averaging());
        let (id, omega, pose) = (on.id(), [0.5; 6], Pose::a_pose());
        let averaged = on.predict_normalized(&pose, &omega, Detail::Full).unwrap();
        let off = on.with_mirror_averaging(false).unwrap();
        assert_ne!(off.id(), id, "a scene must not keep the averaged outputs");
        assert_ne!(
            off.predict_normalized(&pose, &omega, Detail::Full).unwrap(),
            averaged
        );
    }

    #[test]
    fn detail_parses_its_display_and_rejects_others() {
        for d in [Detail::Full, Detail::Smooth] {
            assert_eq!(d.to_string().parse::<Detail>().ok(), Some(d));
        }
        assert_eq!(" SMOOTH ".parse::<Detail>().ok(), Some(Detail::Smooth));
        let err = "wrinkly".parse::<Detail>().expect_err("unknown level");
        assert!(
            matches!(&err, Error::UnknownName { kind: "detail level", name, .. } if name == "wrinkly"),
            "{err}"
        );
        assert!(err.to_string().contains("use full"), "{err}");
    }

    fn random_material(rng: &mut SplitMix64) -> [Real; 6] {
        std::array::from_fn(|_| rng.next_f64())
    }

    #[test]
    fn the_nearest_training_fabric_is_found_by_normalised_omega() {
        let dev = cpu();
        let without = test_predictor(small_model(7, None, &dev), &dev);
        let linen = Material::preset("Linen").unwrap();
        assert!(without.training_fabrics().is_empty());
        assert!(without.nearest_training_fabric(&linen).is_none());

        let mut model = small_model(7, None, &dev);
        model.meta.provenance.training_fabrics = ["Denim Heavy", "Linen", "Silk Chiffon"]
            .map(|name| TrainingFabric {
                name: name.into(),
                omega: Material::preset(name).unwrap().to_normalized(),
            })
            .into();
        let with = test_predictor(model, &dev);
        assert_eq!(with.training_fabrics().len(), 3);
        let (fabric, distance) = with.nearest_training_fabric(&linen).unwrap();
        assert_eq!((fabric.name.as_str(), distance), ("Linen", 0.0));
        // Tulle is nearest Silk Chiffon, at the distance of their normalised ω.
        let tulle = Material::preset("Tulle").unwrap();
        let (fabric, distance) = with.nearest_training_fabric(&tulle).unwrap();
        assert_eq!(fabric.name, "Silk Chiffon");
        let (a, b) = (
            tulle.to_normalized(),
            Material::preset("Silk Chiffon").unwrap().to_normalized(),
        );
        let expected = a
            .iter()
            .zip(&b)
            .map(|(x, y)| (x - y) * (x - y))
            .sum::<Real>();
        assert_relative_eq!(distance, expected.sqrt(), epsilon = 1e-12);
        assert!(distance > 0.0);
    }

    #[test]
    fn predictions_are_finite_and_batch_matches_single() {
        // With mirror averaging too: each item's mirrored pose sits B rows further down.
        for mirror in [false, true] {
            let p = predictor(1, DisplacementFrame::World);
            let p = if mirror {
                p.with_mirror_twins(&test_twins()).unwrap()
            } else {
                p
            };
            batch_matches_single(&p);
        }
    }

    fn batch_matches_single(p: &Predictor) {
        let mut rng = SplitMix64::new(9);
        let limits = JointLimits::default();
        let items: Vec<_> = (0..4)
            .map(|_| (limits.sample(&mut rng, 1.0), random_material(&mut rng)))
            .collect();
        let batch = p.predict_batch(&items, Detail::Full).unwrap();
        for ((pose, m), mesh) in items.iter().zip(&batch) {
            assert_eq!(mesh.vertices.len(), 50);
            assert!(
                mesh.vertices
                    .iter()
                    .all(|v| v.iter().all(|c| c.is_finite()))
            );
            let single = p.predict_normalized(pose, m, Detail::Full).unwrap();
            for (a, b) in single.vertices.iter().zip(&mesh.vertices) {
                assert_relative_eq!(a, b, epsilon = 1e-5);
            }
        }
    }

    #[test]
    fn smooth_detail_is_body_plus_fitting_displacement() {
        let p = predictor(2, DisplacementFrame::World);
        let pose = Pose::zero();
        let m = [0.5; 6];
        let smooth = p.predict_normalized(&pose, &m, Detail::Smooth).unwrap();
        let full = p.predict_normalized(&pose, &m, Detail::Full).unwrap();
        let (pt, mt) = p.input_tensors([(&pose, &m)].into_iter());
        let loc = p
            .model
            .local_norm
            .denormalize(&to_f32(p.model.local.forward(pt, mt)));
        for i in 0..50 {
            let d = full.vertices[i] - smooth.vertices[i];
            assert_relative_eq!(
                d,
                Vec3::new(loc[3 * i], loc[3 * i + 1], loc[3 * i + 2]),
                epsilon = 1e-9
            );
        }
    }

    #[test]
    fn canonical_frame_rotates_displacements_with_the_body() {
        let world = predictor(3, DisplacementFrame::World);
        let canon = predictor(3, DisplacementFrame::Canonical);
        let m = [0.3; 6];
        // At the rest pose every anchor frame is the identity: both frames agree.
        let a = world
            .predict_normalized(&Pose::zero(), &m, Detail::Full)
            .unwrap();
        let b = canon
            .predict_normalized(&Pose::zero(), &m, Detail::Full)
            .unwrap();
        for (x, y) in a.vertices.iter().zip(&b.vertices) {
            assert_relative_eq!(x, y, epsilon = 1e-9);
        }
        let mut pose = Pose::zero();
        pose.set_joint(0, Vec3::new(0.0, 1.0, 0.0));
        let a = world.predict_normalized(&pose, &m, Detail::Full).unwrap();
        let b = canon.predict_normalized(&pose, &m, Detail::Full).unwrap();
        let body = canon.body_points(&pose);
        let moved = a
            .vertices
            .iter()
            .zip(&b.vertices)
            .any(|(x, y)| (x - y).norm() > 1e-4);
        assert!(moved, "a rotated root must rotate canonical displacements");
        for ((x, y), p) in a.vertices.iter().zip(&b.vertices).zip(&body) {
            // Same displacement length: only its direction changes.
            assert_relative_eq!((x - p).norm(), (y - p).norm(), epsilon = 1e-9);
        }
    }

    #[test]
    fn bad_inputs_are_typed_errors() {
        let p = predictor(4, DisplacementFrame::World);
        let mut m = [0.5; 6];
        m[2] = f64::NAN;
        assert!(matches!(
            p.predict_normalized(&Pose::zero(), &m, Detail::Full),
            Err(Error::Core(garmatnet_core::Error::NonFinite { .. }))
        ));
        m[2] = 1.5;
        let err = p
            .predict_normalized(&Pose::zero(), &m, Detail::Full)
            .unwrap_err();
        assert!(
            matches!(err, Error::Core(garmatnet_core::Error::OutOfRange { .. })),
            "{err}"
        );
        let mut pose = Pose::zero();
        pose.set_joint(5, Vec3::new(f64::NAN, 0.0, 0.0));
        assert!(
            p.predict_normalized(&pose, &[0.5; 6], Detail::Smooth)
                .is_err()
        );
    }

    #[test]
    fn non_finite_outputs_are_reported() {
        let dev = cpu();
        let mut model = small_model(5, None, &dev);
        // A diverged net (NaN weights straight from training, never from a file).
        let nan = Tensor::<1>::full([150], f32::NAN, &dev);
        model.fitting.output.bias = Some(burn::module::Param::from_tensor(nan));
        let p = test_predictor(model, &dev);
        let err = p
            .predict_normalized(&Pose::zero(), &[0.5; 6], Detail::Smooth)
            .unwrap_err();
        assert!(matches!(err, Error::NonFiniteOutput { .. }), "{err}");
        // A sequence yields the failure once and ends.
        let poses = vec![Pose::zero(); crate::SEQUENCE_BATCH + 1];
        let silk = Material::preset("Silk Chiffon").unwrap();
        let mut stream = p.sequence(&poses, &silk, Detail::Smooth).unwrap();
        assert!(matches!(
            stream.next(),
            Some(Err(Error::NonFiniteOutput { .. }))
        ));
        assert!(stream.next().is_none());
        assert_eq!(stream.size_hint(), (0, Some(0)));
        assert!(p.predict_sequence(&poses, &silk, Detail::Smooth).is_err());
    }

    #[test]
    fn construction_refuses_other_templates_and_bad_faces() {
        let dev = cpu();
        let model = || small_model(6, None, &dev);
        let sk = Skeleton::smpl_neutral;
        assert!(matches!(
            Predictor::new(model(), test_faces(), test_anchors(), "other", sk(), &dev),
            Err(Error::TemplateMismatch { .. })
        ));
        assert!(
            Predictor::new(
                model(),
                vec![[0, 1, 50]],
                test_anchors(),
                "test-template",
                sk(),
                &dev
            )
            .is_err()
        );
        let mut anchors = test_anchors();
        anchors[3].weights.clear();
        assert!(matches!(
            Predictor::new(model(), test_faces(), anchors, "test-template", sk(), &dev),
            Err(Error::InvalidAnchor { anchor: 3, .. })
        ));
    }

    /// GPU (wgpu) predictions equal CPU predictions, for both pose encodings; CI runs it on
    /// lavapipe.
    #[cfg(feature = "wgpu")]
    #[test]
    fn wgpu_predictions_match_cpu() {
        for encoding in crate::PoseEncoding::ALL {
            wgpu_predictions_match_cpu_with(encoding);
        }
    }

    #[cfg(feature = "wgpu")]
    fn wgpu_predictions_match_cpu_with(encoding: crate::PoseEncoding) {
        let cpu_dev = cpu();
        let gpu = crate::select_device("gpu").unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.safetensors");
        let mut model = small_model(31, Some(4), &cpu_dev);
        if !encoding.is_axis_angle() {
            for net in [&mut model.fitting, &mut model.local] {
                *net = net
                    .config()
                    .clone()
                    .with_pose_encoding(encoding)
                    .init(&cpu_dev);
            }
        }
        model.save(&path).unwrap();
        let make = |dev: &Device| {
            let model = GarMatNetModel::load(&path, dev).unwrap();
            test_predictor(model, dev)
        };
        let (on_cpu, on_gpu) = (make(&cpu_dev), make(&gpu));
        let mut rng = SplitMix64::new(3);
        let limits = JointLimits::default();
        let items: Vec<_> = (0..3)
            .map(|_| (limits.sample(&mut rng, 1.0), random_material(&mut rng)))
            .collect();
        let a = on_cpu.predict_batch(&items, Detail::Full).unwrap();
        let b = on_gpu.predict_batch(&items, Detail::Full).unwrap();
        for (x, y) in a.iter().zip(&b) {
            for (u, v) in x.vertices.iter().zip(&y.vertices) {
                assert_relative_eq!(u, v, max_relative = 1e-4, epsilon = 1e-6);
            }
        }
    }
}
