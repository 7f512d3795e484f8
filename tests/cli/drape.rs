//! `garmatnet drape`: every output format, whole motions, pose warnings and refused input.

use super::{assert_fails_cleanly, coarse_model, garmatnet, glb_document, stdout_of_success};

#[test]
fn drape_writes_every_format_and_compares_with_the_simulator() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let model = coarse_model(dir.path())?;
    let outs: Vec<_> = ["d.obj", "d.glb", "d.ply", "d.png"]
        .iter()
        .map(|n| dir.path().join(n))
        .collect();
    let mut cmd = garmatnet();
    cmd.args([
        "drape",
        "--material",
        "denim heavy",
        "--pose",
        "12",
        "--compare",
        "--model",
    ])
    .arg(&model);
    for o in &outs {
        cmd.arg("--out").arg(o);
    }
    let output = cmd.output()?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&output.stderr)
    );
    for o in &outs {
        assert!(
            std::fs::metadata(o)?.len() > 100,
            "{} is missing or empty",
            o.display()
        );
    }
    assert!(dir.path().join("d_compare.png").exists());
    assert!(stdout.contains("prediction error mean"), "{stdout}");
    let mesh = garmatnet::core::read_obj(&outs[0])?;
    assert_eq!(
        mesh.vertex_count(),
        garmatnet::Garment::tshirt(
            garmatnet::Resolution::Coarse,
            &garmatnet::CapsuleBody::smpl_neutral()
        )?
        .vertex_count()
    );
    Ok(())
}

#[test]
fn drape_frames_write_an_animation_and_numbered_files() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let model = coarse_model(dir.path())?;
    let glb = dir.path().join("walk.glb");
    let obj = dir.path().join("walk.obj");
    let stdout = stdout_of_success(
        garmatnet()
            .args(["drape", "--frames", "10..=12", "--fps", "24", "--model"])
            .arg(&model)
            .arg("--out")
            .arg(&glb)
            .arg("--out")
            .arg(&obj),
    )?;
    assert!(stdout.contains("3 frames"), "{stdout}");
    let doc = glb_document(&glb)?;
    // The garment: two morph targets after frame 10. The body: skinned, its 24 joints
    // rotated by the animation.
    assert_eq!(doc["meshes"][0]["name"], "garment");
    assert_eq!(
        doc["meshes"][0]["weights"].as_array().map(Vec::len),
        Some(2)
    );
    assert_eq!(doc["skins"].as_array().map(Vec::len), Some(1));
    assert_eq!(
        doc["animations"][0]["channels"].as_array().map(Vec::len),
        Some(1 + garmatnet::core::JOINT_COUNT)
    );
    // Each numbered OBJ is that frame's prediction, as one `--pose FRAME` run writes it.
    let single = dir.path().join("single.obj");
    stdout_of_success(
        garmatnet()
            .args(["drape", "--pose", "11", "--model"])
            .arg(&model)
            .arg("--out")
            .arg(&single),
    )?;
    let framed = garmatnet::core::read_obj(dir.path().join("walk.0011.obj"))?;
    let alone = garmatnet::core::read_obj(&single)?;
    let worst = framed
        .vertices
        .iter()
        .zip(&alone.vertices)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    assert!(worst < 1e-5, "frame 11 differs by {worst} m in a batch");
    assert!(dir.path().join("walk.0010.obj").exists());
    assert!(dir.path().join("walk.0012.obj").exists());
    assert!(!dir.path().join("walk.0013.obj").exists());
    // With --compare the simulator drapes the same frames and joins the animation.
    let compared = dir.path().join("c.glb");
    let png = dir.path().join("c.png");
    let stdout = stdout_of_success(
        garmatnet()
            .args(["drape", "--frames", "3..5", "--compare", "--model"])
            .arg(&model)
            .arg("--out")
            .arg(&compared)
            .arg("--out")
            .arg(&png),
    )?;
    assert!(stdout.contains("frame 4: simulated in"), "{stdout}");
    assert!(stdout.contains("prediction error mean"), "{stdout}");
    let doc = glb_document(&compared)?;
    assert_eq!(doc["meshes"][1]["name"], "garment_simulated");
    for f in [
        "c.0003.png",
        "c.0004.png",
        "c_compare.0003.png",
        "c_compare.0004.png",
    ] {
        assert!(dir.path().join(f).exists(), "{f} is missing");
    }
    Ok(())
}

#[test]
fn drape_frames_of_an_amass_file_play_at_its_frame_rate() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let model = coarse_model(dir.path())?;
    use npyz::WriterBuilder as _;
    // An AMASS-like archive: 4 SMPL+H poses and the capture's frame rate.
    let motion = dir.path().join("walk.npz");
    let mut npz = npyz::npz::NpzWriter::create(&motion)?;
    let mut w = npz
        .array::<f64>("poses", Default::default())?
        .default_dtype()
        .shape(&[4, 156])
        .begin_nd()?;
    w.extend((0..4 * 156).map(|i| f64::from(i % 156) * 1e-3))?;
    w.finish()?;
    let mut w = npz
        .array::<f64>("mocap_framerate", Default::default())?
        .default_dtype()
        .shape(&[])
        .begin_nd()?;
    w.extend([120.0])?;
    w.finish()?;
    drop(npz);
    let run = |extra: &[&str]| -> anyhow::Result<serde_json::Value> {
        let glb = dir.path().join("walk.glb");
        let stdout = stdout_of_success(
            garmatnet()
                .args(["drape", "--frames", "all", "--pose"])
                .arg(&motion)
                .args(extra)
                .arg("--model")
                .arg(&model)
                .arg("--out")
                .arg(&glb),
        )?;
        assert!(stdout.contains("4 frames"), "{stdout}");
        glb_document(&glb)
    };
    // The last key time is the last frame's: 3 / 120 s at the file's rate, 3 / 24 with --fps.
    let last_time = |doc: &serde_json::Value| {
        let input = doc["animations"][0]["samplers"][0]["input"]
            .as_u64()
            .unwrap_or(0);
        doc["accessors"][input as usize]["max"][0]
            .as_f64()
            .unwrap_or(0.0)
    };
    assert!((last_time(&run(&[])?) - 3.0 / 120.0).abs() < 1e-6);
    assert!((last_time(&run(&["--fps", "24"])?) - 3.0 / 24.0).abs() < 1e-6);
    Ok(())
}

/// The everyday suite lies within the joint limits training poses are drawn within, so
/// `drape` predicts it without a warning; a pose far past them is warned about.
#[test]
fn drape_warns_about_poses_past_the_joint_limits_only() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let drape = |pose: &std::path::Path| -> anyhow::Result<String> {
        let out = garmatnet()
            .args(["drape", "--frames", "all", "--pose"])
            .arg(pose)
            .arg("--out")
            .arg(dir.path().join("d.obj"))
            .output()?;
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{stderr}");
        Ok(stderr)
    };
    let stderr = drape(std::path::Path::new("everyday"))?;
    assert!(!stderr.contains("joint limits"), "{stderr}");
    let mut far = vec![0.0_f64; 72];
    far[3] = 3.0;
    let poses = dir.path().join("far.json");
    std::fs::write(&poses, serde_json::to_string(&vec![far])?)?;
    let stderr = drape(&poses)?;
    assert!(stderr.contains("outside the joint limits"), "{stderr}");
    Ok(())
}

#[test]
fn drape_bad_input_fails_with_a_message_and_leaves_no_file() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let model = coarse_model(dir.path())?;
    let out = dir.path().join("x.obj");
    let model_arg = model.display().to_string();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--material", "sillk"], "Silk"),
        (vec!["--omega", "0.1,0.2"], "6 comma-separated"),
        (vec!["--omega", "0.1,0.2,0.3,0.4,0.5,7"], "density"),
        (vec!["--detail", "wrinkly"], "smooth"),
        (vec!["--pose", "99999"], "frame"),
        (vec!["--device", "tpu"], "tpu"),
        (vec!["--frames", "0..3", "--pose", "12"], "leave --pose out"),
        (vec!["--frames", "5"], "START..END"),
        (vec!["--frames", "238..250"], "239"),
        (vec!["--frames", "0..2", "--fps", "0"], "--fps"),
        (vec!["--frame", "3"], "--pose FILE --frame N"),
        (vec!["--pose", "5", "--frame", "3"], "--pose FILE --frame N"),
    ];
    let out_arg = out.display().to_string();
    for (args, hint) in cases {
        let full = [
            &["drape", "--model", &model_arg][..],
            &args,
            &["--out", &out_arg],
        ]
        .concat();
        assert_fails_cleanly(&full, hint, &out)?;
    }
    let bad_ext = dir.path().join("x.stl");
    let output = garmatnet()
        .args(["drape", "--model", &model_arg, "--out"])
        .arg(&bad_ext)
        .output()?;
    assert!(!output.status.success());
    assert!(String::from_utf8_lossy(&output.stderr).contains(".glb"));
    assert!(!bad_ext.exists());
    let missing = garmatnet()
        .args(["drape", "--out"])
        .arg(&out)
        .env("GARMATNET_MODEL", dir.path().join("nope.safetensors"))
        .output()?;
    assert!(!missing.status.success());
    assert!(String::from_utf8_lossy(&missing.stderr).contains("GARMATNET_MODEL"));
    assert!(!out.exists());
    Ok(())
}
