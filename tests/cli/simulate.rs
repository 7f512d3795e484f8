//! `garmatnet simulate` and `poses`: random and independent poses and fabrics, strided plans,
//! and settings refused before anything is written.

use super::{assert_fails_cleanly, garmatnet, glb_document, quick_solver, stdout_of_success};

/// `simulate` arguments for a toy dataset of `materials` and `random` random fabrics drawn
/// with `seed`: one pose, the coarse shirt, the `quick` solver settings, no progress.
fn toy_random_simulate(
    materials: &str,
    random: &str,
    seed: &str,
    quick: &std::path::Path,
    out: &std::path::Path,
) -> Vec<String> {
    [
        "simulate",
        "--materials",
        materials,
        "--random-materials",
        random,
        "--material-seed",
        seed,
        "--poses",
        "1",
        "--resolution",
        "coarse",
        "--quiet",
        "--solver",
        &quick.to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
    ]
    .map(String::from)
    .to_vec()
}

/// Settings files and sizes `simulate` cannot honour are refused before the dataset's
/// directory is made: a misspelt key (it would have run with the default), a step that
/// would cut a pose change into astronomically many, a motion too long to hold, and sample
/// plans that leave poses undraped or do not fit a walk.
#[test]
fn simulate_refuses_settings_it_cannot_honour_before_writing() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("ds");
    let out_arg = out.display().to_string();
    let misspelt = dir.path().join("misspelt.json");
    std::fs::write(
        &misspelt,
        r#"{"max_step_rad": 0.3, "drape": {"max_iteratons": 5}}"#,
    )?;
    let tiny = dir.path().join("tiny.json");
    std::fs::write(&tiny, r#"{"max_step_rad": 1e-300}"#)?;
    let base = [
        "simulate",
        "--materials",
        "Cotton Poplin",
        "--resolution",
        "coarse",
        "--out",
        &out_arg,
    ];
    let (misspelt, tiny) = (misspelt.display().to_string(), tiny.display().to_string());
    for (args, hint) in [
        (
            vec!["--poses", "2", "--solver", &misspelt],
            "drape.max_iteratons",
        ),
        (vec!["--poses", "2", "--solver", &tiny], "max_step_rad"),
        (
            vec!["--poses", "18446744073709551615"],
            "at most 100000 frames",
        ),
        (
            vec!["--poses", "2", "--fabric-stride", "0"],
            "--fabric-stride 0",
        ),
        (vec!["--poses", "2", "--full-poses", "1"], "--full-poses 1"),
        (
            vec!["--poses", "2", "--fabric-stride", "2"],
            "stride 2 over 1 materials",
        ),
        (
            vec![
                "--poses",
                "2",
                "--random-materials",
                "1",
                "--fabric-stride",
                "2",
                "--protocol",
                "walk",
            ],
            "needs the canonical protocol",
        ),
        (
            vec!["--poses", "everyday", "--arm-bands", "0.3,0.1"],
            "sets how independent poses are drawn",
        ),
        (
            vec!["--poses", "2", "--arm-bands", "0.8,0.3"],
            "together they make at most 1",
        ),
        (
            vec!["--poses", "everyday", "--paired-arms", "0.5"],
            "sets how independent poses are drawn",
        ),
        (
            vec!["--poses", "2", "--paired-arms", "1.5"],
            "paired_fraction",
        ),
        (
            vec!["--poses", "everyday", "--side-arms", "0.5"],
            "sets how independent poses are drawn",
        ),
        (vec!["--poses", "2", "--side-arms", "1.5"], "side_fraction"),
    ] {
        assert_fails_cleanly(&[&base[..], &args].concat(), hint, &out)?;
    }
    Ok(())
}

/// `poses` writes what `simulate --poses N` drapes, after another file's poses if asked;
/// another arm share or paired arms draw other poses; bad input writes nothing.
#[test]
fn poses_writes_the_sampler_poses_after_another_file() -> anyhow::Result<()> {
    use garmatnet::sim::{PoseSampler, PoseSamplerConfig};
    let dir = tempfile::tempdir()?;
    let path = |name: &str| dir.path().join(name).display().to_string();
    let (first, joined, other) = (path("first.json"), path("joined.json"), path("other.json"));
    let run = |args: &[&str]| stdout_of_success(garmatnet().arg("poses").args(args));
    run(&["--count", "3", "--seed", "4", "--out", &first])?;
    let report = run(&[
        "--count", "2", "--seed", "9", "--after", &first, "--out", &joined,
    ])?;
    assert!(
        report.contains("wrote 5 poses") && report.contains("3 from --after"),
        "{report}"
    );
    run(&[
        "--count",
        "2",
        "--seed",
        "9",
        "--arm-bands",
        "0.1,0.1",
        "--out",
        &other,
    ])?;
    let read = |p: &str| garmatnet::core::read_poses(p);
    let (first, joined, other) = (read(&first)?, read(&joined)?, read(&other)?);
    let drawn = |config: PoseSamplerConfig, count| -> anyhow::Result<Vec<_>> {
        Ok(PoseSampler::new(config)?.poses(count)?)
    };
    let seeded = |seed| PoseSamplerConfig {
        seed,
        ..Default::default()
    };
    assert_eq!(first, drawn(seeded(4), 3)?);
    assert_eq!(joined[..3], first[..]);
    assert_eq!(joined[3..], drawn(seeded(9), 2)?[..]);
    assert_ne!(other[..], joined[3..]);
    // Two poses of seed 9 with the sampler's flags, as the sampler draws them.
    let (paired, side) = (path("paired.json"), path("side.json"));
    for (flags, out) in [
        (&["--paired-arms", "1"][..], &paired),
        (&["--paired-arms", "1", "--side-arms", "0.5"][..], &side),
    ] {
        run(&[
            &["--count", "2", "--seed", "9", "--out", out.as_str()][..],
            flags,
        ]
        .concat())?;
    }
    let paired_config = PoseSamplerConfig {
        paired_fraction: 1.0,
        ..seeded(9)
    };
    assert_eq!(read(&paired)?, drawn(paired_config.clone(), 2)?);
    assert_ne!(read(&paired)?[..], joined[3..]);
    assert_eq!(
        read(&side)?,
        drawn(
            PoseSamplerConfig {
                side_fraction: 0.5,
                ..paired_config
            },
            2
        )?
    );
    assert_ne!(read(&side)?, read(&paired)?);
    // After a dataset's poses: an empty shard of one writes its manifest and nothing else.
    let data = path("data");
    stdout_of_success(garmatnet().args([
        "simulate",
        "--materials",
        "Tulle",
        "--poses",
        "3",
        "--seed",
        "4",
        "--resolution",
        "coarse",
        "--shard",
        "1/2",
        "--quiet",
        "--out",
        &data,
    ]))?;
    let after_data = path("after-data.json");
    run(&[
        "--count",
        "1",
        "--seed",
        "9",
        "--after",
        &data,
        "--out",
        &after_data,
    ])?;
    assert_eq!(read(&after_data)?, joined[..4]);
    let out = dir.path().join("bad.json");
    let bad = out.display().to_string();
    for (args, hint) in [
        (vec!["--count", "0"], "--count 0"),
        (
            vec!["--count", "2", "--arm-bands", "0.5"],
            "give two fractions",
        ),
        (
            vec![
                "--count",
                "2",
                "--motion",
                "brisk",
                "--arm-bands",
                "0.3,0.1",
            ],
            "not a walk",
        ),
        (
            vec!["--count", "2", "--motion", "gentle", "--paired-arms", "0.5"],
            "not a walk",
        ),
        (
            vec!["--count", "2", "--motion", "brisk", "--side-arms", "0.5"],
            "not a walk",
        ),
        (
            vec!["--count", "2", "--after", "no-such.json"],
            "no-such.json",
        ),
        (
            vec!["--count", "2", "--motion", "brisk", "--arm-clearance", "5"],
            "--arm-clearance",
        ),
    ] {
        assert_fails_cleanly(&[&["poses", "--out", &bad][..], &args].concat(), hint, &out)?;
    }
    let obj = dir.path().join("poses.obj");
    assert_fails_cleanly(
        &["poses", "--count", "1", "--out", &obj.display().to_string()],
        "ending in .json",
        &obj,
    )
}

#[test]
fn simulate_adds_seeded_random_materials_after_the_presets() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let quick = quick_solver(dir.path())?;
    let simulate = |out: &str, seed: &str| -> anyhow::Result<serde_json::Value> {
        let status = garmatnet()
            .args(toy_random_simulate(
                "Cotton Poplin",
                "2",
                seed,
                &quick,
                &dir.path().join(out),
            ))
            .status()?;
        anyhow::ensure!(status.success(), "simulate {out} failed");
        Ok(serde_json::from_slice(&std::fs::read(
            dir.path().join(out).join("manifest.json"),
        )?)?)
    };
    let a = simulate("a", "5")?;
    // The stored drapes of a fabric, as an animation and as files.
    let glb = dir.path().join("a.glb");
    let stdout = stdout_of_success(
        garmatnet()
            .args(["dataset", "animate"])
            .arg(dir.path().join("a"))
            .args(["--material", "random-5-001", "--out"])
            .arg(&glb)
            .arg("--out")
            .arg(dir.path().join("a.obj")),
    )?;
    assert!(stdout.contains("random-5-001, frames 0..=0"), "{stdout}");
    assert!(glb_document(&glb)?["meshes"][0]["name"] == "garment");
    assert!(dir.path().join("a.0000.obj").exists());

    let materials = a["materials"].as_array().expect("a material list");
    let names: Vec<&str> = materials
        .iter()
        .filter_map(|m| m["name"].as_str())
        .collect();
    assert_eq!(names, ["Cotton Poplin", "random-5-000", "random-5-001"]);
    let omega = |m: &serde_json::Value| -> Vec<f64> {
        m["omega_normalized"]
            .as_array()
            .unwrap()
            .iter()
            .filter_map(|v| v.as_f64())
            .collect()
    };
    for m in &materials[1..] {
        let w = omega(m);
        assert!(
            w.len() == 6 && w.iter().all(|v| (0.0..=1.0).contains(v)),
            "{w:?}"
        );
    }
    assert_ne!(omega(&materials[1]), omega(&materials[2]));
    assert_eq!(a["samples"].as_array().map(Vec::len), Some(3));
    // Seeded: the same seed gives the same materials, another seed others.
    let b = simulate("b", "5")?;
    assert_eq!(a["materials"], b["materials"]);
    let c = simulate("c", "6")?;
    assert_ne!(omega(&materials[1]), omega(&c["materials"][1]));
    Ok(())
}

/// `--materials none` drapes the random fabrics alone; with nothing to drape, or beside other
/// names, it is refused before anything is written.
#[test]
fn simulate_materials_none_drapes_only_the_random_fabrics() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let quick = quick_solver(dir.path())?;
    let out = dir.path().join("random-only");
    let status = garmatnet()
        .args(toy_random_simulate("none", "2", "5", &quick, &out))
        .status()?;
    anyhow::ensure!(status.success(), "simulate --materials none failed");
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("manifest.json"))?)?;
    let names: Vec<&str> = manifest["materials"]
        .as_array()
        .expect("a material list")
        .iter()
        .filter_map(|m| m["name"].as_str())
        .collect();
    assert_eq!(names, ["random-5-000", "random-5-001"]);
    assert_eq!(manifest["samples"].as_array().map(Vec::len), Some(2));

    let refused = dir.path().join("refused");
    for (materials, random, hint) in [
        ("none", "0", "add --random-materials N"),
        ("none,Linen", "2", "stands alone"),
        ("", "2", "or `none`"),
    ] {
        let a = toy_random_simulate(materials, random, "5", &quick, &refused);
        assert_fails_cleanly(&a, hint, &refused)?;
    }
    Ok(())
}

#[test]
fn simulate_draws_random_materials_between_presets() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let quick = quick_solver(dir.path())?;
    let anchors = ["Silk Chiffon", "Denim Heavy", "Felt"];
    let simulate =
        |out: &str, between: &str, count: &str| -> anyhow::Result<std::process::Output> {
            Ok(garmatnet()
                .args([
                    "simulate",
                    "--materials",
                    "Cotton Poplin",
                    "--random-materials",
                    count,
                ])
                .args([
                    "--random-between",
                    between,
                    "--material-seed",
                    "3",
                    "--poses",
                    "1",
                ])
                .args(["--resolution", "coarse", "--quiet", "--solver"])
                .arg(&quick)
                .arg("--out")
                .arg(dir.path().join(out))
                .output()?)
        };
    let out = simulate("a", &anchors.join(","), "4")?;
    anyhow::ensure!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("a/manifest.json"))?)?;
    let materials = manifest["materials"].as_array().expect("a material list");
    let names: Vec<&str> = materials
        .iter()
        .filter_map(|m| m["name"].as_str())
        .collect();
    assert_eq!(
        names,
        [
            "Cotton Poplin",
            "mix-3-000",
            "mix-3-001",
            "mix-3-002",
            "mix-3-003"
        ]
    );
    // Each lies within the noise of a segment between two of the anchors: its distance to the
    // nearest such segment is a few times 0.03 at most (6 components of 0.03 noise).
    let anchor_omega: Vec<[f64; 6]> = anchors
        .iter()
        .map(|a| garmatnet::Material::preset(a).map(|m| m.to_normalized()))
        .collect::<Result<_, _>>()?;
    for m in &materials[1..] {
        let w: Vec<f64> = m["omega_normalized"]
            .as_array()
            .unwrap()
            .iter()
            .filter_map(|v| v.as_f64())
            .collect();
        assert!(
            w.len() == 6 && w.iter().all(|v| (0.0..=1.0).contains(v)),
            "{w:?}"
        );
        let mut nearest_segment = f64::INFINITY;
        for (i, a) in anchor_omega.iter().enumerate() {
            for b in &anchor_omega[i + 1..] {
                // Closest point of segment a–b to w.
                let ab: Vec<f64> = (0..6).map(|k| b[k] - a[k]).collect();
                let t = ((0..6).map(|k| (w[k] - a[k]) * ab[k]).sum::<f64>()
                    / ab.iter().map(|x| x * x).sum::<f64>())
                .clamp(0.0, 1.0);
                let d = (0..6)
                    .map(|k| (w[k] - a[k] - t * ab[k]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                nearest_segment = nearest_segment.min(d);
            }
        }
        assert!(
            nearest_segment < 0.25,
            "{w:?} is {nearest_segment} from every segment"
        );
    }
    // Seeded, like the uniform draw: the same command gives the same materials.
    let again = simulate("b", &anchors.join(","), "4")?;
    anyhow::ensure!(again.status.success());
    let b: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("b/manifest.json"))?)?;
    assert_eq!(manifest["materials"], b["materials"]);
    // One preset has no segment; no count has nothing to place: both refused, nothing written.
    for (out, between, count, hint) in [
        ("c", "Felt", "2", "at least two presets"),
        ("d", "Felt,Linen", "0", "--random-materials N"),
    ] {
        let refused = simulate(out, between, count)?;
        let text = String::from_utf8_lossy(&refused.stderr);
        assert!(!refused.status.success() && text.contains(hint), "{text}");
        assert!(!dir.path().join(out).exists());
    }
    Ok(())
}

/// `--poses N` draws N independent poses by default (pose i a function of the seed and i),
/// `--motion brisk` keeps the walk, and `--poses everyday` drapes the named suite.
#[test]
fn simulate_draws_independent_poses_by_default_and_keeps_the_walk() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let quick = quick_solver(dir.path())?;
    let simulate = |out: &str, args: &[&str]| -> anyhow::Result<serde_json::Value> {
        let output = garmatnet()
            .args(["simulate", "--materials", "Cotton Poplin", "--seed", "3"])
            .args(["--resolution", "coarse", "--quiet", "--solver"])
            .arg(&quick)
            .args(args)
            .arg("--out")
            .arg(dir.path().join(out))
            .output()?;
        anyhow::ensure!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        Ok(serde_json::from_slice(&std::fs::read(
            dir.path().join(out).join("manifest.json"),
        )?)?)
    };
    let as_json = |poses: Vec<garmatnet::core::Pose>| serde_json::to_value(poses);
    let sampler = garmatnet::sim::PoseSampler::new(garmatnet::sim::PoseSamplerConfig {
        seed: 3,
        ..Default::default()
    })?;
    let independent = simulate("independent", &["--poses", "2"])?;
    assert_eq!(independent["poses"], as_json(sampler.poses(2)?)?);
    let walk = simulate("walk", &["--poses", "2", "--motion", "brisk"])?;
    assert_eq!(
        walk["poses"],
        as_json(garmatnet::sim::MotionGenerator::new(3, 2).generate())?
    );
    let never = dir.path().join("never");
    let never_arg = never.to_string_lossy();
    assert_fails_cleanly(
        &[
            "simulate", "--poses", "2", "--motion", "sprint", "--out", &never_arg,
        ],
        "independent",
        &never,
    )
}

/// A strided plan end to end: `simulate` drapes the plan's samples, `dataset check` finds
/// none missing, and `dataset animate` plays a fabric's stored drapes at the poses the plan
/// holds for it.
#[test]
fn simulate_a_strided_plan_then_check_and_animate_it() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let quick = quick_solver(dir.path())?;
    let data = dir.path().join("strided");
    let stdout = stdout_of_success(
        garmatnet()
            .args([
                "simulate",
                "--materials",
                "Cotton Poplin",
                "--random-materials",
                "1",
            ])
            .args(["--poses", "3", "--fabric-stride", "2", "--full-poses", "1"])
            .args(["--resolution", "coarse", "--quiet", "--solver"])
            .arg(&quick)
            .arg("--out")
            .arg(&data),
    )?;
    // Pose 0 for both fabrics, pose 1 for fabric 1, pose 2 for fabric 0.
    assert!(stdout.contains("wrote 4 samples"), "{stdout}");
    let report = stdout_of_success(garmatnet().args(["dataset", "check"]).arg(&data))?;
    assert!(
        report.contains("2 materials, 3 poses, 4 samples") && report.contains("missing: 0"),
        "{report}"
    );
    stdout_of_success(
        garmatnet()
            .args(["dataset", "animate"])
            .arg(&data)
            .args(["--material", "Cotton Poplin", "--out"])
            .arg(dir.path().join("a.obj")),
    )?;
    let frame = |f: usize| dir.path().join(format!("a.{f:04}.obj")).exists();
    assert_eq!((frame(0), frame(1), frame(2)), (true, false, true));
    Ok(())
}
