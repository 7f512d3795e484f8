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
    let mut bin: Vec<u8> = Vec::new();
    let mut buffer_views = Vec::new();
    let mut accessors = Vec::new();
    let mut gltf_meshes = Vec::new();
    let mut materials = Vec::new();
    let mut nodes = Vec::new();
    let mut push_view = |bin: &mut Vec<u8>, bytes: &[u8], target: u32| -> usize {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let offset = bin.len();
        bin.extend_from_slice(bytes);
        buffer_views.push(
            json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len(), "target": target}),
        );
        buffer_views.len() - 1
    };
    for (k, item) in meshes.iter().enumerate() {
        let mesh = item.mesh;
        if mesh.vertex_count() == 0 || mesh.face_count() == 0 {
            return Err(Error::InvalidArgument(format!(
                "mesh `{}` is empty",
                item.name
            )));
        }
        let positions: Vec<f32> = mesh
            .vertices
            .iter()
            .flat_map(|v| [v.x as f32, v.y as f32, v.z as f32])
            .collect();
        let normals: Vec<f32> = mesh
            .vertex_normals()
            .iter()
            .flat_map(|n| [n.x as f32, n.y as f32, n.z as f32])
            .collect();
        let (min, max) = (0..3).fold(([f32::MAX; 3], [f32::MIN; 3]), |(mut lo, mut hi), c| {
            for p in positions.chunks_exact(3) {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
            (lo, hi)
        });
        let n = mesh.vertex_count();
        let as_bytes = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
        let pos_view = push_view(&mut bin, &as_bytes(&positions), ARRAY_BUFFER);
        accessors.push(json!({"bufferView": pos_view, "componentType": FLOAT, "count": n, "type": "VEC3", "min": min, "max": max}));
        let pos_acc = accessors.len() - 1;
        let nrm_view = push_view(&mut bin, &as_bytes(&normals), ARRAY_BUFFER);
        accessors.push(
            json!({"bufferView": nrm_view, "componentType": FLOAT, "count": n, "type": "VEC3"}),
        );
        let mut attributes = json!({"POSITION": pos_acc, "NORMAL": accessors.len() - 1});
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
            let col_view = push_view(&mut bin, &as_bytes(&linear), ARRAY_BUFFER);
            accessors.push(
                json!({"bufferView": col_view, "componentType": FLOAT, "count": n, "type": "VEC3"}),
            );
            attributes["COLOR_0"] = json!(accessors.len() - 1);
        }
        let indices: Vec<u8> = mesh
            .faces
            .iter()
            .flatten()
            .flat_map(|i| i.to_le_bytes())
            .collect();
        let idx_view = push_view(&mut bin, &indices, ELEMENT_ARRAY_BUFFER);
        accessors.push(json!({"bufferView": idx_view, "componentType": UNSIGNED_INT, "count": mesh.face_count() * 3, "type": "SCALAR"}));
        let base = if item.vertex_colors.is_some() {
            [1.0, 1.0, 1.0] // vertex colours carry the colour; the base must not tint them
        } else {
            item.color.map(srgb_to_linear)
        };
        materials.push(json!({
            "name": format!("{}_material", item.name),
            "doubleSided": true,
            "pbrMetallicRoughness": {"baseColorFactor": [base[0], base[1], base[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.9}
        }));
        gltf_meshes.push(json!({"name": item.name, "primitives": [{"attributes": attributes, "indices": accessors.len() - 1, "material": k}]}));
        nodes.push(json!({"name": item.name, "mesh": k}));
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let document = json!({
        "asset": {"version": "2.0", "generator": concat!("garmatnet ", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": gltf_meshes,
        "materials": materials,
        "accessors": accessors,
        "bufferViews": buffer_views,
        "buffers": [{"byteLength": bin.len()}],
    });
    let mut json_bytes = serde_json::to_vec(&document)
        .map_err(|e| Error::InvalidArgument(format!("glTF JSON: {e}")))?;
    while !json_bytes.len().is_multiple_of(4) {
        json_bytes.push(b' ');
    }
    let total = 12 + 8 + json_bytes.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json_bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json_bytes);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    write_bytes_atomic(path, &out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

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
