//! glTF 2.0 binary (`.glb`) export: meshes with normals, a base colour each and optional
//! per-vertex colours, viewable in Blender, three.js viewers or any browser glTF viewer.
//!
//! The format is small and fully specified (Khronos glTF 2.0 §4.4): a 12-byte header, a JSON
//! chunk describing buffers/accessors/meshes/materials, and one binary chunk. Writing it takes
//! less code than adapting a general glTF crate's object model.

use std::path::Path;

use serde_json::json;

use crate::error::{Error, Result};
use crate::io::write_bytes_atomic;
use crate::mesh::TriMesh;
use crate::render::Color;

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

/// Writes `meshes` as one `.glb` file, atomically.
///
/// # Errors
/// [`Error::InvalidArgument`] for an empty list or an empty mesh, [`Error::Mismatch`] when a
/// vertex-colour list does not match its mesh, [`Error::Io`] when the file cannot be written.
pub fn write_glb(path: impl AsRef<Path>, meshes: &[GlbMesh<'_>]) -> Result<()> {
    if meshes.is_empty() {
        return Err(Error::InvalidArgument(
            "write_glb needs at least one mesh".into(),
        ));
    }
    let mut glb = GlbBuilder::default();
    for item in meshes {
        glb.add_mesh(item, &[])?;
    }
    glb.write(path, None)
}

/// Writes `meshes` as one animated `.glb` file, atomically: each mesh is its first frame,
/// every later frame one morph target of it, and one animation ("drape", `fps` frames a
/// second, linear interpolation) moves each mesh through its frames. Blender imports the
/// frames as shape keys named `frame_0001`, … with the animation driving them; three.js and
/// browser glTF viewers play it.
///
/// All meshes must have the same number of frames. One frame writes a still scene, as
/// [`write_glb`].
///
/// # Errors
/// [`Error::InvalidArgument`] for an empty list, a mesh without frames, an empty mesh, a
/// frame rate that is not a positive finite number, or a file past glTF binary's 4 GiB;
/// [`Error::Mismatch`] when a mesh's frames differ in topology or the meshes in frame
/// count; [`Error::Io`] when the file cannot be written. Nothing is written on error.
pub fn write_glb_animation(
    path: impl AsRef<Path>,
    meshes: &[GlbAnimatedMesh<'_>],
    fps: f64,
) -> Result<()> {
    if meshes.is_empty() {
        return Err(Error::InvalidArgument(
            "write_glb_animation needs at least one mesh".into(),
        ));
    }
    if !(fps.is_finite() && fps > 0.0) {
        return Err(Error::InvalidArgument(format!(
            "the frame rate must be a positive number of frames a second, got {fps}"
        )));
    }
    let frame_count = meshes[0].frames.len();
    let mut glb = GlbBuilder::default();
    for item in meshes {
        let Some((first, rest)) = item.frames.split_first() else {
            return Err(Error::InvalidArgument(format!(
                "mesh `{}` has no frames",
                item.name
            )));
        };
        if item.frames.len() != frame_count {
            return Err(Error::Mismatch {
                what: format!("frames of mesh `{}`", item.name),
                expected: format!("{frame_count} (as many as mesh `{}`)", meshes[0].name),
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
    let animation = (frame_count > 1).then_some(fps);
    glb.write(path, animation)
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
    /// Nodes with morph targets, and their target count.
    morphed: Vec<(usize, usize)>,
}

fn f32_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

fn flat(points: &[crate::math::Vec3]) -> Vec<f32> {
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

    /// Appends `values` as an accessor of `kind` (`VEC3` or `SCALAR`) floats, with their
    /// per-component bounds when `bounds` (glTF requires them on positions and animation
    /// times).
    fn push_floats(
        &mut self,
        values: &[f32],
        kind: &str,
        target: Option<u32>,
        bounds: bool,
    ) -> usize {
        let width = if kind == "VEC3" { 3 } else { 1 };
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
            return Err(Error::InvalidArgument(format!(
                "mesh `{}` is empty",
                item.name
            )));
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
        self.nodes.push(json!({"name": item.name, "mesh": k}));
        Ok(())
    }

    /// The animation that shows frame `f` (0 = the meshes as stored, `f` ≥ 1 = morph
    /// target `f − 1` at full weight) at time `f / fps`, interpolating linearly between.
    fn animation(&mut self, fps: f64) -> serde_json::Value {
        let targets = self.morphed.iter().map(|&(_, t)| t).max().unwrap_or(0);
        let times: Vec<f32> = (0..=targets).map(|f| (f as f64 / fps) as f32).collect();
        let input = self.push_floats(&times, "SCALAR", None, true);
        let mut samplers = Vec::new();
        let mut channels = Vec::new();
        let morphed = self.morphed.clone();
        for (node, count) in morphed {
            let mut weights = vec![0.0_f32; (count + 1) * count];
            for f in 1..=count {
                weights[f * count + (f - 1)] = 1.0;
            }
            let output = self.push_floats(&weights, "SCALAR", None, false);
            samplers.push(json!({"input": input, "output": output, "interpolation": "LINEAR"}));
            channels.push(
                json!({"sampler": samplers.len() - 1, "target": {"node": node, "path": "weights"}}),
            );
        }
        json!({"name": "drape", "samplers": samplers, "channels": channels})
    }

    /// Finishes the document (with the animation at `fps` frames a second, if any) and writes
    /// the file atomically.
    fn write(mut self, path: impl AsRef<Path>, animation: Option<f64>) -> Result<()> {
        let animation = animation
            .filter(|_| !self.morphed.is_empty())
            .map(|fps| self.animation(fps));
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut document = json!({
            "asset": {"version": "2.0", "generator": concat!("garmatnet ", env!("CARGO_PKG_VERSION"))},
            "scene": 0,
            "scenes": [{"nodes": (0..self.nodes.len()).collect::<Vec<_>>()}],
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
        let mut json_bytes = serde_json::to_vec(&document)
            .map_err(|e| Error::InvalidArgument(format!("glTF JSON: {e}")))?;
        while !json_bytes.len().is_multiple_of(4) {
            json_bytes.push(b' ');
        }
        let total = 12 + 8 + json_bytes.len() + 8 + self.bin.len();
        let too_large = || {
            Error::InvalidArgument(format!(
                "the glTF binary would take {total} bytes, past the format's 4 GiB: write \
                 fewer frames or vertices per file"
            ))
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

    /// The floats of accessor `acc`.
    fn floats(doc: &serde_json::Value, bin: &[u8], acc: u64) -> Vec<f32> {
        let acc = &doc["accessors"][acc as usize];
        let view = &doc["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
        let start = view["byteOffset"].as_u64().unwrap() as usize;
        let len = view["byteLength"].as_u64().unwrap() as usize;
        bin[start..start + len]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect()
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
    fn one_frame_is_a_still_scene() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("still.glb");
        let frames = [tri()];
        let item = GlbAnimatedMesh {
            name: "garment",
            frames: &frames,
            color: [1, 2, 3],
        };
        write_glb_animation(&path, &[item], 30.0).unwrap();
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
            let err = write_glb_animation(&path, &[item(&two)], fps).unwrap_err();
            assert!(err.to_string().contains("frame rate"), "{err}");
        }
        assert!(matches!(
            write_glb_animation(&path, &[], 30.0),
            Err(Error::InvalidArgument(_))
        ));
        assert!(matches!(
            write_glb_animation(&path, &[item(&[])], 30.0),
            Err(Error::InvalidArgument(_))
        ));
        let three = [tri(), tri(), tri()];
        let err = write_glb_animation(&path, &[item(&two), item(&three)], 30.0).unwrap_err();
        assert!(matches!(err, Error::Mismatch { .. }), "{err}");
        let mut flipped = tri();
        flipped.faces[0] = [0, 2, 1];
        let err = write_glb_animation(&path, &[item(&[tri(), flipped])], 30.0).unwrap_err();
        assert!(err.to_string().contains("in another order"), "{err}");
        let mut more = tri();
        more.vertices.push(Vec3::new(1.0, 1.0, 0.0));
        let err = write_glb_animation(&path, &[item(&[tri(), more])], 30.0).unwrap_err();
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
            Err(Error::InvalidArgument(_))
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
