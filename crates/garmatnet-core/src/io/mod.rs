//! Files in and out: meshes (OBJ, PLY, glTF binary), pose files, guarded `.npy` headers, and
//! software renders to PNG.

pub(crate) mod drape_output;
pub(crate) mod files;
pub(crate) mod gltf;
pub mod npy_guard;
pub(crate) mod pose_file;
pub mod render;
