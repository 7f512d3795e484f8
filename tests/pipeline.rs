//! The whole pipeline from the command line, at toy size: simulate → dataset check → train →
//! train-baseline → eval, checking each step's files and the report's Table 2 keys.

use std::path::Path;
use std::process::Command;

fn garmatnet(args: &[&str], dir: &Path) -> anyhow::Result<String> {
    let out = Command::new(env!("CARGO_BIN_EXE_garmatnet"))
        .args(args)
        .current_dir(dir)
        .output()?;
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    anyhow::ensure!(out.status.success(), "garmatnet {args:?} failed:\n{text}");
    Ok(text)
}

#[test]
fn simulate_train_and_evaluate_from_the_command_line() -> anyhow::Result<()> {
    let tmp = tempfile::tempdir()?;
    let dir = tmp.path();
    // A quick solver: this test checks the plumbing, not convergence.
    std::fs::write(
        dir.join("quick.json"),
        r#"{"drape": {"max_iterations": 10}, "max_step_rad": 0.15, "intermediate_iterations": 1}"#,
    )?;
    let materials = "Sherpa Fleece 160,Silk Duchess Satin,Trim Fusible Rigid,Cashmere,Cotton Poplin,Denim Heavy,Silk Chiffon";
    let simulate = [
        "simulate",
        "--materials",
        materials,
        "--poses",
        "12",
        "--resolution",
        "coarse",
        "--out",
        "data",
        "--solver",
        "quick.json",
        "--quiet",
    ];
    garmatnet(&simulate, dir)?;
    let check = garmatnet(&["dataset", "check", "data"], dir)?;
    assert!(check.contains("complete: 84"), "{check}");
    assert!(
        check.contains("Newton iterations per sample") && check.contains("worker-hours"),
        "the check reports what the dataset cost: {check}"
    );
    // Resuming with the other motion pace would mix two pose sequences: refused, with the fix.
    let other_pace = garmatnet(&[&simulate[..], &["--motion", "gentle"]].concat(), dir)
        .unwrap_err()
        .to_string();
    assert!(
        other_pace.contains("other poses") && other_pace.contains("--motion gentle"),
        "{other_pace}"
    );
    // An arm–torso clearance that would forbid hanging arms is refused, naming the default.
    let too_wide = garmatnet(&[&simulate[..], &["--arm-clearance", "0.5"]].concat(), dir)
        .unwrap_err()
        .to_string();
    assert!(
        too_wide.contains("--arm-clearance") && too_wide.contains("0.04"),
        "{too_wide}"
    );

    let small = [
        "--data",
        "data",
        "--max-epochs",
        "3",
        "--hidden",
        "16,8,16",
        "--batch-size",
        "8",
        "--held-out",
        "6,2",
        "--quiet",
    ];
    // A held-out rule that holds out every pose is refused before any training.
    let refused = garmatnet(
        &[
            &["train", "--out", "all.safetensors", "--held-out", "6,6"][..],
            &small[..2],
        ]
        .concat(),
        dir,
    )
    .unwrap_err()
    .to_string();
    assert!(refused.contains("held_out_block"), "{refused}");
    assert!(!dir.join("all.safetensors").exists());
    // Not `--quiet`: stderr is a pipe here, so progress comes as lines, one where each net
    // starts and one where it ends (more only after a minute).
    let trained = garmatnet(
        &[
            &["train", "--out", "model.safetensors"][..],
            &small[..small.len() - 1],
        ]
        .concat(),
        dir,
    )?;
    assert!(dir.join("model.safetensors").exists() && dir.join("model.split.json").exists());
    for net in ["fitting", "local"] {
        assert!(
            // The elapsed time runs from the command's start, so the second net's first line
            // reads 1s when the first net took a second (it did under a loaded suite).
            trained.lines().any(|l| {
                l.starts_with(&format!("{net} epoch 0/3 (0.0 %), "))
                    && l.ends_with("elapsed, ETA unknown")
            }) && trained.contains(&format!("{net} epoch 3/3 (100.0 %)")),
            "{trained}"
        );
    }
    // The model knows the fabrics it trained on (Cotton Poplin, Denim Heavy, Silk Chiffon):
    // `drape` names the nearest of them, and warns for a fabric outside their range or far
    // from all of them, and only then.
    let drape = |material: &str, out: &str| {
        garmatnet(
            &[
                "drape",
                "--model",
                "model.safetensors",
                "--material",
                material,
                "--out",
                out,
            ],
            dir,
        )
    };
    let outside = drape("Trim Fusible Rigid", "trim.obj")?;
    assert!(
        outside.contains("warning: the material lies outside the fabrics"),
        "{outside}"
    );
    assert!(
        outside.contains("nearest training fabric: ")
            && outside.contains("warning: the material is ")
            && outside.contains("from the nearest fabric"),
        "{outside}"
    );
    let inside = drape("Cotton Poplin", "poplin.obj")?;
    assert!(!inside.contains("warning"), "{inside}");
    assert!(
        inside.contains("nearest training fabric: Cotton Poplin (0.000 away"),
        "{inside}"
    );

    // Leave drapes that did not settle out of training (this 10-iteration solver leaves
    // many), with an annealed learning rate and rotation-matrix pose features: the split
    // lists them, none is trained on, the test set is the same, and the model file says how
    // its nets read the pose.
    let manifest: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("data/manifest.json"))?)?;
    let residual = |m: &serde_json::Value, p: &serde_json::Value| -> f64 {
        manifest["samples"]
            .as_array()
            .and_then(|all| {
                all.iter()
                    .find(|r| &r["material"] == m && &r["pose"] == p)
                    .and_then(|r| r["stats"]["residual"].as_f64())
            })
            .unwrap_or(f64::NAN)
    };
    let mut residuals: Vec<f64> = manifest["samples"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|r| r["stats"]["residual"].as_f64())
        .collect();
    residuals.sort_by(f64::total_cmp);
    let median = residuals[residuals.len() / 2].to_string();
    garmatnet(
        &[
            &["train", "--out", "settled.safetensors"][..],
            &["--max-train-residual", &median, "--lr-schedule", "cosine"],
            &["--pose-encoding", "rotation-matrix"],
            &small,
        ]
        .concat(),
        dir,
    )?;
    let header = |name: &str| -> anyhow::Result<serde_json::Value> {
        let bytes = std::fs::read(dir.join(name))?;
        let length = u64::from_le_bytes(bytes[..8].try_into()?) as usize;
        let outer: serde_json::Value = serde_json::from_slice(&bytes[8..8 + length])?;
        let document = outer["__metadata__"]["garmatnet"]
            .as_str()
            .unwrap_or_default();
        Ok(serde_json::from_str(document)?)
    };
    for (name, encoding) in [
        ("settled.safetensors", "rotation_matrix"),
        ("model.safetensors", "axis_angle"),
    ] {
        let h = header(name)?;
        for net in ["fitting", "local"] {
            assert_eq!(h[net]["pose_encoding"], encoding, "{name} {net}");
        }
    }
    let read_split = |name: &str| -> anyhow::Result<serde_json::Value> {
        Ok(serde_json::from_slice(&std::fs::read(dir.join(name))?)?)
    };
    let (settled, plain) = (
        read_split("settled.split.json")?,
        read_split("model.split.json")?,
    );
    let limit: f64 = median.parse()?;
    assert!(!settled["unsettled"].as_array().unwrap().is_empty());
    assert!(plain["unsettled"].as_array().unwrap().is_empty());
    for set in ["train", "dev"] {
        for k in settled[set].as_array().unwrap() {
            let r = residual(&k["material"], &k["pose"]);
            assert!(r <= limit, "{set} sample {k} has residual {r} > {limit}");
        }
    }
    assert_eq!(settled["test"], plain["test"]);

    // An ensemble: a second seed of the same recipe, averaged with the first into one model
    // that evaluates like any other and carries their common split. Members trained on
    // different splits are refused, and nothing is written.
    garmatnet(
        &[
            &["train", "--out", "seed7.safetensors", "--seed", "7"][..],
            &small,
        ]
        .concat(),
        dir,
    )?;
    assert_eq!(read_split("seed7.split.json")?, plain);
    let made = garmatnet(
        &[
            "ensemble",
            "--out",
            "ensemble.safetensors",
            "model.safetensors",
            "seed7.safetensors",
        ],
        dir,
    )?;
    assert!(made.contains("2 members"), "{made}");
    assert_eq!(read_split("ensemble.split.json")?, plain);
    assert_eq!(header("ensemble.safetensors")?["fitting"]["hidden"], 32);
    garmatnet(
        &[
            "eval",
            "--data",
            "data",
            "--model",
            "ensemble.safetensors",
            "--report",
            "ensemble-report",
            "--no-figures",
        ],
        dir,
    )?;
    let ensemble_report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("ensemble-report/report.json"))?)?;
    let whole = ensemble_report["garmatnet"]["whole_mm"]
        .as_f64()
        .unwrap_or(f64::NAN);
    assert!(whole.is_finite() && whole > 0.0, "{ensemble_report}");
    let mixed = garmatnet(
        &[
            "ensemble",
            "--out",
            "mixed.safetensors",
            "model.safetensors",
            "settled.safetensors",
        ],
        dir,
    )
    .unwrap_err()
    .to_string();
    assert!(mixed.contains("different splits"), "{mixed}");
    assert!(!dir.join("mixed.safetensors").exists());

    let bad = garmatnet(
        &[
            &["train", "--out", "bad.safetensors", "--lr-schedule", "step"][..],
            &small,
        ]
        .concat(),
        dir,
    )
    .unwrap_err()
    .to_string();
    assert!(bad.contains("cosine"), "{bad}");
    let bad = garmatnet(
        &[
            &[
                "train",
                "--out",
                "bad.safetensors",
                "--pose-encoding",
                "euler",
            ][..],
            &small,
        ]
        .concat(),
        dir,
    )
    .unwrap_err()
    .to_string();
    assert!(bad.contains("rotation-matrix"), "{bad}");
    assert!(!dir.join("bad.safetensors").exists());
    let baseline = garmatnet(
        &[&["train-baseline", "--out", "baseline"][..], &small].concat(),
        dir,
    )?;
    // A summary per material, not the manifest's normalisers (one number a line each).
    assert!(baseline.contains("best_dev_mse"), "{baseline}");
    assert!(!baseline.contains("fitting_norm"), "{baseline}");
    assert!(baseline.lines().count() < 200, "{baseline}");
    let eval = garmatnet(
        &[
            "eval",
            "--data",
            "data",
            "--model",
            "model.safetensors",
            "--baseline",
            "baseline",
            "--report",
            "report",
            "--no-figures",
        ],
        dir,
    )?;
    assert!(eval.contains("GarMatNet"), "{eval}");
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("report/report.json"))?)?;
    for net in ["garmatnet", "baseline"] {
        for key in ["fitting_mm", "local_mm", "whole_mm"] {
            let v = report[net][key].as_f64().unwrap_or(f64::NAN);
            assert!(v.is_finite() && v >= 0.0, "{net}.{key} = {v}");
        }
    }
    assert!(dir.join("report/report.md").exists());
    // `--held-out 6,2` holds out frames 0, 1, 6 and 7 of the 12.
    assert_eq!(report["held_out_poses"], 4, "{report}");
    assert_eq!(report["held_out_rule"], "frames 0–1 of every 6");
    assert_eq!(report["mirror_averaging"], true, "the predictor's default");

    // Without --data: held-out sets alone, no split file read (the training data read whole
    // as one, for the code path), with and without mirror averaging.
    for (out, extra) in [
        ("held-on", None),
        ("held-off", Some("--no-mirror-averaging")),
    ] {
        let args = [
            "eval",
            "--model",
            "model.safetensors",
            "--held-out",
            "whole=data",
            "--report",
            out,
        ];
        let printed = garmatnet(&[&args[..], extra.as_slice()].concat(), dir)?;
        assert!(printed.contains("GarMatNet (whole, "), "{printed}");
    }
    let held: Vec<serde_json::Value> = ["held-on", "held-off"]
        .iter()
        .map(|out| {
            let file = std::fs::read(dir.join(out).join("report.json"))?;
            Ok(serde_json::from_slice(&file)?)
        })
        .collect::<anyhow::Result<_>>()?;
    assert_eq!(held[0]["mirror_averaging"], true);
    assert_eq!(held[1]["mirror_averaging"], false);
    let whole = |r: &serde_json::Value| r["held_out_sets"][0]["all"]["whole_mm"].as_f64();
    assert!(whole(&held[0]).is_some_and(f64::is_finite), "{}", held[0]);
    assert_ne!(whole(&held[0]), whole(&held[1]));
    let refused = garmatnet(
        &[
            "eval",
            "--model",
            "model.safetensors",
            "--baseline",
            "baseline",
            "--held-out",
            "whole=data",
            "--report",
            "held-baseline",
        ],
        dir,
    )
    .unwrap_err()
    .to_string();
    assert!(
        refused.contains("give the dataset it was trained on with --data"),
        "{refused}"
    );

    // Fabric calibration: every fabric calibrated with its drapes at two poses the model
    // trained on, its other ten poses predicted with and without it.
    let eval_calibration = |extra: &[&str]| {
        let base = [
            "eval-calibration",
            "--data",
            "data",
            "--model",
            "model.safetensors",
        ];
        garmatnet(&[&base[..], extra].concat(), dir)
    };
    let calibrated = eval_calibration(&[
        "--reference-poses",
        "2,3",
        "--ridge",
        "0.1,1e6",
        "--out",
        "calibration.json",
    ])?;
    assert!(calibrated.contains("mean over 7 fabrics"), "{calibrated}");
    let calibration: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("calibration.json"))?)?;
    let rows = calibration["rows"].as_array().expect("rows");
    assert_eq!(rows.len(), 7, "{calibration}");
    for row in rows {
        assert_eq!(row["poses"], 10, "{row}");
        let plain = row["uncalibrated_mm"].as_f64().unwrap_or(f64::NAN);
        let errors = row["calibrated_mm"].as_array().expect("one per ridge");
        let (fitted, stiff) = (errors[0].as_f64().unwrap(), errors[1].as_f64().unwrap());
        assert!(plain.is_finite() && fitted.is_finite(), "{row}");
        // A huge ridge keeps the uncalibrated nets.
        assert!((stiff - plain).abs() < 1e-3 * plain, "{row}");
    }
    let (before, after) = (
        calibration["mean_uncalibrated_mm"].as_f64().unwrap(),
        rows.iter()
            .map(|r| r["calibrated_reference_mm"][0].as_f64().unwrap())
            .sum::<f64>()
            / 7.0,
    );
    let at_reference = rows
        .iter()
        .map(|r| r["reference_mm"].as_f64().unwrap())
        .sum::<f64>()
        / 7.0;
    // The fit shrinks the gap at the poses it was fitted to.
    assert!(
        after < at_reference,
        "{after} >= {at_reference} (mean at other poses {before})"
    );
    // Measured at the held-out frames alone (Table 2's poses): four of the ten, with the same
    // fit at the reference poses.
    let held_out = eval_calibration(&[
        "--reference-poses",
        "2,3",
        "--test-poses",
        "0,1,6,7",
        "--out",
        "calibration-held-out.json",
    ])?;
    assert!(held_out.contains("mean over 7 fabrics"), "{held_out}");
    let held_out: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("calibration-held-out.json"))?)?;
    for (row, all) in held_out["rows"].as_array().expect("rows").iter().zip(rows) {
        assert_eq!(row["poses"], 4, "{row}");
        assert_eq!(row["reference_mm"], all["reference_mm"], "{row}");
    }
    // A reference pose is a fit, not a test.
    let both = eval_calibration(&["--reference-poses", "2,3", "--test-poses", "0,3"])
        .unwrap_err()
        .to_string();
    assert!(both.contains("both a reference and a test pose"), "{both}");
    let twice = eval_calibration(&["--reference-poses", "2,2"])
        .unwrap_err()
        .to_string();
    assert!(
        twice.contains("reference pose 2 is listed twice"),
        "{twice}"
    );
    let past = eval_calibration(&["--test-poses", "12"])
        .unwrap_err()
        .to_string();
    assert!(
        past.contains("test pose 12 is past the dataset's 12 poses"),
        "{past}"
    );

    // The harness: the simulator at the dataset's own budget (10 here), warm-started from the
    // previous frame's ground truth, must reproduce the stored sample.
    garmatnet(
        &[
            "bench",
            "--data",
            "data",
            "--model",
            "model.safetensors",
            "--variant",
            "again=model.safetensors",
            "--baseline",
            "baseline",
            "--out",
            "bench",
            "--samples",
            "4",
            "--sim-samples",
            "1",
            "--sim-budgets",
            "2",
            "--polish-budgets",
            "2",
            "--batch",
            "3",
            "--repeats",
            "1",
        ],
        dir,
    )?;
    let bench: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("bench/bench.json"))?)?;
    let rows = bench["rows"].as_array().expect("rows");
    let find = |method: &str, batch: u64| {
        rows.iter()
            .find(|r| r["method"] == method && r["batch"] == batch)
            .unwrap_or_else(|| panic!("no row {method} x{batch} in {rows:?}"))
    };
    let reference = find("simulator ≤ 10 it (reference)", 1);
    assert!(
        reference["error_mm"].as_f64().unwrap() < 1e-3,
        "{reference}"
    );
    assert!(find("simulator ≤ 2 it", 1)["error_mm"].as_f64().unwrap() > 0.0);
    // The frame stepped as an application steps it (the default budget, 8).
    let frame = find("simulator frame, one step ≤ 8 it", 1);
    assert!(
        frame["error_mm"].as_f64().unwrap().is_finite()
            && frame["ms_per_frame"].as_f64().unwrap() > 0.0,
        "{frame}"
    );
    for method in ["GarMatNet full", "GarMatNet smooth", "GarMatNet again full"] {
        for batch in [1, 3] {
            let row = find(method, batch);
            assert!(row["ms_per_frame"].as_f64().unwrap() > 0.0, "{row}");
            assert!(row["error_mm"].as_f64().unwrap().is_finite(), "{row}");
        }
        // More samples (4) than a batch (3): the batched rows still cover every sample, so
        // they err as the single predictions do.
        let (one, batched) = (find(method, 1), find(method, 3));
        assert!(
            (one["error_mm"].as_f64().unwrap() - batched["error_mm"].as_f64().unwrap()).abs()
                < 1e-3,
            "{one} {batched}"
        );
    }
    // The prediction polished by 2 Newton iterations: timed with the prediction, and moved.
    let polished = find("GarMatNet full + simulator ≤ 2 it", 1);
    let raw = find("GarMatNet full", 1);
    assert!(
        polished["error_mm"].as_f64().unwrap().is_finite(),
        "{polished}"
    );
    assert_ne!(
        polished["error_mm"], raw["error_mm"],
        "the polish changed nothing"
    );
    assert!(
        polished["ms_per_frame"].as_f64().unwrap() > raw["ms_per_frame"].as_f64().unwrap(),
        "{polished}"
    );
    assert_eq!(polished["samples"], 4);
    find("TailorNet-style baseline", 1);
    assert!(rows.iter().any(|r| r["pareto"] == true));
    for file in ["bench.md", "pareto.png"] {
        assert!(dir.join("bench").join(file).exists(), "{file}");
    }
    // A variant that trained on the main model's test samples (here: every fabric) would be
    // measured on its own training data: refused before anything is simulated or written.
    garmatnet(
        &[
            &["train", "--out", "every-fabric.safetensors"][..],
            &["--test-materials", "none"],
            &small,
        ]
        .concat(),
        dir,
    )?;
    let leaky = garmatnet(
        &[
            "bench",
            "--data",
            "data",
            "--model",
            "model.safetensors",
            "--variant",
            "leaky=every-fabric.safetensors",
            "--out",
            "bench-leaky",
        ],
        dir,
    )
    .unwrap_err()
    .to_string();
    assert!(leaky.contains("another test set"), "{leaky}");
    assert!(!dir.join("bench-leaky").exists());
    // Nor is a baseline compared with a model that tests fabrics it has no net for; it is
    // refused before the simulator runs or anything is written.
    let uncovered = garmatnet(
        &[
            "bench",
            "--data",
            "data",
            "--model",
            "every-fabric.safetensors",
            "--baseline",
            "baseline",
            "--out",
            "bench-uncovered",
        ],
        dir,
    )
    .unwrap_err()
    .to_string();
    assert!(
        uncovered.contains("holds out no target fabric"),
        "{uncovered}"
    );
    assert!(!dir.join("bench-uncovered").exists());
    Ok(())
}
