//! The `garmatnet` command line: real runs of the binary, success and failure paths, one
//! module a topic.

mod datasets;
mod drape;
mod models;
mod output;
mod simulate;
mod template_body;

use std::process::Command;

fn garmatnet() -> Command {
    Command::new(env!("CARGO_BIN_EXE_garmatnet"))
}

/// Runs `garmatnet args` and asserts it fails, says `hint` on stderr and leaves no `out`.
fn assert_fails_cleanly<S: AsRef<std::ffi::OsStr> + std::fmt::Debug>(
    args: &[S],
    hint: &str,
    out: &std::path::Path,
) -> anyhow::Result<()> {
    let output = garmatnet()
        .args(args)
        .env_remove("RUST_BACKTRACE")
        .output()?;
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success(), "{args:?} should fail");
    assert!(
        stderr.contains(hint),
        "{args:?}: expected `{hint}` in: {stderr}"
    );
    assert!(!out.exists(), "{args:?} left {} behind", out.display());
    Ok(())
}

/// An untrained model for the coarse T-shirt (the CLI cannot tell it from a trained one).
fn coarse_model(dir: &std::path::Path) -> anyhow::Result<std::path::PathBuf> {
    use garmatnet::core::TemplateInfo;
    let device = garmatnet::select_device("cpu")?;
    let body = garmatnet::CapsuleBody::smpl_neutral();
    let garment = garmatnet::Garment::tshirt(garmatnet::Resolution::Coarse, &body)?;
    let config = garmatnet::GarMatNetConfig::new(garment.vertex_count(), 16, 8, 16);
    let path = dir.join("coarse.safetensors");
    garmatnet::GarMatNetModel::untrained(&config, TemplateInfo::of(&garment), &device)
        .save(&path)?;
    Ok(path)
}

/// Runs `cmd`, which must succeed (else both output streams are shown), and returns its
/// stdout.
fn stdout_of_success(cmd: &mut Command) -> anyhow::Result<String> {
    let output = cmd.output()?;
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    assert!(
        output.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&output.stderr)
    );
    Ok(stdout)
}

/// The JSON document of a `.glb` file (its first chunk).
fn glb_document(path: &std::path::Path) -> anyhow::Result<serde_json::Value> {
    let bytes = std::fs::read(path)?;
    let json_len = u32::from_le_bytes(bytes[12..16].try_into()?) as usize;
    Ok(serde_json::from_slice(&bytes[20..20 + json_len])?)
}

/// Solver settings for toy datasets: 5 Newton iterations, one intermediate step.
fn quick_solver(dir: &std::path::Path) -> anyhow::Result<std::path::PathBuf> {
    let quick = dir.join("quick.json");
    std::fs::write(
        &quick,
        r#"{"drape": {"max_iterations": 5}, "max_step_rad": 0.3, "intermediate_iterations": 1}"#,
    )?;
    Ok(quick)
}
