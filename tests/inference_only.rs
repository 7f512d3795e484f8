//! An application that only predicts depends on `garmatnet` with `default-features = false`
//! (`tests/inference-only`, not a workspace member): it gets core and model, the typed
//! prediction API on burn, and none of the solver, the trainer or the command line.

use std::process::Command;

#[test]
fn an_inference_only_dependent_compiles_no_solver_trainer_or_cli() {
    let manifest = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/inference-only/Cargo.toml"
    );
    let out = Command::new(env!("CARGO"))
        .args([
            "tree",
            "--offline",
            "--locked",
            "-e",
            "normal",
            "--prefix",
            "none",
        ])
        .args(["--manifest-path", manifest])
        .output()
        .expect("cargo runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let tree = String::from_utf8_lossy(&out.stdout);
    let crates: Vec<&str> = tree.lines().filter_map(|l| l.split(' ').next()).collect();
    for present in ["garmatnet", "garmatnet-core", "garmatnet-model", "burn"] {
        assert!(crates.contains(&present), "{present} missing:\n{tree}");
    }
    for absent in [
        "garmatnet-sim",
        "garmatnet-train",
        "faer",
        "plotters",
        "indicatif",
        "clap",
    ] {
        assert!(!crates.contains(&absent), "{absent} compiled:\n{tree}");
    }
}
