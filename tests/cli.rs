//! The `garmatnet` command line: real runs of the binary, success and failure paths.

use std::process::Command;

fn garmatnet() -> Command {
    Command::new(env!("CARGO_BIN_EXE_garmatnet"))
}

#[test]
fn template_writes_a_readable_obj_for_each_resolution() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    for (resolution, min, max) in [
        ("coarse", 500, 1000),
        ("default", 2000, 3000),
        ("paper", 4000, 4600),
    ] {
        let out = dir.path().join(format!("{resolution}.obj"));
        let status = garmatnet()
            .args(["template", "--resolution", resolution, "--out"])
            .arg(&out)
            .status()?;
        assert!(status.success());
        let mesh = garmatnet::core::read_obj(&out)?;
        assert!(
            (min..max).contains(&mesh.vertex_count()),
            "{resolution}: {}",
            mesh.vertex_count()
        );
    }
    Ok(())
}

#[test]
fn body_poses_from_a_frame_and_from_a_file() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let rest = dir.path().join("rest.obj");
    assert!(
        garmatnet()
            .args(["body", "--out"])
            .arg(&rest)
            .status()?
            .success()
    );
    let posed = dir.path().join("posed.obj");
    assert!(
        garmatnet()
            .args(["body", "--pose", "40", "--out"])
            .arg(&posed)
            .status()?
            .success()
    );
    let (a, b) = (
        garmatnet::core::read_obj(&rest)?,
        garmatnet::core::read_obj(&posed)?,
    );
    assert_eq!(a.faces, b.faces, "posing keeps the body's topology");
    assert!(
        a.vertices
            .iter()
            .zip(&b.vertices)
            .any(|(p, q)| (p - q).norm() > 0.05)
    );

    let poses = dir.path().join("poses.json");
    let mut v = vec![0.0; 72];
    v[16 * 3 + 2] = -1.0; // lower the left arm
    std::fs::write(&poses, serde_json::to_string(&vec![vec![0.0; 72], v])?)?;
    let from_file = dir.path().join("file.obj");
    let ok = garmatnet()
        .args(["body", "--frame", "1", "--pose"])
        .arg(&poses)
        .arg("--out")
        .arg(&from_file)
        .status()?;
    assert!(ok.success());
    Ok(())
}

#[test]
fn bad_input_fails_with_a_message_and_leaves_no_file() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("x.obj");
    let nan = dir.path().join("nan.json");
    std::fs::write(&nan, "[[".to_owned() + &["0.0"; 71].join(",") + ", NaN]]")?;
    let short = dir.path().join("short.json");
    std::fs::write(&short, "[[0.0, 1.0]]")?;
    let cases: Vec<Vec<String>> = vec![
        vec!["template".into(), "--resolution".into(), "huge".into()],
        vec!["body".into(), "--pose".into(), nan.display().to_string()],
        vec!["body".into(), "--pose".into(), short.display().to_string()],
        vec![
            "body".into(),
            "--pose".into(),
            dir.path().join("missing.json").display().to_string(),
        ],
        vec!["body".into(), "--pose".into(), "100000".into()],
        vec![
            "body".into(),
            "--pose".into(),
            short.display().to_string(),
            "--frame".into(),
            "3".into(),
        ],
    ];
    for args in cases {
        let output = garmatnet()
            .args(&args)
            .arg("--out")
            .arg(&out)
            .env_remove("RUST_BACKTRACE")
            .output()?;
        assert!(!output.status.success(), "{args:?} should fail");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(
            stderr.len() > 20,
            "{args:?}: the error must say what is wrong: {stderr}"
        );
        assert!(!out.exists(), "{args:?} left an output file behind");
    }
    let unwritable = garmatnet()
        .args(["template", "--out"])
        .arg(dir.path().join("no/such/dir/x.obj"))
        .output()?;
    assert!(!unwritable.status.success());
    assert!(String::from_utf8_lossy(&unwritable.stderr).contains("no/such/dir"));
    Ok(())
}
