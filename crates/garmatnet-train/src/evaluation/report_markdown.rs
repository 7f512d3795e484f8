//! `report.md`: the evaluation [`Report`] as Markdown tables, all errors in millimetres.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use crate::evaluation::report::{
    ErrorStats, HeldOutReport, HeldOutSet, MaterialErrors, PartErrors, PhysicalQuality, Report,
    SampleErrors,
};

impl Report {
    /// The report as Markdown tables.
    #[must_use]
    pub fn to_markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# GarMatNet evaluation\n");
        let _ = writeln!(
            s,
            "Dataset `{}`, displacement frame `{}`, test materials: {}; {} held-out poses \
             ({}).\n",
            self.dataset_hash,
            self.displacement_frame,
            if self.test_materials.is_empty() {
                "none (every fabric trained on)".to_owned()
            } else {
                self.test_materials.join(", ")
            },
            self.held_out_poses,
            self.held_out_rule
        );
        let _ = writeln!(
            s,
            "Mirror averaging {}.\n",
            if self.mirror_averaging {
                "on"
            } else {
                "off (the nets' own predictions)"
            }
        );
        let _ = writeln!(
            s,
            "## Mean per-vertex error (mm), {}\n",
            if self.test_materials.is_empty() {
                "every fabric × held-out poses"
            } else {
                "target materials × held-out poses (Table 2)"
            }
        );
        let _ = writeln!(
            s,
            "| Method | Samples | Generally-fitting | Locally-detailed | Whole | Whole p95 | Whole max |"
        );
        let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|");
        error_row(&mut s, "GarMatNet", &self.garmatnet);
        if let Some(b) = &self.baseline {
            error_row(&mut s, "Baseline (TailorNet-style)", b);
        }
        // Without target materials the comparison set is the whole test set (and its
        // unseen-pose part): the same numbers are not repeated.
        let repeats = |e: &ErrorStats| {
            e.samples == self.garmatnet.samples
                && e.whole_mm.to_bits() == self.garmatnet.whole_mm.to_bits()
        };
        if !repeats(&self.garmatnet_all_test) {
            error_row(
                &mut s,
                "GarMatNet, whole test set",
                &self.garmatnet_all_test,
            );
        }
        if let Some(parts) = &self.garmatnet_by_part {
            let dev_name = if let Some((offset, every)) = parts.dev_frames {
                format!(
                    "GarMatNet, development set (training fabrics at unseen poses: frames \
                     {offset} mod {every})"
                )
            } else if parts.dev_materials.is_empty() {
                "GarMatNet, development set (seen fabric and pose)".to_owned()
            } else {
                format!(
                    "GarMatNet, development set (unseen fabrics {} at training poses)",
                    parts.dev_materials.join(", ")
                )
            };
            for (name, part) in [
                (
                    "GarMatNet, unseen fabric at training poses",
                    &parts.unseen_material,
                ),
                (
                    "GarMatNet, training fabrics at unseen poses",
                    &parts.unseen_pose,
                ),
                (dev_name.as_str(), &parts.development),
            ] {
                if let Some(e) = part.as_ref().filter(|e| !repeats(e)) {
                    error_row(&mut s, name, e);
                }
            }
        }
        held_out_rows(&mut s, &self.held_out_sets);
        if let Some(f) = &self.fabric_lookup {
            let nearest: Vec<String> = f
                .nearest_to
                .iter()
                .map(|(target, near)| format!("{target} → {near}"))
                .collect();
            let _ = writeln!(
                s,
                "\nReference rows, not predictions: the true drape at the same held-out pose of a \
                 fabric the model trained on (nearest in ω: {}; best: the closest of them, \
                 chosen by the truth).\n",
                nearest.join(", ")
            );
            let _ = writeln!(
                s,
                "| Reference | Samples | Generally-fitting | Locally-detailed | Whole | Whole p95 | Whole max |"
            );
            let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|");
            error_row(
                &mut s,
                "Nearest training fabric in ω, true drape",
                &f.nearest_material,
            );
            error_row(
                &mut s,
                "Best training fabric, true drape (oracle)",
                &f.best_material,
            );
        }
        if !self.material_support.is_empty() {
            let _ = writeln!(
                s,
                "\nTest materials against the training materials' range of normalised ω: \
                 inside it the model interpolates, outside it extrapolates.\n"
            );
            let _ = writeln!(s, "| Material | Outside the training range |");
            let _ = writeln!(s, "|---|---|");
            for m in &self.material_support {
                let outside = if m.outside.is_empty() {
                    "inside".to_owned()
                } else {
                    m.outside
                        .iter()
                        .map(ToString::to_string)
                        .collect::<Vec<_>>()
                        .join("; ")
                };
                let _ = writeln!(s, "| {} | {outside} |", m.material);
            }
        }
        per_material_table(&mut s, &self.per_sample);
        test_set_material_table(&mut s, &self.per_material);
        for set in &self.held_out_sets {
            held_out_material_table(&mut s, &set.name, &set.per_material);
            held_out_pose_table(&mut s, &set.name, &set.per_sample);
        }
        symmetry_table(&mut s, &self.held_out_sets);
        fabric_distance_table(&mut s, self);
        let _ = writeln!(s, "\n## Per material and pose (whole pipeline, mm)\n");
        let _ = writeln!(s, "| Material | Pose | Frame | GarMatNet | Baseline |");
        let _ = writeln!(s, "|---|---:|---:|---:|---:|");
        for r in &self.per_sample {
            let b = r
                .baseline
                .map_or_else(|| "–".to_owned(), |b| format!("{:.2}", b.whole_mm));
            let _ = writeln!(
                s,
                "| {} | {} | {} | {:.2} | {b} |",
                r.material, r.pose, r.frame, r.garmatnet.whole_mm
            );
        }
        let p = &self.penetration;
        let _ = writeln!(
            s,
            "\n## Body penetration (push-out ε = {:.1} mm)\n",
            p.epsilon_mm
        );
        let _ = writeln!(s, "| | Before | After |\n|---|---:|---:|");
        let _ = writeln!(
            s,
            "| Vertices inside the body | {:.2} % | {:.2} % |",
            100.0 * p.inside_fraction_before,
            100.0 * p.inside_fraction_after
        );
        let _ = writeln!(
            s,
            "| Deepest penetration (mm) | {:.2} | {:.2} |",
            p.max_depth_before_mm, p.max_depth_after_mm
        );
        let _ = writeln!(
            s,
            "| Whole error (mm) | {:.2} | {:.2} |",
            self.garmatnet_all_test.whole_mm, p.whole_mm_after
        );
        if let Some(q) = &self.physical_quality {
            let _ = writeln!(
                s,
                "\n## Physical quality (raw predictions, before push-out)\n"
            );
            physical_quality_table(&mut s, "the test set", q);
        }
        for set in &self.held_out_sets {
            if let Some(q) = &set.physical_quality {
                physical_quality_table(&mut s, &set.name, q);
            }
        }
        let t = &self.timing;
        let _ = writeln!(s, "\n## Speed and size\n");
        let _ = writeln!(s, "| | Value |\n|---|---:|");
        let _ = writeln!(s, "| Device | {} |", t.device);
        let _ = writeln!(s, "| ms/frame, batch 1 | {:.2} |", t.batch1_ms_per_frame);
        let _ = writeln!(
            s,
            "| ms/frame, batch {} | {:.3} |",
            t.batch_size, t.batched_ms_per_frame
        );
        let _ = writeln!(
            s,
            "| GarMatNet model (MB) | {:.2} |",
            self.sizes.garmatnet_mb
        );
        if let Some(b) = self.sizes.baseline_mb {
            let _ = writeln!(s, "| Baseline, all materials (MB) | {b:.2} |");
        }
        if let Some(c) = &self.frame_comparison {
            let _ = writeln!(s, "\n## Displacement frame\n");
            let _ = writeln!(s, "| Frame | Whole error (mm) |\n|---|---:|");
            let _ = writeln!(s, "| {} | {:.2} |", c.primary.0, c.primary.1);
            let _ = writeln!(s, "| {} | {:.2} |", c.other.0, c.other.1);
            let _ = writeln!(s, "\nWinner: **{}**.", c.winner);
        }
        if !self.files.is_empty() {
            let _ = writeln!(s, "\n## Figures\n");
            for f in &self.files {
                if f.ends_with(".png") {
                    let _ = writeln!(s, "![{f}]({f})");
                } else {
                    let _ = writeln!(s, "- [{f}]({f})");
                }
            }
        }
        s
    }
}

/// Mean whole-pipeline error per material over its samples in `rows` (GarMatNet, and the
/// baseline where it has every sample of that material), best first.
fn per_material_table(s: &mut String, rows: &[SampleErrors]) {
    let mut materials: Vec<(&str, Vec<&SampleErrors>)> = Vec::new();
    for r in rows {
        match materials.iter_mut().find(|(m, _)| *m == r.material) {
            Some((_, list)) => list.push(r),
            None => materials.push((&r.material, vec![r])),
        }
    }
    if materials.len() < 2 {
        return;
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let mut table: Vec<(&str, usize, f64, Option<f64>)> = materials
        .iter()
        .map(|(m, list)| {
            let garmatnet: Vec<f64> = list.iter().map(|r| r.garmatnet.whole_mm).collect();
            let baseline: Option<Vec<f64>> = list
                .iter()
                .map(|r| r.baseline.map(|b| b.whole_mm))
                .collect();
            (*m, list.len(), mean(&garmatnet), baseline.map(|b| mean(&b)))
        })
        .collect();
    table.sort_by(|a, b| a.2.total_cmp(&b.2));
    let _ = writeln!(
        s,
        "\n## Per material (whole pipeline, mean over its samples below, mm)\n"
    );
    let _ = writeln!(s, "| Material | Samples | GarMatNet | Baseline |");
    let _ = writeln!(s, "|---|---:|---:|---:|");
    for (m, n, g, b) in table {
        let b = b.map_or_else(|| "–".to_owned(), |b| format!("{b:.2}"));
        let _ = writeln!(s, "| {m} | {n} | {g:.2} | {b} |");
    }
}

/// GarMatNet's error per material over the whole test set, where it has more than the
/// comparison set (with no unseen material the two are the same, and the table above has it).
fn test_set_material_table(s: &mut String, rows: &[MaterialErrors]) {
    if rows.iter().all(|r| r.unseen) || rows.iter().all(|r| !r.unseen) {
        return;
    }
    let _ = writeln!(
        s,
        "\n## Per material, whole test set (GarMatNet, mm): a fabric it never trained on at \
         every pose, a training fabric at the held-out poses\n"
    );
    let _ = writeln!(
        s,
        "| Material | Samples | Generally-fitting | Locally-detailed | Whole | Whole p95 | Whole max |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|");
    for r in rows {
        error_row(s, &material_label(r), &r.garmatnet);
    }
}

impl HeldOutReport {
    /// The report as Markdown tables.
    #[must_use]
    pub fn to_markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "# GarMatNet on held-out sets
"
        );
        let _ = writeln!(
            s,
            "Model `{}` ({} training fabrics recorded), mirror averaging {}.\n",
            self.model,
            self.training_fabrics.len(),
            if self.mirror_averaging { "on" } else { "off" }
        );
        let _ = writeln!(s, "## Mean per-vertex error (mm)\n");
        let _ = writeln!(
            s,
            "| Method | Samples | Generally-fitting | Locally-detailed | Whole | Whole p95 | Whole max |"
        );
        let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|");
        held_out_rows(&mut s, &self.held_out_sets);
        for set in &self.held_out_sets {
            held_out_material_table(&mut s, &set.name, &set.per_material);
            held_out_pose_table(&mut s, &set.name, &set.per_sample);
        }
        symmetry_table(&mut s, &self.held_out_sets);
        for set in &self.held_out_sets {
            if let Some(q) = &set.physical_quality {
                physical_quality_table(&mut s, &set.name, q);
            }
        }
        s
    }
}

/// Each held-out set's rows of the error table: all of it, its training and unseen fabrics
/// when it has both, and its converged truths when some did not converge.
fn held_out_rows(s: &mut String, sets: &[HeldOutSet]) {
    for set in sets {
        for (part, stats) in [
            ("", Some(&set.all)),
            (", training fabrics", set.training_fabrics.as_ref()),
            (", unseen fabrics", set.unseen_fabrics.as_ref()),
        ] {
            if let Some(e) = stats.filter(|e| part.is_empty() || e.samples != set.all.samples) {
                error_row(s, &format!("GarMatNet, {}{part}", set.name), e);
            }
        }
        if let Some(e) = &set.converged_only {
            let name = format!(
                "GarMatNet, {}, converged truth only ({} left out)",
                set.name, set.unconverged
            );
            error_row(s, &name, e);
        }
    }
}

/// The mirror asymmetry of predictions and truths at the held-out sets' symmetric poses.
fn symmetry_table(s: &mut String, sets: &[HeldOutSet]) {
    if sets.iter().all(|set| set.symmetry.is_none()) {
        return;
    }
    let _ = writeln!(
        s,
        "\n## Mirror asymmetry at left-right symmetric poses (mm, mean over vertices of \
         |x_i − mirror(x_twin)|, predictions before push-out)\n"
    );
    let _ = writeln!(
        s,
        "| Set | Samples | Prediction, mean | Prediction, max | Truth, mean | Truth, max |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|");
    for set in sets {
        if let Some(m) = &set.symmetry {
            let _ = writeln!(
                s,
                "| {} | {} | {:.2} | {:.2} | {:.2} | {:.2} |",
                set.name,
                m.samples,
                m.prediction_mean_mm,
                m.prediction_max_mm,
                m.truth_mean_mm,
                m.truth_max_mm
            );
        }
    }
}

/// GarMatNet's error per fabric of a held-out set, each unseen fabric with its nearest
/// training fabric.
fn held_out_material_table(s: &mut String, set: &str, rows: &[MaterialErrors]) {
    if rows.len() < 2 {
        return;
    }
    let _ = writeln!(s, "\n## Per material, {set} (GarMatNet, mm)\n");
    let _ = writeln!(
        s,
        "| Material | Samples | Generally-fitting | Locally-detailed | Whole | Whole p95 | Whole max |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|");
    for r in rows {
        error_row(s, &material_label(r), &r.garmatnet);
    }
}

/// GarMatNet's error per pose of a held-out set, averaged over the set's fabrics at that
/// pose, with the fabric it errs most at there: which poses the model handles worst.
fn held_out_pose_table(s: &mut String, set: &str, rows: &[SampleErrors]) {
    let mut poses: BTreeMap<usize, Vec<&SampleErrors>> = BTreeMap::new();
    for r in rows {
        poses.entry(r.pose).or_default().push(r);
    }
    if poses.len() < 2 {
        return;
    }
    let _ = writeln!(
        s,
        "\n## Per pose, {set} (GarMatNet, mean over the pose's fabrics, mm)\n"
    );
    let _ = writeln!(
        s,
        "| Pose | Frame | Fabrics | Generally-fitting | Locally-detailed | Whole | Worst fabric |"
    );
    let _ = writeln!(s, "|---:|---:|---:|---:|---:|---:|---|");
    for (pose, at) in poses {
        let n = at.len() as f64;
        let mean = |f: fn(&PartErrors) -> f64| at.iter().map(|r| f(&r.garmatnet)).sum::<f64>() / n;
        let worst = at
            .iter()
            .max_by(|a, b| a.garmatnet.whole_mm.total_cmp(&b.garmatnet.whole_mm))
            .map(|r| format!("{} ({:.2})", r.material, r.garmatnet.whole_mm))
            .unwrap_or_default();
        let label = match &at[0].pose_name {
            Some(name) => format!("{pose} ({name})"),
            None => pose.to_string(),
        };
        let _ = writeln!(
            s,
            "| {label} | {} | {} | {:.2} | {:.2} | {:.2} | {worst} |",
            at[0].frame,
            at.len(),
            mean(|e| e.fitting_mm),
            mean(|e| e.local_mm),
            mean(|e| e.whole_mm),
        );
    }
}

/// A material's row label: an unseen fabric says so and names its nearest training fabric.
fn material_label(r: &MaterialErrors) -> String {
    match (&r.nearest_training, r.unseen) {
        (Some(n), _) => format!(
            "{} (never trained on; nearest: {}, {:.3} away)",
            r.material, n.material, n.distance
        ),
        (None, true) => format!("{} (never trained on)", r.material),
        (None, false) => r.material.clone(),
    }
}

/// The upper ends of [`fabric_distance_table`]'s bins of distance in normalised ω.
const DISTANCE_BINS: [f64; 5] = [0.10, 0.15, 0.20, 0.30, 0.40];

/// The bin of [`DISTANCE_BINS`] a distance falls in (the last is open).
fn distance_bin(distance: f64) -> usize {
    DISTANCE_BINS
        .iter()
        .position(|&upper| distance < upper)
        .unwrap_or(DISTANCE_BINS.len())
}

/// The error against the distance from each fabric to the nearest training fabric, per set
/// (the test set's unseen fabrics at every pose, each held-out set's fabrics at its poses):
/// the training fabrics at distance 0, then the unseen ones in bins of distance.
fn fabric_distance_table(s: &mut String, report: &Report) {
    let sets: Vec<(&str, &[MaterialErrors])> =
        std::iter::once(("test set", report.per_material.as_slice()))
            .chain(
                report
                    .held_out_sets
                    .iter()
                    .map(|set| (set.name.as_str(), set.per_material.as_slice())),
            )
            .filter(|(_, rows)| rows.iter().any(|r| r.nearest_training.is_some()))
            .collect();
    if sets.is_empty() {
        return;
    }
    let _ = writeln!(
        s,
        "\n## Error against the distance to the nearest training fabric (normalised ω)\n"
    );
    let _ = writeln!(
        s,
        "Each fabric's mean whole error over its samples in the set; a bin's mean weighs \
         every sample alike. A flat column means the model generalises across fabrics.\n"
    );
    let _ = writeln!(
        s,
        "| Set | Distance | Fabrics | Samples | Whole (mm) | Range over fabrics (mm) |"
    );
    let _ = writeln!(s, "|---|---|---:|---:|---:|---:|");
    for (name, rows) in sets {
        let mut bins: Vec<(String, Vec<&MaterialErrors>)> =
            vec![("trained on".to_owned(), Vec::new())];
        let mut lower = 0.0;
        for upper in DISTANCE_BINS {
            bins.push((format!("{lower:.2}–{upper:.2}"), Vec::new()));
            lower = upper;
        }
        bins.push((format!("{lower:.2} and beyond"), Vec::new()));
        for r in rows {
            let bin = match &r.nearest_training {
                Some(n) => 1 + distance_bin(n.distance),
                None if !r.unseen => 0,
                None => continue,
            };
            bins[bin].1.push(r);
        }
        for (label, members) in bins.iter().filter(|(_, m)| !m.is_empty()) {
            let samples: usize = members.iter().map(|r| r.garmatnet.samples).sum();
            let mean = members
                .iter()
                .map(|r| r.garmatnet.whole_mm * r.garmatnet.samples as f64)
                .sum::<f64>()
                / samples.max(1) as f64;
            let (lo, hi) = members
                .iter()
                .fold((f64::INFINITY, 0.0_f64), |(lo, hi), r| {
                    (lo.min(r.garmatnet.whole_mm), hi.max(r.garmatnet.whole_mm))
                });
            let _ = writeln!(
                s,
                "| {name} | {label} | {} | {samples} | {mean:.2} | {lo:.2}–{hi:.2} |",
                members.len()
            );
        }
    }
}

/// One row of an error table: samples, the three parts and the spread of the whole error.
fn error_row(s: &mut String, name: &str, e: &ErrorStats) {
    let _ = writeln!(
        s,
        "| {name} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} |",
        e.samples, e.fitting_mm, e.local_mm, e.whole_mm, e.whole_p95_mm, e.whole_max_mm
    );
}

/// One set's physical-quality table, prediction beside the ground truth.
fn physical_quality_table(s: &mut String, name: &str, q: &PhysicalQuality) {
    let _ = writeln!(s, "\n{name}, {} samples:\n", q.samples);
    let _ = writeln!(s, "| | Prediction | Ground truth |\n|---|---:|---:|");
    let _ = writeln!(
        s,
        "| Force residual, median (RMS force over weight; friction, the final projection and f32 storage move the truth's) | {:.2} | {:.2} |",
        q.median_residual, q.truth_median_residual
    );
    let _ = writeln!(
        s,
        "| Deepest penetration (mm), mean / worst | {:.2} / {:.2} | worst {:.2} |",
        q.mean_depth_mm, q.worst_depth_mm, q.truth_worst_depth_mm
    );
    let _ = writeln!(
        s,
        "| Mean largest spring stretch | {:.3} | {:.3} |",
        q.mean_max_stretch, q.truth_mean_max_stretch
    );
    let _ = writeln!(
        s,
        "| Samples past the sound stretch ({}) | {} (worst {:.3}) | |",
        q.sound_stretch, q.past_sound_stretch, q.worst_stretch
    );
    let _ = writeln!(
        s,
        "| Energy above the ground truth per unit weight (mm), mean / median | {:.2} / {:.2} | 0 |",
        q.mean_energy_above_truth_mm, q.median_energy_above_truth_mm
    );
    if let Some(n) = &q.newton {
        let _ = writeln!(
            s,
            "| Newton iterations to converge ({} samples; converged) | {:.0} ({}) | {:.0} (the protocol's final converge) |",
            n.samples, n.mean_iterations, n.converged, n.truth_mean_iterations
        );
        let _ = writeln!(
            s,
            "| Polished drape's distance to the ground truth (mm) | {:.2} | 0 |",
            n.mean_distance_to_truth_mm
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pose_table_averages_each_pose_over_its_fabrics_and_names_the_worst() {
        let row = |material: &str, pose: usize, name: Option<&str>, whole_mm: f64| SampleErrors {
            material: material.into(),
            pose,
            frame: pose,
            pose_name: name.map(str::to_owned),
            garmatnet: PartErrors {
                fitting_mm: whole_mm / 2.0,
                local_mm: 1.0,
                whole_mm,
            },
            baseline: None,
        };
        let rows = [
            row("Tulle", 0, Some("t-pose"), 4.0),
            row("Tulle", 7, Some("arms-crossed"), 10.0),
            row("Felt", 0, Some("t-pose"), 6.0),
            row("Felt", 7, Some("arms-crossed"), 14.0),
        ];
        let mut s = String::new();
        held_out_pose_table(&mut s, "everyday", &rows);
        assert!(s.contains("## Per pose, everyday"), "{s}");
        assert!(
            s.contains("| 0 (t-pose) | 0 | 2 | 2.50 | 1.00 | 5.00 | Felt (6.00) |"),
            "{s}"
        );
        assert!(
            s.contains("| 7 (arms-crossed) | 7 | 2 | 6.00 | 1.00 | 12.00 | Felt (14.00) |"),
            "{s}"
        );
        // One pose is no table.
        let mut one = String::new();
        held_out_pose_table(&mut one, "everyday", &rows[..1]);
        assert!(one.is_empty());
    }

    #[test]
    fn distance_bins_are_half_open_and_the_last_is_unbounded() {
        assert_eq!(distance_bin(0.0), 0);
        assert_eq!(distance_bin(0.099), 0);
        assert_eq!(distance_bin(0.10), 1);
        assert_eq!(distance_bin(0.2999), 3);
        assert_eq!(distance_bin(0.30), 4);
        assert_eq!(distance_bin(0.40), DISTANCE_BINS.len());
        assert_eq!(distance_bin(3.0), DISTANCE_BINS.len());
    }
}
