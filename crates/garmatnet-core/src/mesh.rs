//! Indexed triangle meshes.

use crate::error::{Error, Result};
use crate::math::Vec3;

/// An indexed triangle mesh: vertex positions (metres) and counter-clockwise faces.
#[derive(Debug, Clone, PartialEq)]
pub struct TriMesh {
    /// Vertex positions.
    pub vertices: Vec<Vec3>,
    /// Triangles as vertex indices, counter-clockwise seen from outside.
    pub faces: Vec<[u32; 3]>,
}

impl TriMesh {
    /// A mesh from vertices and faces, checked.
    ///
    /// # Errors
    /// [`Error::InvalidMesh`] if a face indexes past the vertices or repeats a vertex;
    /// [`Error::NonFinite`] if a vertex is NaN or infinite.
    pub fn new(vertices: Vec<Vec3>, faces: Vec<[u32; 3]>) -> Result<Self> {
        crate::error::ensure_finite("mesh vertex coordinates", vertices.iter().flat_map(|v| [v.x, v.y, v.z]))?;
        let n = vertices.len();
        for (f, face) in faces.iter().enumerate() {
            if let Some(bad) = face.iter().find(|&&i| i as usize >= n) {
                return Err(Error::InvalidMesh(format!(
                    "face {f} uses vertex {bad}, but the mesh has only {n} vertices"
                )));
            }
            if face[0] == face[1] || face[1] == face[2] || face[0] == face[2] {
                return Err(Error::InvalidMesh(format!("face {f} repeats a vertex: {face:?}")));
            }
        }
        Ok(Self { vertices, faces })
    }

    /// The number of vertices.
    #[must_use]
    pub fn vertex_count(&self) -> usize {
        self.vertices.len()
    }

    /// The number of triangles.
    #[must_use]
    pub fn face_count(&self) -> usize {
        self.faces.len()
    }
}
