//! Datasets built on, joined with and resumed from others by `garmatnet simulate`, and
//! shards joined by `garmatnet dataset merge`.

use super::{garmatnet, quick_solver};

#[test]
fn simulate_builds_on_a_dataset_of_the_same_or_fewer_poses() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let quick = quick_solver(dir.path())?;
    let simulate = |out: &str, materials: &str, poses: &str, reuse: Option<&str>| {
        let mut cmd = garmatnet();
        cmd.args([
            "simulate",
            "--materials",
            materials,
            "--random-materials",
            "1",
        ])
        .args([
            "--material-seed",
            "5",
            "--poses",
            poses,
            "--resolution",
            "coarse",
        ])
        // Not `--quiet`: progress goes to stderr, a pipe here, as lines.
        .env("GARMATNET_PROGRESS_SECS", "0")
        .arg("--out")
        .arg(dir.path().join(out));
        match reuse {
            // Built on a dataset, a new one takes that dataset's (quick) solver settings.
            Some(reuse) => cmd.arg("--reuse").arg(dir.path().join(reuse)),
            None => cmd.arg("--solver").arg(&quick),
        };
        cmd.output()
    };
    let first = simulate("a", "Cotton Poplin", "1", None)?;
    anyhow::ensure!(first.status.success(), "{first:?}");
    let output = simulate("b", "Denim Heavy,Cotton Poplin", "1", Some("a"))?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{output:?}");
    assert!(
        stdout.contains("wrote 1 samples (2 already done, 2 of them copied from --reuse"),
        "{stdout}"
    );
    // Progress starts where the dataset stands, and reaches the end.
    let stderr = String::from_utf8_lossy(&output.stderr);
    let lines: Vec<&str> = stderr.lines().collect();
    assert!(
        lines.len() == 2
            && lines[0].starts_with("samples 2/3 (66.7 %)")
            && lines[0].ends_with("ETA unknown")
            && lines[1].starts_with("samples 3/3 (100.0 %)")
            // 5 Newton iterations do not settle a drape (`quick_solver`).
            && lines[1].ends_with("ETA 0s  1 not converged (last: m0 p0)"),
        "{stderr}"
    );
    let read = |path: std::path::PathBuf| std::fs::read(path);
    // Cotton Poplin was material 0 of `a` and is material 1 of `b`; the random fabric 1 and 2.
    for (from, to) in [("m000_p0000", "m001_p0000"), ("m001_p0000", "m002_p0000")] {
        assert_eq!(
            read(
                dir.path()
                    .join("a/samples")
                    .join(from)
                    .join("simulated.npy")
            )?,
            read(dir.path().join("b/samples").join(to).join("simulated.npy"))?
        );
    }
    let manifest = |d: &str| -> anyhow::Result<serde_json::Value> {
        Ok(serde_json::from_slice(&std::fs::read(
            dir.path().join(d).join("manifest.json"),
        )?)?)
    };
    assert_eq!(manifest("b")?["solver"], manifest("a")?["solver"]);
    // More poses (the sampler's pose i depends on the seed and i alone): the canonical
    // samples of pose 0 are copied to pose 0, only pose 1 is draped.
    let output = simulate("c", "Cotton Poplin", "2", Some("a"))?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{output:?}");
    assert!(
        stdout.contains("wrote 2 samples (2 already done, 2 of them copied from --reuse"),
        "{stdout}"
    );
    assert_eq!(
        read(dir.path().join("a/samples/m000_p0000/simulated.npy"))?,
        read(dir.path().join("c/samples/m000_p0000/simulated.npy"))?
    );
    // A walk's samples depend on the poses before them: other poses are refused, naming
    // what differs.
    let walk = |out: &str, poses: &str, reuse: Option<&str>| {
        let mut cmd = garmatnet();
        cmd.args(["simulate", "--materials", "Cotton Poplin", "--poses", poses])
            .args([
                "--protocol",
                "walk",
                "--motion",
                "brisk",
                "--resolution",
                "coarse",
            ])
            .args(["--quiet", "--out"])
            .arg(dir.path().join(out));
        match reuse {
            Some(reuse) => cmd.arg("--reuse").arg(dir.path().join(reuse)),
            None => cmd.arg("--solver").arg(&quick),
        };
        cmd.output()
    };
    let first = walk("w1", "1", None)?;
    anyhow::ensure!(first.status.success(), "{first:?}");
    let output = walk("w2", "2", Some("w1"))?;
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("poses of the dataset to reuse"), "{stderr}");
    Ok(())
}

#[test]
fn simulate_joins_datasets_of_different_fabrics_without_draping_again() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let quick = quick_solver(dir.path())?;
    let simulate = |out: &str, args: &[&str], reuse: &[&str]| {
        let mut cmd = garmatnet();
        cmd.arg("simulate")
            .args(args)
            .args(["--poses", "1", "--resolution", "coarse", "--quiet", "--out"])
            .arg(dir.path().join(out));
        if reuse.is_empty() {
            cmd.arg("--solver").arg(&quick);
        }
        for r in reuse {
            cmd.arg("--reuse").arg(dir.path().join(r));
        }
        cmd.output()
    };
    let made = |out: &str, args: &[&str]| -> anyhow::Result<()> {
        let o = simulate(out, args, &[])?;
        anyhow::ensure!(o.status.success(), "{o:?}");
        Ok(())
    };
    // Two datasets of other fabrics: a preset and a uniform draw; a preset and a mix.
    made(
        "a",
        &[
            "--materials",
            "Felt",
            "--random-materials",
            "1",
            "--material-seed",
            "5",
        ],
    )?;
    let between = [
        "--random-materials",
        "1",
        "--material-seed",
        "5",
        "--random-between",
    ];
    made(
        "b",
        &[&["--materials", "Linen"][..], &between, &["Felt,Linen"]].concat(),
    )?;
    let names = |out: &str| -> anyhow::Result<Vec<String>> {
        let m: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.path().join(out).join("manifest.json"))?)?;
        Ok(m["materials"]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(|e| e["name"].as_str().map(str::to_owned))
            .collect())
    };
    // Every fabric of both, copied, none draped.
    let joined = simulate("ab", &["--materials", "reused"], &["a", "b"])?;
    let stdout = String::from_utf8_lossy(&joined.stdout);
    assert!(joined.status.success(), "{joined:?}");
    assert!(
        stdout.contains("wrote 0 samples (4 already done, 4 of them copied from --reuse"),
        "{stdout}"
    );
    assert_eq!(names("ab")?, ["Felt", "random-5-000", "Linen", "mix-5-000"]);
    let npy = |d: &str, s: &str| {
        std::fs::read(
            dir.path()
                .join(d)
                .join("samples")
                .join(s)
                .join("simulated.npy"),
        )
    };
    assert_eq!(npy("b", "m001_p0000")?, npy("ab", "m003_p0000")?);
    // A reused fabric by name, beside a preset listed both ways (once).
    let picked = simulate("c", &["--materials", "mix-5-000,Linen,reused"], &["b"])?;
    assert!(picked.status.success(), "{picked:?}");
    assert_eq!(names("c")?, ["mix-5-000", "Linen"]);
    // A name that is neither a preset nor a reused fabric; one named twice; `reused` alone.
    for (materials, reuse, says) in [
        (
            "mix-5-007",
            &["b"][..],
            "nor is it a fabric of the --reuse datasets",
        ),
        ("Linen,linen", &["b"][..], "listed twice"),
        ("reused", &[][..], "give one"),
    ] {
        let refused = simulate("refused", &["--materials", materials], reuse)?;
        let stderr = String::from_utf8_lossy(&refused.stderr);
        assert!(
            !refused.status.success() && stderr.contains(says),
            "{stderr}"
        );
    }
    // Two fabrics of one name with other ω (mixes of other presets) are refused.
    made(
        "d",
        &[
            &["--materials", "Tulle"][..],
            &between,
            &["Tulle,Denim Heavy"],
        ]
        .concat(),
    )?;
    let clash = simulate("bd", &["--materials", "reused"], &["b", "d"])?;
    let stderr = String::from_utf8_lossy(&clash.stderr);
    assert!(
        !clash.status.success() && stderr.contains("two fabrics are named `mix-5-000`"),
        "{stderr}"
    );
    assert!(!dir.path().join("bd").exists() && !dir.path().join("refused").exists());
    Ok(())
}

#[test]
fn simulate_resumes_a_dataset_with_the_solver_settings_it_was_made_with() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let quick = quick_solver(dir.path())?;
    let out = dir.path().join("d");
    let simulate = |solver: Option<&std::path::Path>| -> anyhow::Result<std::process::Output> {
        let mut cmd = garmatnet();
        cmd.args(["simulate", "--materials", "Cotton Poplin", "--poses", "2"])
            .args(["--resolution", "coarse", "--quiet", "--out"])
            .arg(&out);
        if let Some(solver) = solver {
            cmd.arg("--solver").arg(solver);
        }
        Ok(cmd.output()?)
    };
    anyhow::ensure!(simulate(Some(&quick))?.status.success(), "first run failed");
    let manifest = || -> anyhow::Result<serde_json::Value> {
        Ok(serde_json::from_slice(&std::fs::read(
            out.join("manifest.json"),
        )?)?)
    };
    let made_with = manifest()?["solver"].clone();
    // As if killed before its last sample: re-running without --solver finishes it with the
    // dataset's quick settings, not the defaults.
    std::fs::remove_dir_all(out.join("samples/m000_p0001"))?;
    let output = simulate(None)?;
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let resumed = manifest()?;
    assert_eq!(resumed["solver"], made_with);
    assert_eq!(resumed["samples"].as_array().map(Vec::len), Some(2));
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("samples/m000_p0001/stats.json"))?)?;
    assert!(
        stats["stats"]["iterations"]
            .as_u64()
            .is_some_and(|i| i <= 5),
        "{stats}"
    );
    // Other settings given explicitly are refused.
    let other = dir.path().join("other.json");
    std::fs::write(&other, r#"{"drape": {"max_iterations": 6}}"#)?;
    let output = simulate(Some(&other))?;
    assert!(!output.status.success());
    assert!(
        String::from_utf8_lossy(&output.stderr).contains("solver settings"),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    Ok(())
}

#[test]
fn dataset_merge_joins_shards_and_completes_slim_samples() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let quick = quick_solver(dir.path())?;
    for (shard, out) in [("0/2", "s0"), ("1/2", "s1"), ("0/1", "whole")] {
        let status = garmatnet()
            .args([
                "simulate",
                "--materials",
                "Cotton Poplin,Denim Heavy",
                "--poses",
                "2",
            ])
            .args([
                "--resolution",
                "coarse",
                "--quiet",
                "--shard",
                shard,
                "--solver",
            ])
            .arg(&quick)
            .arg("--out")
            .arg(dir.path().join(out))
            .status()?;
        anyhow::ensure!(status.success(), "simulate --shard {shard} failed");
    }
    // Shard 1 travels slim: only the simulated garments and the markers.
    for entry in std::fs::read_dir(dir.path().join("s1/samples"))? {
        let sample = entry?.path();
        std::fs::remove_file(sample.join("smoothed.npy"))?;
        std::fs::remove_file(sample.join("body.npy"))?;
    }
    let merged = dir.path().join("merged");
    let output = garmatnet()
        .args(["dataset", "merge", "--into"])
        .arg(&merged)
        .arg(dir.path().join("s0"))
        .arg(dir.path().join("s1"))
        .output()?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        output.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        stdout.contains("2 copied, 2 completed from slim samples"),
        "{stdout}"
    );
    assert!(
        stdout.contains(
            "it holds 4 of 4 samples (2 materials, 2 poses: every material at every pose)"
        ),
        "{stdout}"
    );
    let status = garmatnet()
        .args(["dataset", "check"])
        .arg(&merged)
        .status()?;
    assert!(status.success());
    for sample in ["m001_p0000", "m001_p0001"] {
        for name in ["simulated.npy", "smoothed.npy", "body.npy"] {
            let path = |root: &str| {
                dir.path()
                    .join(root)
                    .join("samples")
                    .join(sample)
                    .join(name)
            };
            assert_eq!(
                std::fs::read(merged.join("samples").join(sample).join(name))?,
                std::fs::read(path("whole"))?,
                "{sample}/{name}"
            );
        }
    }
    // A missing source fails by name and creates nothing.
    let nowhere = dir.path().join("nowhere");
    let out = dir.path().join("never");
    let output = garmatnet()
        .args(["dataset", "merge", "--into"])
        .arg(&out)
        .arg(dir.path().join("s0"))
        .arg(&nowhere)
        .output()?;
    assert!(!output.status.success());
    assert!(String::from_utf8_lossy(&output.stderr).contains("nowhere"));
    assert!(!out.exists());
    Ok(())
}
