//! `garmatnet template` and `body`: the meshes they write, poses from frames and files, and
//! outputs they refuse.

use super::{assert_fails_cleanly, garmatnet};

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

/// `template --out t.glb` and `body --out b.png` wrote OBJ text under another format's name;
/// only `.obj` (any case) is accepted, and nothing is written otherwise.
#[test]
fn template_and_body_refuse_an_output_that_is_not_obj() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    for (command, name) in [
        ("template", "t.glb"),
        ("template", "t"),
        ("body", "b.png"),
        ("body", "b.ply"),
    ] {
        let out = dir.path().join(name);
        assert_fails_cleanly(
            &[command, "--out", out.to_str().unwrap()],
            "writes only Wavefront OBJ",
            &out,
        )?;
    }
    for (command, name) in [("template", "T.OBJ"), ("body", "B.Obj")] {
        let out = dir.path().join(name);
        let status = garmatnet().args([command, "--out"]).arg(&out).status()?;
        assert!(status.success(), "{command} --out {name}");
        assert!(garmatnet::core::read_obj(&out)?.vertex_count() > 0);
    }
    Ok(())
}

/// `body` notes a pose past the limits training poses are drawn within, and no other: every
/// pose of the everyday suite lies within them.
#[test]
fn body_notes_only_poses_past_the_training_limits() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let obj = dir.path().join("body.obj");
    for name in garmatnet::sim::everyday_pose_names() {
        let out = garmatnet()
            .args(["body", "--pose", &format!("everyday:{name}"), "--out"])
            .arg(&obj)
            .output()?;
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{name}: {stderr}");
        assert!(stderr.is_empty(), "{name}: {stderr}");
    }
    Ok(())
}
