//! What `garmatnet bench` found ([`BenchReport`]: one [`BenchRow`] per measured
//! configuration) and how it is written: `bench.json`, `bench.md` (a markdown table, fastest
//! first, with what was not measured and what to keep in mind) and `pareto.png`.

use std::path::Path;

use garmatnet_core::Real;
use garmatnet_sim::{GROUND_TRUTH_REVISION, revision_label};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::evaluation::plots::{ParetoPoint, pareto_chart};

/// One measured configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BenchRow {
    /// What ran, e.g. `GarMatNet full` or `simulator ≤ 25 it`.
    pub method: String,
    /// `simulator`, `garmatnet`, `baseline` or `polish` (a prediction polished by the
    /// simulator).
    pub family: String,
    /// `cpu` or `gpu` (the simulator: `cpu, 1 thread`).
    pub device: String,
    /// Frames per call.
    pub batch: usize,
    /// Wall-clock milliseconds per frame, push-out included: for batch-1 rows (networks,
    /// polished predictions, the baseline) the median over the timed calls; for batched
    /// rows one timed pass over every batch divided by its frames; for the simulator's rows
    /// the mean over the measured samples, each timed once.
    pub ms_per_frame: Real,
    /// Mean per-vertex Euclidean error against the ground truth (mm).
    pub error_mm: Real,
    /// Samples the error is averaged over.
    pub samples: usize,
    /// Size of the model file(s) (MB), for networks.
    pub size_mb: Option<Real>,
    /// Whether no other row is both faster and more accurate.
    pub pareto: bool,
}

/// Everything `garmatnet bench` measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BenchReport {
    /// The dataset's fingerprint.
    pub dataset_hash: String,
    /// The held-out samples measured (`m{material}_p{pose}` stems), networks first, the
    /// simulator's are the first [`crate::BenchConfig::sim_samples`].
    pub samples: Vec<String>,
    /// The measurements, fastest first.
    pub rows: Vec<BenchRow>,
    /// What could not be measured, and why.
    pub skipped: Vec<String>,
    /// What to keep in mind reading the rows (e.g. a dataset draped by another
    /// ground-truth revision of the solver than the one that ran here).
    #[serde(default)]
    pub notes: Vec<String>,
    /// Worker threads the CPU backend could use.
    pub threads: usize,
}

/// Errors closer than this (mm) are the same error on the Pareto front: one model's
/// batch-1 and batched rows predict the same samples and differ only by f32 rounding
/// (≈ 5e-7 mm), which must not make the slower row look more accurate. A micrometre is far
/// below any difference the table (two decimals) or a garment can show.
const SAME_ERROR_MM: Real = 1e-3;

/// Marks the rows no other row beats on both time and error (errors within
/// [`SAME_ERROR_MM`] counting as equal).
pub(crate) fn mark_pareto(rows: &mut [BenchRow]) {
    let points: Vec<(Real, Real)> = rows.iter().map(|r| (r.ms_per_frame, r.error_mm)).collect();
    for (i, row) in rows.iter_mut().enumerate() {
        let (t, e) = points[i];
        row.pareto = !points.iter().enumerate().any(|(j, &(tj, ej))| {
            let no_worse = ej <= e + SAME_ERROR_MM;
            let better = ej < e - SAME_ERROR_MM;
            j != i && tj <= t && no_worse && (tj < t || better)
        });
    }
}

pub(crate) fn write_report(dir: &Path, report: &BenchReport) -> Result<()> {
    let json = serde_json::to_vec_pretty(report).map_err(|source| Error::Serialize {
        what: "the bench report",
        source,
    })?;
    garmatnet_core::write_bytes_atomic(dir.join("bench.json"), &json)?;
    garmatnet_core::write_bytes_atomic(dir.join("bench.md"), markdown(report).as_bytes())?;
    let points: Vec<ParetoPoint> = report
        .rows
        .iter()
        .map(|r| ParetoPoint {
            label: if r.batch > 1 {
                format!("{} ×{} {}", r.method, r.batch, r.device)
            } else {
                format!("{} {}", r.method, r.device)
            },
            group: match r.family.as_str() {
                "simulator" => 0,
                "garmatnet" => 1,
                "polish" => 3,
                _ => 2,
            },
            x: r.ms_per_frame,
            y: r.error_mm,
            highlight: r.pareto,
        })
        .collect();
    pareto_chart(
        &dir.join("pareto.png"),
        "Run time against error (held-out samples)",
        "milliseconds per frame (log scale)",
        "mean per-vertex error (mm)",
        &points,
        &[
            "simulator",
            "GarMatNet",
            "baseline",
            "GarMatNet + simulator",
        ],
        (1000, 640),
    )
}

/// The note a report needs when the dataset's drapes come from another ground-truth
/// revision than this build's solver, which the simulator rows run (`simulated`).
pub(crate) fn revision_note(dataset_revision: Option<u32>, simulated: bool) -> Option<String> {
    (simulated && dataset_revision != Some(GROUND_TRUTH_REVISION)).then(|| {
        format!(
            "the dataset's drapes are ground-truth revision {}, the simulator rows ran \
             revision {GROUND_TRUTH_REVISION}: where the two solvers differ, even the \
             converged row does not reproduce the stored drapes",
            revision_label(dataset_revision)
        )
    })
}

impl BenchReport {
    /// The report as a markdown table, fastest first.
    #[must_use]
    pub fn to_markdown(&self) -> String {
        markdown(self)
    }
}

/// The report as a markdown table, fastest first.
fn markdown(report: &BenchReport) -> String {
    let mut md = String::from(
        "| method | device | batch | ms/frame | error (mm) | samples | size (MB) | Pareto |\n\
         |---|---|---:|---:|---:|---:|---:|:---:|\n",
    );
    for r in &report.rows {
        md.push_str(&format!(
            "| {} | {} | {} | {:.3} | {:.2} | {} | {} | {} |\n",
            r.method,
            r.device,
            r.batch,
            r.ms_per_frame,
            r.error_mm,
            r.samples,
            r.size_mb.map_or("–".into(), |s| format!("{s:.1}")),
            if r.pareto { "✓" } else { "" }
        ));
    }
    for (title, items) in [("Not measured", &report.skipped), ("Notes", &report.notes)] {
        if !items.is_empty() {
            md.push_str(&format!("\n{title}:\n"));
            for s in items {
                md.push_str(&format!("- {s}\n"));
            }
        }
    }
    md.push_str(&format!(
        "\n{} CPU threads available; samples: {}.\n",
        report.threads,
        report.samples.join(", ")
    ));
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(ms: Real, err: Real) -> BenchRow {
        BenchRow {
            method: format!("{ms}/{err}"),
            family: "garmatnet".into(),
            device: "cpu".into(),
            batch: 1,
            ms_per_frame: ms,
            error_mm: err,
            samples: 1,
            size_mb: None,
            pareto: false,
        }
    }

    #[test]
    fn pareto_front_keeps_only_undominated_rows() {
        let mut rows = vec![row(1.0, 9.0), row(2.0, 5.0), row(3.0, 6.0), row(100.0, 0.0)];
        mark_pareto(&mut rows);
        let front: Vec<bool> = rows.iter().map(|r| r.pareto).collect();
        assert_eq!(front, vec![true, true, false, true]);

        // The same model's batched and batch-1 rows: the same error up to f32 rounding, so
        // the slower one is dominated whichever way the rounding fell.
        for rounding in [5e-7, -5e-7] {
            let mut rows = vec![row(1.6, 14.444_086), row(1.9, 14.444_086 + rounding)];
            mark_pareto(&mut rows);
            assert_eq!(
                rows.iter().map(|r| r.pareto).collect::<Vec<_>>(),
                vec![true, false],
                "{rounding}"
            );
        }
    }

    #[test]
    fn a_dataset_of_another_revision_is_noted_when_the_simulator_ran() {
        assert_eq!(revision_note(Some(GROUND_TRUTH_REVISION), true), None);
        assert_eq!(
            revision_note(None, false),
            None,
            "no simulator rows, no note"
        );
        for other in [None, Some(GROUND_TRUTH_REVISION + 1)] {
            let note = revision_note(other, true).unwrap();
            assert!(note.contains("converged row does not reproduce"), "{note}");
            let report = BenchReport {
                dataset_hash: "h".into(),
                samples: vec!["m000_p0001".into()],
                rows: vec![row(1.0, 2.0)],
                skipped: Vec::new(),
                notes: vec![note.clone()],
                threads: 1,
            };
            assert!(markdown(&report).contains(&format!("Notes:\n- {note}")));
        }
    }
}
