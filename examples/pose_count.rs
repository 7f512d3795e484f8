//! Run: `cargo run --release --example pose_count -- --out pose-count.png POSES=REPORT_DIR ...`
//!
//! The error away from the training data against the number of training poses: each
//! `POSES=REPORT_DIR` names a model's training poses (per fabric, or in all for a strided
//! dataset) and the directory of its held-out `eval` report (`garmatnet eval --model M
//! --held-out NAME=DIR ... --report REPORT_DIR`, whose `report.json` this reads). It prints
//! every held-out set's whole error per model, fits `error = a · poses^b` to each set by least
//! squares on the logarithms, prints `b` and the pose count at which the fit reaches
//! `--target` millimetres, and draws the points on a chart (`--out`, PNG; each set's `b` in the
//! legend). The reports must all be mirror-averaged or all raw (`--no-mirror-averaging`).

use std::path::PathBuf;

use anyhow::{Context, Result, bail, ensure};
use clap::Parser;
use garmatnet::train::{HeldOutReport, Series, line_chart};

/// Command-line arguments.
#[derive(Debug, Parser)]
struct Args {
    /// The chart to write (PNG).
    #[arg(long)]
    out: PathBuf,
    /// The error to reach, in mm (the pose count the fit needs for it is printed).
    #[arg(long, default_value_t = 8.0)]
    target: f64,
    /// `POSES=REPORT_DIR`: training poses, and a held-out eval report's directory.
    #[arg(required = true, value_parser = parse_point)]
    points: Vec<(f64, PathBuf)>,
}

/// Parses `POSES=REPORT_DIR`.
fn parse_point(s: &str) -> Result<(f64, PathBuf)> {
    let (poses, dir) = s
        .split_once('=')
        .with_context(|| format!("{s:?}: expected POSES=REPORT_DIR"))?;
    let poses: f64 = poses
        .parse()
        .with_context(|| format!("{poses:?}: the training poses must be a number"))?;
    ensure!(
        poses.is_finite() && poses > 0.0,
        "{poses}: the training poses must be a positive number"
    );
    Ok((poses, PathBuf::from(dir)))
}

/// Least-squares fit of `ln y = ln a + b ln x`: returns `(a, b)`, or `None` for fewer than
/// two distinct x.
fn power_law(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let n = points.len() as f64;
    let (sx, sy) = points
        .iter()
        .fold((0.0, 0.0), |(sx, sy), &(x, y)| (sx + x.ln(), sy + y.ln()));
    let (mx, my) = (sx / n, sy / n);
    let (sxx, sxy) = points.iter().fold((0.0, 0.0), |(sxx, sxy), &(x, y)| {
        let dx = x.ln() - mx;
        (sxx + dx * dx, sxy + dx * (y.ln() - my))
    });
    (sxx > 0.0).then(|| {
        let b = sxy / sxx;
        ((my - b * mx).exp(), b)
    })
}

fn main() -> Result<()> {
    let args = Args::parse();
    ensure!(
        args.target.is_finite() && args.target > 0.0,
        "--target must be a positive number of mm"
    );
    let mut reports = Vec::with_capacity(args.points.len());
    for (poses, dir) in &args.points {
        let path = dir.join("report.json");
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("reading {}", path.display()))?;
        let report: HeldOutReport = serde_json::from_str(&text)
            .with_context(|| format!("{}: not a held-out eval report", path.display()))?;
        if report.held_out_sets.is_empty() {
            bail!("{}: no held-out sets", path.display());
        }
        reports.push((*poses, dir, report));
    }
    let averaged = reports[0].2.mirror_averaging;
    if let Some((_, dir, r)) = reports
        .iter()
        .find(|(_, _, r)| r.mirror_averaging != averaged)
    {
        bail!(
            "{}: mirror averaging {}, {}'s {averaged}: evaluate them alike",
            dir.display(),
            r.mirror_averaging,
            reports[0].1.display()
        );
    }
    let mut series: Vec<Series> = Vec::new();
    for (poses, dir, report) in &reports {
        let path = dir.join("report.json");
        for set in &report.held_out_sets {
            let error = set.all.whole_mm;
            ensure!(
                error.is_finite() && error > 0.0,
                "{}: set {} has error {error} mm, not a positive number",
                path.display(),
                set.name
            );
            let point = (*poses, error);
            match series.iter_mut().find(|s| s.label == set.name) {
                Some(s) => s.points.push(point),
                None => series.push(Series {
                    label: set.name.clone(),
                    points: vec![point],
                }),
            }
            println!(
                "{poses:>6} poses  {:<18} {:>6.2} mm  ({} samples, {})",
                set.name,
                error,
                set.all.samples,
                dir.display()
            );
        }
    }
    for s in &mut series {
        s.points.sort_by(|a, b| a.0.total_cmp(&b.0));
        match power_law(&s.points) {
            Some((a, b)) => {
                let reach = if b < 0.0 {
                    format!(
                        "{} mm at {:.0} poses",
                        args.target,
                        (args.target / a).powf(1.0 / b)
                    )
                } else {
                    "the fit does not fall with more poses".to_owned()
                };
                println!("{}: error = {a:.2} · poses^{b:.3}; {reach}", s.label);
                s.label = format!("{} (poses^{b:.2})", s.label);
            }
            None => println!("{}: fewer than two pose counts, no fit", s.label),
        }
    }
    line_chart(
        &args.out,
        "Error away from the training data against training poses",
        "training poses",
        "mean per-vertex error (mm)",
        &series,
        (900, 560),
    )?;
    println!("wrote {}", args.out.display());
    Ok(())
}
