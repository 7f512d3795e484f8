//! The fuzz targets' seed corpus (fuzz/corpus), replayed deterministically in the normal test
//! suite with the same checks as the targets in fuzz/fuzz_targets: files named `valid_*` must
//! load, every file must give a result or a typed error and never panic. Random bytes for the
//! same loaders run as proptests in each crate (pose files, OBJ, model files).

use std::path::{Path, PathBuf};

fn corpus(target: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fuzz/corpus")
        .join(target);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("corpus entry").path())
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no seeds in {}", dir.display());
    files
}

fn is_valid_seed(path: &Path) -> bool {
    path.file_name()
        .and_then(|n| n.to_str())
        .is_some_and(|n| n.starts_with("valid_"))
}

/// Writes `bytes` to `name` in a fresh directory and returns both.
fn staged(name: &str, bytes: &[u8]) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).expect("stage input");
    (dir, path)
}

#[test]
fn obj_seeds() {
    for seed in corpus("obj") {
        let bytes = std::fs::read(&seed).expect("seed");
        let (_dir, path) = staged("mesh.obj", &bytes);
        match garmatnet::core::read_obj(&path) {
            Ok(mesh) => {
                let n = mesh.vertices.len();
                assert!(mesh.faces.iter().flatten().all(|&i| (i as usize) < n));
                assert!(
                    mesh.vertices
                        .iter()
                        .all(|v| v.iter().all(|c| c.is_finite()))
                );
            }
            Err(e) => assert!(!is_valid_seed(&seed), "{}: {e}", seed.display()),
        }
    }
}

#[test]
fn pose_file_seeds() {
    for seed in corpus("pose_file") {
        let bytes = std::fs::read(&seed).expect("seed");
        let Some((&kind, body)) = bytes.split_first() else {
            continue;
        };
        let ext = ["json", "npz", "npy"][kind as usize % 3];
        let (_dir, path) = staged(&format!("poses.{ext}"), body);
        match garmatnet::core::read_poses(&path) {
            Ok(poses) => {
                assert!(!poses.is_empty());
                assert!(
                    poses
                        .iter()
                        .all(|p| p.to_vec().iter().all(|v| v.is_finite()))
                );
            }
            Err(e) => assert!(!is_valid_seed(&seed), "{}: {e}", seed.display()),
        }
    }
}

#[test]
fn dataset_seeds() {
    for seed in corpus("dataset") {
        let bytes = std::fs::read(&seed).expect("seed");
        let Some((&kind, body)) = bytes.split_first() else {
            continue;
        };
        let ok = if kind % 2 == 0 {
            let (dir, _) = staged("manifest.json", body);
            garmatnet::sim::manifest::Manifest::read(dir.path())
                .map(|_| ())
                .map_err(|e| e.to_string())
        } else {
            let (_dir, path) = staged("simulated.npy", body);
            garmatnet::sim::sample_arrays::read_points_npy(&path, "m000_p0000")
                .map(|p| assert!(!p.is_empty()))
                .map_err(|e| e.to_string())
        };
        if let Err(e) = ok {
            assert!(!is_valid_seed(&seed), "{}: {e}", seed.display());
        }
    }
}

#[test]
fn model_file_seeds() {
    let device = garmatnet::select_device("cpu").expect("cpu");
    for seed in corpus("model_file") {
        let bytes = std::fs::read(&seed).expect("seed");
        let (_dir, path) = staged("model.safetensors", &bytes);
        match garmatnet::GarMatNetModel::load(&path, &device) {
            Ok(model) => model.validate().expect("a loaded model is consistent"),
            Err(e) => assert!(!is_valid_seed(&seed), "{}: {e}", seed.display()),
        }
        // Every truncation of a seed is an error, not a panic.
        for cut in [
            0,
            1,
            8,
            bytes.len() / 3,
            bytes.len() / 2,
            bytes.len().saturating_sub(1),
        ] {
            let (_dir, path) = staged("cut.safetensors", &bytes[..cut.min(bytes.len())]);
            if cut < bytes.len() {
                assert!(
                    garmatnet::GarMatNetModel::load(&path, &device).is_err(),
                    "cut {cut}"
                );
            }
        }
    }
}
