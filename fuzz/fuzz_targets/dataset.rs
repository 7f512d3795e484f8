//! Dataset files copied between machines: the first byte picks a manifest or a sample array;
//! any bytes give a dataset/array or a typed error naming the file, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&kind, body)) = data.split_first() else {
        return;
    };
    let dir = tempfile::tempdir().expect("temp dir");
    if kind % 2 == 0 {
        std::fs::write(dir.path().join("manifest.json"), body).expect("write input");
        let _ = garmatnet_sim::manifest::Manifest::read(dir.path());
    } else {
        let path = dir.path().join("simulated.npy");
        std::fs::write(&path, body).expect("write input");
        if let Ok(points) = garmatnet_sim::sample_arrays::read_points_npy(&path, "m000_p0000") {
            assert!(!points.is_empty());
        }
    }
});
