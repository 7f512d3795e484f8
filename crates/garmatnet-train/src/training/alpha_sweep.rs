//! The weight-controller sweep of the paper's Table 3: one GarMatNet per α, each evaluated
//! on the same split, summarised as `alpha_sweep.md` and `alpha_sweep.json`.

use std::fmt::Write as _;
use std::path::Path;

use garmatnet_model::{GarMatNetModel, select_device};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::evaluation::evaluate::{EvalConfig, EvalInputs, evaluate};
use crate::training::train_config::{RunOptions, TrainConfig};
use crate::training::trainer::train;

/// The paper's α values.
pub const PAPER_ALPHAS: [f64; 5] = [0.1, 0.3, 0.5, 0.7, 0.9];

/// One row of Table 3.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AlphaSweepRow {
    /// The weight controller α.
    pub alpha: f64,
    /// Generally-fitting net error (mm), target materials × held-out poses.
    pub fitting_mm: f64,
    /// Locally-detailed net error (mm).
    pub local_mm: f64,
    /// Whole-pipeline error (mm).
    pub whole_mm: f64,
    /// Whole-pipeline error over the whole test set (mm).
    pub whole_all_test_mm: f64,
    /// Epochs trained by the fitting and local nets.
    pub epochs: [usize; 2],
}

/// Trains and evaluates one model per α in `alphas` (everything else from `config`) under
/// `out_dir/alpha_{α:.2}/`, and writes `alpha_sweep.md` and `alpha_sweep.json` to `out_dir`.
/// A model that already exists is evaluated without retraining if it was trained with this
/// α and these settings, and an interrupted training resumes from its checkpoint, so a
/// killed sweep can simply be run again.
///
/// # Errors
/// As [`train`] and [`evaluate`]; [`Error::InvalidConfig`] for no α, an α outside [0, 1],
/// or two α values that share a directory (equal to two decimals); [`Error::StaleOutput`]
/// for an existing model trained with another α or other settings.
pub fn sweep_alpha(
    data_dir: &Path,
    out_dir: &Path,
    alphas: &[f64],
    config: &TrainConfig,
    eval: &EvalConfig,
) -> Result<Vec<AlphaSweepRow>> {
    if alphas.is_empty() || alphas.iter().any(|a| !(0.0..=1.0).contains(a)) {
        return Err(Error::InvalidConfig(format!(
            "alphas {alphas:?}: give at least one value, each in [0, 1]"
        )));
    }
    for (i, &alpha) in alphas.iter().enumerate() {
        if let Some(&earlier) = alphas[..i]
            .iter()
            .find(|&&a| alpha_dir_name(a) == alpha_dir_name(alpha))
        {
            return Err(Error::InvalidConfig(format!(
                "alphas {earlier} and {alpha} would share the directory `{}` (α is named with \
                 two decimals), so one model would be reported under both; give distinct \
                 values that differ in the first two decimals",
                alpha_dir_name(alpha)
            )));
        }
    }
    let mut rows = Vec::new();
    for &alpha in alphas {
        let dir = out_dir.join(alpha_dir_name(alpha));
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
        let model = dir.join("model.safetensors");
        let run = TrainConfig {
            alpha,
            ..config.clone()
        };
        let mut epochs = [0, 0];
        if model.exists() {
            check_reusable(&model, &run)?;
        } else {
            let summary = train(
                data_dir,
                &model,
                &run,
                &RunOptions {
                    resume: true,
                    ..RunOptions::default()
                },
            )?;
            epochs = [
                summary.fitting.as_ref().map_or(0, |s| s.epochs),
                summary.local.as_ref().map_or(0, |s| s.epochs),
            ];
        }
        let report = evaluate(
            &EvalInputs {
                held_out: Vec::new(),
                data_dir: data_dir.to_owned(),
                model: model.clone(),
                baseline: None,
                compare_model: None,
                out_dir: dir.join("eval"),
            },
            eval,
        )?;
        rows.push(AlphaSweepRow {
            alpha,
            fitting_mm: report.garmatnet.fitting_mm,
            local_mm: report.garmatnet.local_mm,
            whole_mm: report.garmatnet.whole_mm,
            whole_all_test_mm: report.garmatnet_all_test.whole_mm,
            epochs,
        });
    }
    let json = serde_json::to_vec_pretty(&rows).map_err(|source| Error::Serialize {
        what: "the α sweep",
        source,
    })?;
    garmatnet_core::write_bytes_atomic(out_dir.join("alpha_sweep.json"), &json)?;
    garmatnet_core::write_bytes_atomic(out_dir.join("alpha_sweep.md"), markdown(&rows).as_bytes())?;
    for f in ["alpha_sweep.json", "alpha_sweep.md"] {
        crate::data::files::make_readable(&out_dir.join(f));
    }
    Ok(rows)
}

/// The directory of α's model under the sweep's output directory.
fn alpha_dir_name(alpha: f64) -> String {
    format!("alpha_{alpha:.2}")
}

/// Checks that the existing model at `path` was trained by `run`: its nets' α, and the
/// training configuration it records where it has one (all but `quiet` and `device`), so a
/// directory left by a sweep with another α or other options is not reported as this one.
///
/// # Errors
/// [`Error::Model`] if the model cannot be read; [`Error::StaleOutput`] if it was trained
/// otherwise.
fn check_reusable(path: &Path, run: &TrainConfig) -> Result<()> {
    let model = GarMatNetModel::load(path, &select_device("cpu")?)?;
    let stale = |what: String| Error::StaleOutput {
        path: path.to_owned(),
        message: format!(
            "it was trained with {what}, not with this sweep's; remove `{}` (or choose \
             another output directory) to train it again",
            path.parent().unwrap_or(path).display()
        ),
    };
    let stored_alpha = model.fitting.config().alpha;
    if stored_alpha != run.alpha {
        return Err(stale(format!("α = {stored_alpha}, not α = {}", run.alpha)));
    }
    if let Some(stored) = model.meta.provenance.extra.get("train_config") {
        let same = serde_json::from_value::<TrainConfig>(stored.clone())
            .is_ok_and(|stored| stored.same_run(run));
        if !same {
            return Err(stale("other training settings".into()));
        }
    }
    Ok(())
}

/// Table 3 as Markdown.
#[must_use]
pub(crate) fn markdown(rows: &[AlphaSweepRow]) -> String {
    let mut s = String::from(
        "# Mean per-vertex error under different weights α (Table 3)\n\n\
         | α | Generally-fitting (mm) | Locally-detailed (mm) | Whole (mm) | Whole, all test (mm) |\n\
         |---:|---:|---:|---:|---:|\n",
    );
    for r in rows {
        let _ = writeln!(
            s,
            "| {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
            r.alpha, r.fitting_mm, r.local_mm, r.whole_mm, r.whole_all_test_mm
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{synthetic_dataset, training_lock};
    use crate::training::trainer::tests::tiny_config;

    #[test]
    fn sweep_writes_one_row_per_alpha_and_reuses_finished_models() {
        let _serial = training_lock();
        let dir = tempfile::tempdir().unwrap();
        let data = dir.path().join("data");
        synthetic_dataset(&data, 6, 20);
        let out = dir.path().join("sweep");
        let eval = EvalConfig {
            figures: false,
            timing_repeats: 1,
            timing_batch: 2,
            ..EvalConfig::default()
        };
        let rows = sweep_alpha(&data, &out, &[0.3, 0.7], &tiny_config(2), &eval).unwrap();
        assert_eq!(rows.len(), 2);
        assert!(
            rows.iter()
                .all(|r| r.whole_mm.is_finite() && r.epochs == [2, 2])
        );
        let md = std::fs::read_to_string(out.join("alpha_sweep.md")).unwrap();
        assert!(md.contains("| 0.30 |") && md.contains("| 0.70 |"), "{md}");
        assert!(out.join("alpha_sweep.json").exists());
        let again = sweep_alpha(&data, &out, &[0.3], &tiny_config(2), &eval).unwrap();
        assert_eq!(
            again[0].epochs,
            [0, 0],
            "an existing model is not retrained"
        );
        assert_eq!(again[0].whole_mm, rows[0].whole_mm);
        assert!(sweep_alpha(&data, &out, &[1.5], &tiny_config(2), &eval).is_err());

        // A model trained with other options, or left under another α's name, is not
        // reported as this run's.
        let err = sweep_alpha(&data, &out, &[0.3], &tiny_config(3), &eval).unwrap_err();
        assert!(
            matches!(err, Error::StaleOutput { .. }) && err.to_string().contains("remove"),
            "{err}"
        );
        std::fs::rename(out.join("alpha_0.70"), out.join("alpha_0.50")).unwrap();
        let err = sweep_alpha(&data, &out, &[0.5], &tiny_config(2), &eval).unwrap_err();
        assert!(
            matches!(err, Error::StaleOutput { .. }) && err.to_string().contains("α = 0.7"),
            "{err}"
        );
    }

    #[test]
    fn alphas_that_share_a_directory_are_refused_before_any_training() {
        let dir = tempfile::tempdir().unwrap();
        let eval = EvalConfig::default();
        for alphas in [[0.301, 0.304], [0.5, 0.5], [0.7, 0.699]] {
            let err = sweep_alpha(
                &dir.path().join("no data"),
                &dir.path().join("sweep"),
                &alphas,
                &tiny_config(1),
                &eval,
            )
            .unwrap_err();
            assert!(
                matches!(err, Error::InvalidConfig(_)) && err.to_string().contains("share"),
                "{alphas:?}: {err}"
            );
        }
        assert!(!dir.path().join("sweep").exists(), "nothing is written");
    }
}
