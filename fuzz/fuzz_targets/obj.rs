//! OBJ meshes from other tools: any bytes give a mesh or a typed error, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("mesh.obj");
    std::fs::write(&path, data).expect("write input");
    if let Ok(mesh) = garmatnet_core::read_obj(&path) {
        // A mesh that loads is usable: every face indexes a vertex, every coordinate finite.
        let n = mesh.vertices.len();
        assert!(mesh.faces.iter().flatten().all(|&i| (i as usize) < n));
        assert!(mesh.vertices.iter().all(|v| v.iter().all(|c| c.is_finite())));
    }
});
