//! glTF 2.0 binary (`.glb`) export: meshes with normals, a base colour each and optional
//! per-vertex colours, viewable in Blender, three.js viewers or any browser glTF viewer; and
//! animations of them ([`write_glb_animation`]): a mesh given frame by frame as morph targets,
//! a mesh skinned to the SMPL skeleton once, posed by its joints' rotations.
//!
//! The format is small and fully specified (Khronos glTF 2.0 §4.4): a 12-byte header, a JSON
//! chunk describing buffers/accessors/meshes/materials, and one binary chunk. Writing it takes
//! less code than adapting a general glTF crate's object model.

use std::path::Path;

use serde_json::json;

use crate::body::pose::Pose;
use crate::body::skeleton::{JOINT_COUNT, JOINT_NAMES, PARENTS, Skeleton};
use crate::error::{Error, Result};
use crate::io::files::write_bytes_atomic;
use crate::io::render::Color;
use crate::math::{Real, Vec3};
use crate::mesh::TriMesh;

/// One mesh to export.
#[derive(Debug, Clone, Copy)]
pub struct GlbMesh<'a> {
    /// Node name shown in viewers.
    pub name: &'a str,
    /// The mesh (metres, y up, as glTF expects).
    pub mesh: &'a TriMesh,
    /// Base colour (sRGB).
    pub color: Color,
    /// Optional per-vertex colours (sRGB), e.g. an error heat map.
    pub vertex_colors: Option<&'a [Color]>,
}

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const UNSIGNED_SHORT: u32 = 5123;
/// The most joints glTF's `JOINTS_0`/`WEIGHTS_0` give one vertex.
const MAX_INFLUENCES: usize = 4;

fn srgb_to_linear(c: u8) -> f64 {
    let c = f64::from(c) / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// One mesh moving through a sequence of frames, for [`write_glb_animation`].
#[derive(Debug, Clone, Copy)]
pub struct GlbAnimatedMesh<'a> {
    /// Node name shown in viewers.
    pub name: &'a str,
    /// The mesh at each frame, in order (metres, y up): one topology, the same faces and
    /// vertex count in every frame.
    pub frames: &'a [TriMesh],
    /// Base colour (sRGB).
    pub color: Color,
}

/// A mesh skinned to an SMPL skeleton and moved by a sequence of poses, for
/// [`write_glb_animation`]: written once, in its rest pose, with its skeleton as glTF joint
/// nodes whose rotations the animation drives (a few bytes a joint a frame instead of a
/// copy of every vertex). Viewers pose it by linear blend skinning with these weights,
/// which is how [`crate::PosedBody::mesh`] poses the body's rest mesh, so each frame shows
/// that mesh (to `f32` rounding).
#[derive(Debug, Clone, Copy)]
pub struct GlbSkinnedMesh<'a> {
    /// Node name shown in viewers (the joints are named after SMPL's).
    pub name: &'a str,
    /// The mesh in the skeleton's rest pose (metres, y up).
    pub rest: &'a TriMesh,
    /// Each vertex's skinning weights: 1 to 4 `(joint, weight)` pairs summing to one, as
    /// [`crate::CapsuleBody::rest_mesh_weights`] gives them.
    pub weights: &'a [Vec<(usize, Real)>],
    /// The skeleton the weights refer to.
    pub skeleton: &'a Skeleton,
    /// The pose at each frame, in order.
    pub poses: &'a [Pose],
    /// Base colour (sRGB).
    pub color: Color,
}

/// Writes `meshes` as one `.glb` file, atomically.
///
/// # Errors
/// [`Error::Empty`] for an empty list or an empty mesh, [`Error::Mismatch`] when a
/// vertex-colour list does not match its mesh, [`Error::GlbTooLarge`] for a file past the
/// format's 4 GiB, [`Error::Io`] when the file cannot be written.
pub fn write_glb(path: impl AsRef<Path>, meshes: &[GlbMesh<'_>]) -> Result<()> {
    if meshes.is_empty() {
        return Err(Error::Empty {
            what: "write_glb".into(),
            item: "mesh",
        });
    }
    let mut glb = GlbBuilder::default();
    for item in meshes {
        glb.add_mesh(item, &[])?;
    }
    glb.write(path, None)
}

/// Writes `meshes` and `skinned` as one animated `.glb` file, atomically, with one animation
/// ("drape", `fps` frames a second, linear interpolation) over their frames. Each of
/// `meshes` is stored as its first frame with every later frame one morph target of it;
/// Blender imports those as shape keys named `frame_0001`, … driven by the animation. Each
/// of `skinned` is stored once with its skeleton, whose joint rotations the animation
/// drives ([`GlbSkinnedMesh`]). Blender, three.js and browser glTF viewers play both.
///
/// Every mesh must have the same number of frames (poses, for `skinned`). One frame writes
/// a still scene.
///
/// # Errors
/// [`Error::Empty`] for no mesh at all, a mesh without frames or poses, or an empty mesh;
/// [`Error::InvalidFrameRate`] for a frame rate that is not a positive finite number, and
/// [`Error::KeyTimes`] for one so extreme that the frames' key times overflow or coincide in
/// 32-bit floats; [`Error::InvalidSkinWeights`] for skinning weights that are not 1 to 4
/// finite, non-negative pairs on valid joints summing to one; [`Error::GlbTooLarge`] for a
/// file past glTF binary's 4 GiB or its indices; [`Error::Mismatch`] when a mesh's frames differ in topology, the weights do not
/// match the vertices, or the meshes differ in frame count; [`Error::Io`] when the file
/// cannot be written. Nothing is written on error.
pub fn write_glb_animation(
    path: impl AsRef<Path>,
    meshes: &[GlbAnimatedMesh<'_>],
    skinned: &[GlbSkinnedMesh<'_>],
    fps: f64,
) -> Result<()> {
    // The first mesh sets the frame count every other must have.
    let Some((frame_count, first_name)) = meshes
        .first()
        .map(|m| (m.frames.len(), m.name))
        .or_else(|| skinned.first().map(|s| (s.poses.len(), s.name)))
    else {
        return Err(Error::Empty {
            what: "write_glb_animation".into(),
            item: "mesh",
        });
    };
    if !(fps.is_finite() && fps > 0.0) {
        return Err(Error::InvalidFrameRate { fps });
    }
    let mut glb = GlbBuilder::default();
    for item in meshes {
        let Some((first, rest)) = item.frames.split_first() else {
            return Err(Error::Empty {
                what: format!("mesh `{}`", item.name),
                item: "frame",
            });
        };
        if item.frames.len() != frame_count {
            return Err(Error::Mismatch {
                what: format!("frames of mesh `{}`", item.name),
                expected: format!("{frame_count} (as many as mesh `{first_name}`)"),
                got: item.frames.len().to_string(),
            });
        }
        for (k, frame) in rest.iter().enumerate() {
            if frame.vertex_count() != first.vertex_count() || frame.faces != first.faces {
                return Err(Error::Mismatch {
                    what: format!("topology of mesh `{}` at frame {}", item.name, k + 1),
                    expected: format!(
                        "frame 0's {} vertices and {} faces",
                        first.vertex_count(),
                        first.face_count()
                    ),
                    got: format!(
                        "{} vertices and {} faces{}",
                        frame.vertex_count(),
                        frame.face_count(),
                        if frame.face_count() == first.face_count() {
                            ", in another order"
                        } else {
                            ""
                        }
                    ),
                });
            }
        }
        let still = GlbMesh {
            name: item.name,
            mesh: first,
            color: item.color,
            vertex_colors: None,
        };
        glb.add_mesh(&still, rest)?;
    }
    for item in skinned {
        if item.poses.len() != frame_count {
            return Err(Error::Mismatch {
                what: format!("poses of skinned mesh `{}`", item.name),
                expected: format!("{frame_count} (as many as mesh `{first_name}` has frames)"),
                got: item.poses.len().to_string(),
            });
        }
        glb.add_skinned(item)?;
    }
    glb.write(path, (frame_count > 1).then_some(fps))
}

/// The parts of a glTF document under construction, and its binary chunk.
#[derive(Default)]
struct GlbBuilder {
    bin: Vec<u8>,
    buffer_views: Vec<serde_json::Value>,
    accessors: Vec<serde_json::Value>,
    meshes: Vec<serde_json::Value>,
    materials: Vec<serde_json::Value>,
    nodes: Vec<serde_json::Value>,
    /// The nodes the scene lists (joint nodes other than a skeleton's root are children).
    roots: Vec<usize>,
    skins: Vec<serde_json::Value>,
    /// Nodes with morph targets, and their target count.
    morphed: Vec<(usize, usize)>,
    /// Joint nodes, and their rotation (x, y, z, w) at every frame.
    rotated: Vec<(usize, Vec<f32>)>,
}

fn f32_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn flat(points: &[Vec3]) -> Vec<f32> {
    points
        .iter()
        .flat_map(|v| [v.x as f32, v.y as f32, v.z as f32])
        .collect()
}

impl GlbBuilder {
    /// Appends `bytes` as a buffer view (4-byte aligned); `target` as glTF's, if any.
    fn push_view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        let mut view = json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()});
        if let Some(target) = target {
            view["target"] = json!(target);
        }
        self.buffer_views.push(view);
        self.buffer_views.len() - 1
    }

    /// Appends `values` as an accessor of `kind` (`SCALAR`, `VEC3`, `VEC4` or `MAT4`) floats, with their
    /// per-component bounds when `bounds` (glTF requires them on positions and animation
    /// times).
    fn push_floats(
        &mut self,
        values: &[f32],
        kind: &str,
        target: Option<u32>,
        bounds: bool,
    ) -> usize {
        let width = match kind {
            "VEC3" => 3,
            "VEC4" => 4,
            "MAT4" => 16,
            _ => 1,
        };
        let view = self.push_view(&f32_bytes(values), target);
        let mut accessor = json!({"bufferView": view, "componentType": FLOAT, "count": values.len() / width, "type": kind});
        if bounds {
            let (mut lo, mut hi) = (vec![f32::MAX; width], vec![f32::MIN; width]);
            for p in values.chunks_exact(width) {
                for c in 0..width {
                    lo[c] = lo[c].min(p[c]);
                    hi[c] = hi[c].max(p[c]);
                }
            }
            accessor["min"] = json!(lo);
            accessor["max"] = json!(hi);
        }
        self.accessors.push(accessor);
        self.accessors.len() - 1
    }

    /// Adds `item` as a node, with one morph target per mesh of `later_frames` (same
    /// topology, checked by the caller): positions and normals as offsets from `item`'s.
    fn add_mesh(&mut self, item: &GlbMesh<'_>, later_frames: &[TriMesh]) -> Result<()> {
        let mesh = item.mesh;
        if mesh.vertex_count() == 0 || mesh.face_count() == 0 {
            return Err(Error::Empty {
                what: format!("mesh `{}`", item.name),
                item: "vertex and triangle",
            });
        }
        let n = mesh.vertex_count();
        let positions = flat(&mesh.vertices);
        let normals = flat(&mesh.vertex_normals());
        let pos_acc = self.push_floats(&positions, "VEC3", Some(ARRAY_BUFFER), true);
        let nrm_acc = self.push_floats(&normals, "VEC3", Some(ARRAY_BUFFER), false);
        let mut attributes = json!({"POSITION": pos_acc, "NORMAL": nrm_acc});
        if let Some(colors) = item.vertex_colors {
            if colors.len() != n {
                return Err(Error::Mismatch {
                    what: format!("vertex colours of mesh `{}`", item.name),
                    expected: format!("{n} (one per vertex)"),
                    got: colors.len().to_string(),
                });
            }
            let linear: Vec<f32> = colors
                .iter()
                .flat_map(|c| c.map(|x| srgb_to_linear(x) as f32))
                .collect();
            attributes["COLOR_0"] =
                json!(self.push_floats(&linear, "VEC3", Some(ARRAY_BUFFER), false));
        }
        let mut targets = Vec::with_capacity(later_frames.len());
        for frame in later_frames {
            let offsets = |now: Vec<f32>, base: &[f32]| -> Vec<f32> {
                now.iter().zip(base).map(|(a, b)| a - b).collect()
            };
            let d_pos = offsets(flat(&frame.vertices), &positions);
            let d_nrm = offsets(flat(&frame.vertex_normals()), &normals);
            let pos = self.push_floats(&d_pos, "VEC3", Some(ARRAY_BUFFER), true);
            let nrm = self.push_floats(&d_nrm, "VEC3", Some(ARRAY_BUFFER), false);
            targets.push(json!({"POSITION": pos, "NORMAL": nrm}));
        }
        let indices: Vec<u8> = mesh
            .faces
            .iter()
            .flatten()
            .flat_map(|i| i.to_le_bytes())
            .collect();
        let idx_view = self.push_view(&indices, Some(ELEMENT_ARRAY_BUFFER));
        self.accessors.push(json!({"bufferView": idx_view, "componentType": UNSIGNED_INT, "count": mesh.face_count() * 3, "type": "SCALAR"}));
        let base = if item.vertex_colors.is_some() {
            [1.0, 1.0, 1.0] // vertex colours carry the colour; the base must not tint them
        } else {
            item.color.map(srgb_to_linear)
        };
        let k = self.meshes.len();
        self.materials.push(json!({
            "name": format!("{}_material", item.name),
            "doubleSided": true,
            "pbrMetallicRoughness": {"baseColorFactor": [base[0], base[1], base[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.9}
        }));
        let mut primitive =
            json!({"attributes": attributes, "indices": self.accessors.len() - 1, "material": k});
        let mut gltf_mesh = json!({"name": item.name});
        if !targets.is_empty() {
            let names: Vec<String> = (1..=targets.len())
                .map(|f| format!("frame_{f:04}"))
                .collect();
            gltf_mesh["weights"] = json!(vec![0.0; targets.len()]);
            gltf_mesh["extras"] = json!({ "targetNames": names });
            self.morphed.push((self.nodes.len(), targets.len()));
            primitive["targets"] = json!(targets);
        }
        gltf_mesh["primitives"] = json!([primitive]);
        self.meshes.push(gltf_mesh);
        self.roots.push(self.nodes.len());
        self.nodes.push(json!({"name": item.name, "mesh": k}));
        Ok(())
    }

    /// Adds `item`: its rest mesh with `JOINTS_0`/`WEIGHTS_0`, its skeleton as joint nodes
    /// (posed at the first frame) and a skin binding them, and each joint's rotation at every
    /// frame for the animation.
    fn add_skinned(&mut self, item: &GlbSkinnedMesh<'_>) -> Result<()> {
        let n = item.rest.vertex_count();
        if item.weights.len() != n {
            return Err(Error::Mismatch {
                what: format!("skinning weights of mesh `{}`", item.name),
                expected: format!("{n} (one list per vertex)"),
                got: item.weights.len().to_string(),
            });
        }
        if item.poses.is_empty() {
            return Err(Error::Empty {
                what: format!("skinned mesh `{}`", item.name),
                item: "pose",
            });
        }
        let mut joints = Vec::with_capacity(n * MAX_INFLUENCES * 2);
        let mut weights = Vec::with_capacity(n * MAX_INFLUENCES);
        for (v, list) in item.weights.iter().enumerate() {
            let sum: Real = list.iter().map(|&(_, w)| w).sum();
            let valid = (1..=MAX_INFLUENCES).contains(&list.len())
                && list
                    .iter()
                    .all(|&(j, w)| j < JOINT_COUNT && w.is_finite() && w >= 0.0)
                && (sum - 1.0).abs() < 1e-6;
            if !valid {
                return Err(Error::InvalidSkinWeights {
                    mesh: item.name.to_owned(),
                    vertex: v,
                    weights: list.clone(),
                });
            }
            for slot in 0..MAX_INFLUENCES {
                let (j, w) = list.get(slot).copied().unwrap_or((0, 0.0));
                joints.extend_from_slice(&(j as u16).to_le_bytes());
                weights.push(w as f32);
            }
        }
        self.add_mesh(
            &GlbMesh {
                name: item.name,
                mesh: item.rest,
                color: item.color,
                vertex_colors: None,
            },
            &[],
        )?;
        // `add_mesh` just added the mesh and its node (a scene root); give them the skin.
        let (mesh, mesh_node) = (self.meshes.len() - 1, self.nodes.len() - 1);
        let joints_view = self.push_view(&joints, Some(ARRAY_BUFFER));
        self.accessors.push(json!({"bufferView": joints_view, "componentType": UNSIGNED_SHORT, "count": n, "type": "VEC4"}));
        let joints_acc = self.accessors.len() - 1;
        let weights_acc = self.push_floats(&weights, "VEC4", Some(ARRAY_BUFFER), false);
        let attributes = &mut self.meshes[mesh]["primitives"][0]["attributes"];
        attributes["JOINTS_0"] = json!(joints_acc);
        attributes["WEIGHTS_0"] = json!(weights_acc);

        // The skeleton: node j's translation is its rest offset from its parent, its
        // rotation the pose's local rotation; the inverse bind matrix undoes the rest
        // position, as `Skeleton::skinning_transforms` does.
        let rest = item.skeleton.rest_joints();
        let base = self.nodes.len();
        let quat = |pose: &Pose, j: usize| -> [f32; 4] {
            let q = pose.joint_rotation(j);
            [q.i as f32, q.j as f32, q.k as f32, q.w as f32]
        };
        for j in 0..JOINT_COUNT {
            let offset = match PARENTS[j] {
                Some(p) => rest[j] - rest[p],
                None => rest[j],
            };
            let mut node = json!({
                "name": format!("{}_{}", item.name, JOINT_NAMES[j]),
                "translation": [offset.x as f32, offset.y as f32, offset.z as f32],
                "rotation": quat(&item.poses[0], j),
            });
            let children: Vec<usize> = (0..JOINT_COUNT)
                .filter(|&c| PARENTS[c] == Some(j))
                .map(|c| base + c)
                .collect();
            if !children.is_empty() {
                node["children"] = json!(children);
            }
            if PARENTS[j].is_none() {
                self.roots.push(base + j);
            }
            self.nodes.push(node);
            let track: Vec<f32> = item.poses.iter().flat_map(|p| quat(p, j)).collect();
            self.rotated.push((base + j, track));
        }
        let mut inverse_binds = Vec::with_capacity(JOINT_COUNT * 16);
        for r in rest {
            // Column-major 4×4: identity with translation −r.
            let t = [-r.x as f32, -r.y as f32, -r.z as f32];
            inverse_binds.extend_from_slice(&[1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0]);
            inverse_binds.extend_from_slice(&[0.0, 0.0, 1.0, 0.0, t[0], t[1], t[2], 1.0]);
        }
        let ibm = self.push_floats(&inverse_binds, "MAT4", None, false);
        let root = (0..JOINT_COUNT)
            .find(|&j| PARENTS[j].is_none())
            .unwrap_or_default();
        self.skins.push(json!({
            "name": format!("{}_skeleton", item.name),
            "joints": (base..base + JOINT_COUNT).collect::<Vec<_>>(),
            "inverseBindMatrices": ibm,
            "skeleton": base + root,
        }));
        self.nodes[mesh_node]["skin"] = json!(self.skins.len() - 1);
        Ok(())
    }

    /// The animation that shows frame `f` at time `f / fps`, interpolating linearly
    /// between: morph target `f − 1` at full weight (frame 0: the meshes as stored), and each
    /// joint at its rotation of frame `f`.
    fn animation(&mut self, fps: f64, frame_count: usize) -> Result<serde_json::Value> {
        let times: Vec<f32> = (0..frame_count).map(|f| (f as f64 / fps) as f32).collect();
        // glTF needs finite, strictly increasing key times, which f32 cannot keep for every
        // frame rate and length (1e-30 frames a second overflows, 1e30 rounds them together).
        if times.iter().any(|t| !t.is_finite()) || times.windows(2).any(|w| w[1] <= w[0]) {
            return Err(Error::KeyTimes {
                fps,
                frames: frame_count,
            });
        }
        let input = self.push_floats(&times, "SCALAR", None, true);
        let mut samplers = Vec::new();
        let mut channels = Vec::new();
        for (node, track) in std::mem::take(&mut self.rotated) {
            let output = self.push_floats(&track, "VEC4", None, false);
            samplers.push(json!({"input": input, "output": output, "interpolation": "LINEAR"}));
            channels.push(
                json!({"sampler": samplers.len() - 1, "target": {"node": node, "path": "rotation"}}),
            );
        }
        let morphed = self.morphed.clone();
        for (node, count) in morphed {
            // Frame f's weights are target f − 1 at 1, every other at 0: a (count + 1) ×
            // count table, stored sparse (zeros but for one entry a frame), so a long
            // sequence costs 8 bytes a frame here instead of 4 × count.
            if (count + 1)
                .checked_mul(count)
                .is_none_or(|n| n > u32::MAX as usize)
            {
                return Err(Error::GlbTooLarge {
                    what: format!("an animation of {} frames", count + 1),
                });
            }
            // Below u32::MAX, checked above.
            let indices: Vec<u8> = (1..=count)
                .flat_map(|f| ((f * count + (f - 1)) as u32).to_le_bytes())
                .collect();
            let index_view = self.push_view(&indices, None);
            let value_view = self.push_view(&f32_bytes(&vec![1.0; count]), None);
            self.accessors.push(json!({
                "componentType": FLOAT,
                "count": (count + 1) * count,
                "type": "SCALAR",
                "sparse": {
                    "count": count,
                    "indices": {"bufferView": index_view, "componentType": UNSIGNED_INT},
                    "values": {"bufferView": value_view},
                },
            }));
            let output = self.accessors.len() - 1;
            samplers.push(json!({"input": input, "output": output, "interpolation": "LINEAR"}));
            channels.push(
                json!({"sampler": samplers.len() - 1, "target": {"node": node, "path": "weights"}}),
            );
        }
        Ok(json!({"name": "drape", "samplers": samplers, "channels": channels}))
    }

    /// Finishes the document (with the animation at `fps` frames a second, if any) and writes
    /// the file atomically.
    fn write(mut self, path: impl AsRef<Path>, animation: Option<f64>) -> Result<()> {
        let frame_count = match (self.morphed.first(), self.rotated.first()) {
            (Some(&(_, targets)), _) => targets + 1,
            (None, Some((_, track))) => track.len() / 4,
            (None, None) => 1,
        };
        let animation = animation
            .filter(|_| frame_count > 1)
            .map(|fps| self.animation(fps, frame_count))
            .transpose()?;
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut document = json!({
            "asset": {"version": "2.0", "generator": concat!("garmatnet ", env!("CARGO_PKG_VERSION"))},
            "scene": 0,
            "scenes": [{"nodes": self.roots}],
            "nodes": self.nodes,
            "meshes": self.meshes,
            "materials": self.materials,
            "accessors": self.accessors,
            "bufferViews": self.buffer_views,
            "buffers": [{"byteLength": self.bin.len()}],
        });
        if let Some(animation) = animation {
            document["animations"] = json!([animation]);
        }
        if !self.skins.is_empty() {
            document["skins"] = json!(self.skins);
        }
        let mut json_bytes =
            serde_json::to_vec(&document).map_err(|source| Error::GlbJson { source })?;
        while !json_bytes.len().is_multiple_of(4) {
            json_bytes.push(b' ');
        }
        let total = 12 + 8 + json_bytes.len() + 8 + self.bin.len();
        let too_large = || Error::GlbTooLarge {
            what: format!("a file of {total} bytes (the format's limit is 4 GiB)"),
        };
        let as_u32 = |n: usize| u32::try_from(n).map_err(|_| too_large());
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&as_u32(total)?.to_le_bytes());
        out.extend_from_slice(&as_u32(json_bytes.len())?.to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&json_bytes);
        out.extend_from_slice(&as_u32(self.bin.len())?.to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&self.bin);
        write_bytes_atomic(path, &out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Real, Vec3};

    fn tri() -> TriMesh {
        TriMesh::new(
            vec![
                Vec3::zeros(),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
            ],
            vec![[0, 1, 2]],
        )
        .unwrap()
    }

    fn u32_at(b: &[u8], i: usize) -> u32 {
        u32::from_le_bytes(b[i..i + 4].try_into().unwrap())
    }

    #[test]
    fn glb_layout_is_valid_and_positions_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.glb");
        let m = tri();
        let colors = [[255, 0, 0], [0, 255, 0], [0, 0, 255]];
        write_glb(
            &path,
            &[
                GlbMesh {
                    name: "garment",
                    mesh: &m,
                    color: [10, 20, 30],
                    vertex_colors: Some(&colors),
                },
                GlbMesh {
                    name: "body",
                    mesh: &m,
                    color: [200, 200, 200],
                    vertex_colors: None,
                },
            ],
        )
        .unwrap();
        let b = std::fs::read(&path).unwrap();
        assert_eq!(&b[0..4], b"glTF");
        assert_eq!(u32_at(&b, 4), 2);
        assert_eq!(u32_at(&b, 8) as usize, b.len());
        let json_len = u32_at(&b, 12) as usize;
        assert_eq!(&b[16..20], b"JSON");
        assert_eq!(json_len % 4, 0);
        let doc: serde_json::Value = serde_json::from_slice(&b[20..20 + json_len]).unwrap();
        let bin_start = 20 + json_len + 8;
        assert_eq!(&b[20 + json_len + 4..bin_start], b"BIN\0");
        assert_eq!(doc["meshes"].as_array().unwrap().len(), 2);
        assert!(doc["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"].is_number());
        assert!(
            doc["meshes"][1]["primitives"][0]["attributes"]
                .get("COLOR_0")
                .is_none()
        );
        // Read the second vertex of the first mesh back from the binary chunk.
        let acc = &doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"]
            .as_u64()
            .unwrap() as usize];
        let view = &doc["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
        let off = bin_start + view["byteOffset"].as_u64().unwrap() as usize + 12;
        let x = f32::from_le_bytes(b[off..off + 4].try_into().unwrap());
        assert_eq!(x, 1.0);
        assert_eq!(
            doc["buffers"][0]["byteLength"].as_u64().unwrap() as usize,
            b.len() - bin_start
        );
    }

    /// The JSON document and the binary chunk of a `.glb` file.
    fn parse(b: &[u8]) -> (serde_json::Value, &[u8]) {
        assert_eq!(&b[0..4], b"glTF");
        assert_eq!(u32_at(b, 8) as usize, b.len());
        let json_len = u32_at(b, 12) as usize;
        let doc = serde_json::from_slice(&b[20..20 + json_len]).unwrap();
        (doc, &b[20 + json_len + 8..])
    }

    /// The 4-byte little-endian words of buffer view `view`.
    fn words(doc: &serde_json::Value, bin: &[u8], view: &serde_json::Value) -> Vec<[u8; 4]> {
        let view = &doc["bufferViews"][view.as_u64().unwrap() as usize];
        let start = view["byteOffset"].as_u64().unwrap() as usize;
        let len = view["byteLength"].as_u64().unwrap() as usize;
        bin[start..start + len]
            .chunks_exact(4)
            .map(|c| c.try_into().unwrap())
            .collect()
    }

    /// The floats of accessor `acc`, sparse ones expanded as glTF readers expand them.
    fn floats(doc: &serde_json::Value, bin: &[u8], acc: u64) -> Vec<f32> {
        let acc = &doc["accessors"][acc as usize];
        let width = match acc["type"].as_str().unwrap() {
            "VEC3" => 3,
            "VEC4" => 4,
            "MAT4" => 16,
            _ => 1,
        };
        let mut values = match acc.get("bufferView") {
            Some(view) => words(doc, bin, view)
                .into_iter()
                .map(f32::from_le_bytes)
                .collect(),
            None => vec![0.0; acc["count"].as_u64().unwrap() as usize * width],
        };
        if let Some(sparse) = acc.get("sparse") {
            assert_eq!(sparse["indices"]["componentType"], UNSIGNED_INT);
            let indices = words(doc, bin, &sparse["indices"]["bufferView"]);
            let replacements = words(doc, bin, &sparse["values"]["bufferView"]);
            assert_eq!(indices.len(), sparse["count"].as_u64().unwrap() as usize);
            for (i, v) in indices.iter().zip(replacements) {
                values[u32::from_le_bytes(*i) as usize] = f32::from_le_bytes(v);
            }
        }
        values
    }

    #[test]
    fn an_animation_plays_every_frame_at_its_time() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("anim.glb");
        let frames: Vec<TriMesh> = (0..4)
            .map(|f| {
                let mut m = tri();
                for v in &mut m.vertices {
                    v.y += 0.1 * f as Real;
                }
                m
            })
            .collect();
        let still = vec![tri(); 4];
        write_glb_animation(
            &path,
            &[
                GlbAnimatedMesh {
                    name: "garment",
                    frames: &frames,
                    color: [10, 20, 30],
                },
                GlbAnimatedMesh {
                    name: "body",
                    frames: &still,
                    color: [200, 200, 200],
                },
            ],
            &[],
            25.0,
        )
        .unwrap();
        let b = std::fs::read(&path).unwrap();
        let (doc, bin) = parse(&b);
        assert_eq!(
            doc["buffers"][0]["byteLength"].as_u64().unwrap() as usize,
            bin.len()
        );
        let mesh = &doc["meshes"][0];
        let prim = &mesh["primitives"][0];
        let targets = prim["targets"].as_array().unwrap();
        assert_eq!(targets.len(), 3);
        assert_eq!(mesh["weights"].as_array().unwrap().len(), 3);
        assert_eq!(mesh["extras"]["targetNames"][2], "frame_0003");
        // Frame 3 = frame 0 + target 2: every vertex 0.3 higher.
        let base = floats(&doc, bin, prim["attributes"]["POSITION"].as_u64().unwrap());
        let delta = floats(&doc, bin, targets[2]["POSITION"].as_u64().unwrap());
        for (k, (b, d)) in base.iter().zip(&delta).enumerate() {
            let expected = frames[3].vertices[k / 3][k % 3] as f32;
            assert!(
                (b + d - expected).abs() < 1e-6,
                "{k}: {b} + {d} vs {expected}"
            );
        }
        // Positions of morph targets carry bounds, as glTF requires.
        let acc = &doc["accessors"][targets[0]["POSITION"].as_u64().unwrap() as usize];
        assert!(acc["min"].is_array() && acc["max"].is_array());
        // One channel per mesh, each driving its node's weights.
        let anim = &doc["animations"][0];
        assert_eq!(anim["channels"].as_array().unwrap().len(), 2);
        assert_eq!(anim["channels"][1]["target"]["node"], 1);
        assert_eq!(anim["channels"][1]["target"]["path"], "weights");
        let sampler = &anim["samplers"][0];
        assert_eq!(sampler["interpolation"], "LINEAR");
        let times = floats(&doc, bin, sampler["input"].as_u64().unwrap());
        assert_eq!(times, vec![0.0, 0.04, 0.08, 0.12]);
        // At time f / fps exactly target f − 1 is on: weights[f][t] = (t == f − 1).
        // Stored sparse: one stored entry a frame after the first, not the whole table.
        let output = &doc["accessors"][sampler["output"].as_u64().unwrap() as usize];
        assert!(output.get("bufferView").is_none());
        assert_eq!(output["sparse"]["count"], 3);
        let weights = floats(&doc, bin, sampler["output"].as_u64().unwrap());
        assert_eq!(weights.len(), 4 * 3);
        for f in 0..4 {
            for t in 0..3 {
                let on = f >= 1 && t == f - 1;
                assert_eq!(weights[f * 3 + t], if on { 1.0 } else { 0.0 }, "frame {f}");
            }
        }
    }

    #[test]
    fn a_skinned_mesh_follows_its_poses_as_linear_blend_skinning_does() {
        use crate::body::pose::JointLimits;
        use crate::body::skeleton::{blend_point, joint_index};
        use crate::rng::SplitMix64;
        use nalgebra::{Matrix4, Point3, Quaternion, Translation3, UnitQuaternion};

        let skeleton = Skeleton::smpl_neutral();
        let rest = skeleton.rest_joints();
        let elbow = joint_index("left_elbow").unwrap();
        let wrist = joint_index("left_wrist").unwrap();
        let spine = joint_index("spine3").unwrap();
        // A triangle along the left forearm, its corners skinned to one, two and three joints.
        let mesh = TriMesh::new(
            vec![
                rest[elbow],
                (rest[elbow] + rest[wrist]) * 0.5,
                rest[wrist] + Vec3::y() * 0.02,
            ],
            vec![[0, 1, 2]],
        )
        .unwrap();
        let weights = vec![
            vec![(elbow, 1.0)],
            vec![(elbow, 0.5), (wrist, 0.5)],
            vec![(wrist, 0.6), (elbow, 0.3), (spine, 0.1)],
        ];
        let mut rng = SplitMix64::new(3);
        let poses: Vec<Pose> = (0..3)
            .map(|_| JointLimits::default().sample(&mut rng, 1.0))
            .collect();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("skinned.glb");
        let body = GlbSkinnedMesh {
            name: "body",
            rest: &mesh,
            weights: &weights,
            skeleton: &skeleton,
            poses: &poses,
            color: [200, 200, 200],
        };
        write_glb_animation(&path, &[], &[body], 10.0).unwrap();
        let b = std::fs::read(&path).unwrap();
        let (doc, bin) = parse(&b);
        let skin = &doc["skins"][0];
        let joints: Vec<usize> = skin["joints"]
            .as_array()
            .unwrap()
            .iter()
            .map(|j| j.as_u64().unwrap() as usize)
            .collect();
        assert_eq!(joints.len(), JOINT_COUNT);
        // The scene lists the mesh and the skeleton's root, not the other joints.
        assert_eq!(doc["scenes"][0]["nodes"].as_array().unwrap().len(), 2);
        let ibm = floats(&doc, bin, skin["inverseBindMatrices"].as_u64().unwrap());
        let anim = &doc["animations"][0];
        // Each joint's rotation track, by node.
        let mut tracks = std::collections::HashMap::new();
        for channel in anim["channels"].as_array().unwrap() {
            assert_eq!(channel["target"]["path"], "rotation");
            let sampler = &anim["samplers"][channel["sampler"].as_u64().unwrap() as usize];
            let track = floats(&doc, bin, sampler["output"].as_u64().unwrap());
            tracks.insert(channel["target"]["node"].as_u64().unwrap() as usize, track);
        }
        assert_eq!(tracks.len(), JOINT_COUNT);
        // Parents of each node, from the children lists.
        let mut parent = std::collections::HashMap::new();
        for (k, node) in doc["nodes"].as_array().unwrap().iter().enumerate() {
            for c in node["children"].as_array().into_iter().flatten() {
                parent.insert(c.as_u64().unwrap() as usize, k);
            }
        }
        let prim = &doc["meshes"][0]["primitives"][0];
        let positions = floats(&doc, bin, prim["attributes"]["POSITION"].as_u64().unwrap());
        let wts = floats(&doc, bin, prim["attributes"]["WEIGHTS_0"].as_u64().unwrap());
        let jacc = &doc["accessors"][prim["attributes"]["JOINTS_0"].as_u64().unwrap() as usize];
        let jview = &doc["bufferViews"][jacc["bufferView"].as_u64().unwrap() as usize];
        let jstart = jview["byteOffset"].as_u64().unwrap() as usize;
        let joint_of = |v: usize, s: usize| {
            let at = jstart + (v * 4 + s) * 2;
            u16::from_le_bytes([bin[at], bin[at + 1]]) as usize
        };
        for (f, pose) in poses.iter().enumerate() {
            // A glTF viewer's skinning: global(joint) · inverseBind, blended by the weights.
            let local = |node: usize| -> Matrix4<f64> {
                let t = &doc["nodes"][node]["translation"];
                let t = Translation3::new(
                    t[0].as_f64().unwrap(),
                    t[1].as_f64().unwrap(),
                    t[2].as_f64().unwrap(),
                );
                let q = &tracks[&node][f * 4..f * 4 + 4];
                let q = UnitQuaternion::from_quaternion(Quaternion::new(
                    f64::from(q[3]),
                    f64::from(q[0]),
                    f64::from(q[1]),
                    f64::from(q[2]),
                ));
                t.to_homogeneous() * q.to_homogeneous()
            };
            let global = |mut node: usize| {
                let mut m = local(node);
                while let Some(&p) = parent.get(&node) {
                    m = local(p) * m;
                    node = p;
                }
                m
            };
            let expected_transforms = skeleton.skinning_transforms(pose);
            for v in 0..3 {
                let p = Point3::new(
                    f64::from(positions[v * 3]),
                    f64::from(positions[v * 3 + 1]),
                    f64::from(positions[v * 3 + 2]),
                );
                let mut got = Vec3::zeros();
                for s in 0..MAX_INFLUENCES {
                    let j = joint_of(v, s);
                    let w = f64::from(wts[v * 4 + s]);
                    let inv = Matrix4::from_iterator(
                        ibm[j * 16..j * 16 + 16].iter().map(|&x| f64::from(x)),
                    );
                    got += (global(joints[j]) * inv).transform_point(&p).coords * w;
                }
                let expected = blend_point(&expected_transforms, &weights[v], &mesh.vertices[v]);
                assert!(
                    (got - expected).norm() < 1e-5,
                    "frame {f} vertex {v}: {got} vs {expected}"
                );
            }
        }
        // Bad weights are refused, naming the vertex.
        let bad = vec![vec![(elbow, 1.0)], vec![(elbow, 0.5)], vec![(99, 1.0)]];
        let err = write_glb_animation(
            dir.path().join("bad.glb"),
            &[],
            &[GlbSkinnedMesh {
                weights: &bad,
                ..body
            }],
            10.0,
        )
        .unwrap_err();
        assert!(err.to_string().contains("vertex 1"), "{err}");
        assert!(!dir.path().join("bad.glb").exists());
        // Alone, a skinned mesh sets the frame count; beside a morphed mesh it must match.
        let two = GlbSkinnedMesh {
            poses: &poses[..2],
            ..body
        };
        write_glb_animation(dir.path().join("two.glb"), &[], &[two], 10.0).unwrap();
        let frames = vec![mesh.clone(); 3];
        let morph = GlbAnimatedMesh {
            name: "garment",
            frames: &frames[..2],
            color: [0, 0, 0],
        };
        let err =
            write_glb_animation(dir.path().join("bad2.glb"), &[morph], &[body], 10.0).unwrap_err();
        assert!(err.to_string().contains("poses of skinned mesh"), "{err}");
        assert!(!dir.path().join("bad2.glb").exists());
    }

    #[test]
    fn one_frame_is_a_still_scene() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("still.glb");
        let frames = [tri()];
        let item = GlbAnimatedMesh {
            name: "garment",
            frames: &frames,
            color: [1, 2, 3],
        };
        write_glb_animation(&path, &[item], &[], 30.0).unwrap();
        let b = std::fs::read(&path).unwrap();
        let (doc, _) = parse(&b);
        assert!(doc.get("animations").is_none());
        assert!(doc["meshes"][0]["primitives"][0].get("targets").is_none());
    }

    #[test]
    fn bad_animations_are_refused_without_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.glb");
        let two = [tri(), tri()];
        fn item(frames: &[TriMesh]) -> GlbAnimatedMesh<'_> {
            GlbAnimatedMesh {
                name: "g",
                frames,
                color: [0, 0, 0],
            }
        }
        for fps in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let err = write_glb_animation(&path, &[item(&two)], &[], fps).unwrap_err();
            assert!(matches!(err, Error::InvalidFrameRate { .. }), "{err}");
            assert!(err.to_string().contains("frame rate"), "{err}");
        }
        for fps in [1e-300, 1e300] {
            let err = write_glb_animation(&path, &[item(&two)], &[], fps).unwrap_err();
            assert!(matches!(err, Error::KeyTimes { frames: 2, .. }), "{err}");
            assert!(err.to_string().contains("frame rate such as"), "{err}");
        }
        assert!(matches!(
            write_glb_animation(&path, &[], &[], 30.0),
            Err(Error::Empty { item: "mesh", .. })
        ));
        assert!(matches!(
            write_glb_animation(&path, &[item(&[])], &[], 30.0),
            Err(Error::Empty { item: "frame", .. })
        ));
        let three = [tri(), tri(), tri()];
        let err = write_glb_animation(&path, &[item(&two), item(&three)], &[], 30.0).unwrap_err();
        assert!(matches!(err, Error::Mismatch { .. }), "{err}");
        let mut flipped = tri();
        flipped.faces[0] = [0, 2, 1];
        let err = write_glb_animation(&path, &[item(&[tri(), flipped])], &[], 30.0).unwrap_err();
        assert!(err.to_string().contains("in another order"), "{err}");
        let mut more = tri();
        more.vertices.push(Vec3::new(1.0, 1.0, 0.0));
        let err = write_glb_animation(&path, &[item(&[tri(), more])], &[], 30.0).unwrap_err();
        assert!(err.to_string().contains("frame 1"), "{err}");
        assert!(!path.exists());
    }

    #[test]
    fn bad_input_is_refused_without_a_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("b.glb");
        let m = tri();
        assert!(matches!(
            write_glb(&path, &[]),
            Err(Error::Empty { item: "mesh", .. })
        ));
        let short = [[0, 0, 0]];
        let bad = GlbMesh {
            name: "g",
            mesh: &m,
            color: [0, 0, 0],
            vertex_colors: Some(&short),
        };
        assert!(matches!(
            write_glb(&path, &[bad]),
            Err(Error::Mismatch { .. })
        ));
        assert!(!path.exists());
    }
}
