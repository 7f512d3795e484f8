//! How the command behaves as a Unix tool: closed pipes, and bad input that fails with a
//! message and leaves no file.

use super::garmatnet;

/// A reader that stops early (`garmatnet materials | head -3`) ends the command quietly, as it
/// does Unix tools: exit 0 and no panic. The pipe's reading end is closed before the command
/// starts, so its first line meets a broken pipe every time.
#[test]
fn a_closed_stdout_ends_the_command_quietly() -> anyhow::Result<()> {
    let (reader, writer) = std::io::pipe()?;
    drop(reader);
    let out = garmatnet().arg("materials").stdout(writer).output()?;
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{:?}: {stderr}", out.status);
    assert!(stderr.is_empty(), "{stderr}");
    // Errors other than a closed pipe still fail, with their message.
    let out = garmatnet()
        .args(["materials", "--model", "no-such-model.safetensors"])
        .output()?;
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.starts_with("Error: "), "{stderr}");
    Ok(())
}

/// A warning or note on a standard error whose reader has gone is dropped; the command still
/// does its work and exits 0 (`eprintln!` panicked there).
#[test]
fn a_closed_stderr_does_not_end_a_command_that_warns() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    // A pose far past the joint limits: `body` poses it anyway, with a note on stderr.
    let mut pose = vec![0.0_f64; 72];
    pose[3] = 3.0;
    let poses = dir.path().join("pose.json");
    std::fs::write(&poses, serde_json::to_string(&vec![pose])?)?;
    let obj = dir.path().join("body.obj");
    let body = || {
        let mut command = garmatnet();
        command
            .args(["body", "--pose"])
            .arg(&poses)
            .arg("--out")
            .arg(&obj);
        command
    };
    let out = body().output()?;
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.starts_with("note: "), "{stderr}");
    std::fs::remove_file(&obj)?;
    // The same with standard error's reader gone: the note is dropped, the command finishes
    // (`eprintln!` panicked here, exit 101).
    let (reader, writer) = std::io::pipe()?;
    drop(reader);
    let out = body().stderr(writer).output()?;
    assert!(out.status.success(), "{:?}", out.status);
    assert!(garmatnet::core::read_obj(&obj)?.vertex_count() > 0);
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
