//! Pose files from capture systems: the first byte picks the format (.json, .npz, .npy), the
//! rest is the file. Any bytes give poses or a typed error, never a panic or a NaN pose.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&kind, body)) = data.split_first() else {
        return;
    };
    let ext = ["json", "npz", "npy"][kind as usize % 3];
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join(format!("poses.{ext}"));
    std::fs::write(&path, body).expect("write input");
    if let Ok(poses) = garmatnet_core::read_poses(&path) {
        assert!(poses.iter().all(|p| p.to_vec().iter().all(|v| v.is_finite())));
    }
});
