//! The evaluation's figures: per-pose error charts for each target material (the paper's
//! Figs. 7–8) and heat maps of per-vertex error on the garment (Figs. 11–12), with a PLY
//! coloured by error for viewers.

use std::path::Path;

use burn::prelude::*;
use garmatnet_core::render::{
    BODY_COLOR, Camera, RenderItem, RenderSettings, Shading, heat_colors, render, save_png,
    side_by_side,
};
use garmatnet_core::{Aabb, TriMesh, Vec3, write_ply};
use garmatnet_model::GarMatNetModel;

use crate::data::loader::{SampleKey, TrainingDataset};
use crate::data::split::Split;
use crate::error::{Error, Result};
use crate::evaluation::plots::{Series, line_chart};
use crate::evaluation::prediction_errors::{
    Mirror, VertexErrors, predict_baseline, predict_garmatnet,
};
use crate::evaluation::report::SampleErrors;
use crate::training::baseline::Baseline;
use garmatnet_core::slug;

pub(crate) fn per_pose_plots(
    out_dir: &Path,
    split: &Split,
    data: &TrainingDataset,
    per_sample: &[SampleErrors],
) -> Result<Vec<String>> {
    let mut files = Vec::new();
    for &m in &split.test_materials {
        let name = &data.spec().materials[m].name;
        let rows: Vec<&SampleErrors> = per_sample.iter().filter(|r| &r.material == name).collect();
        if rows.is_empty() {
            continue;
        }
        let mut series = vec![Series {
            label: "GarMatNet".into(),
            points: rows
                .iter()
                .map(|r| (r.frame as f64, r.garmatnet.whole_mm))
                .collect(),
        }];
        let baseline: Vec<(f64, f64)> = rows
            .iter()
            .filter_map(|r| r.baseline.map(|b| (r.frame as f64, b.whole_mm)))
            .collect();
        if !baseline.is_empty() {
            series.push(Series {
                label: "Baseline".into(),
                points: baseline,
            });
        }
        let file = format!("per_pose_{}.png", slug(name));
        line_chart(
            &out_dir.join(&file),
            &format!("{name}: mean per-vertex error per test pose"),
            "frame",
            "error (mm)",
            &series,
            (800, 450),
        )?;
        files.push(file);
    }
    Ok(files)
}

/// Heat maps of the whole error for two poses of the first target material (the worst and
/// the median pose by GarMatNet's error): GarMatNet left, baseline right, one colour scale;
/// plus a PLY of GarMatNet's prediction coloured by its error.
pub(crate) fn heat_maps(
    out_dir: &Path,
    split: &Split,
    data: &TrainingDataset,
    garmatnet: &[(SampleKey, VertexErrors)],
    (baseline, baseline_nets): (&[(SampleKey, VertexErrors)], Option<&Baseline>),
    (model, mirror): (&GarMatNetModel, Mirror<'_>),
    device: &Device,
) -> Result<Vec<String>> {
    // The first target material, or without targets the first fabric tested.
    let Some(material) = split
        .test_materials
        .first()
        .copied()
        .or_else(|| split.test.first().map(|k| k.material))
    else {
        return Ok(Vec::new());
    };
    let baseline_net =
        baseline_nets.and_then(|b| b.materials.iter().find(|m| m.material == material));
    let held_out = |k: &SampleKey| split.held_out_poses.binary_search(&k.pose).is_ok();
    let mut candidates: Vec<&(SampleKey, VertexErrors)> = garmatnet
        .iter()
        .filter(|(k, _)| k.material == material && held_out(k))
        .collect();
    if candidates.is_empty() {
        return Ok(Vec::new());
    }
    let mean = |e: &VertexErrors| e.whole.iter().sum::<f64>();
    candidates.sort_by(|a, b| mean(&a.1).total_cmp(&mean(&b.1)));
    let mut chosen = vec![candidates[candidates.len() - 1]];
    let median = candidates[candidates.len() / 2];
    if median.0 != chosen[0].0 {
        chosen.push(median);
    }
    let name = slug(&data.spec().materials[material].name);
    let faces = data.garment().rest.faces.clone();
    let mut files = Vec::new();
    for (key, errors) in chosen {
        let truth = data.truth(*key)?;
        let pred = predict_garmatnet(model, data, &[*key], device, mirror)?.remove(0);
        let garment: Vec<Vec3> = truth
            .body_points
            .iter()
            .zip(pred.d_fitting.iter().zip(&pred.d_local))
            .map(|(b, (f, l))| b + (f + l))
            .collect();
        let base = baseline.iter().find(|(k, _)| k == key).map(|(_, e)| e);
        let scale = errors
            .whole
            .iter()
            .chain(base.iter().flat_map(|e| e.whole.iter()))
            .fold(0.0f64, |a, &b| a.max(b));
        let mesh = TriMesh::new(garment, faces.clone())?;
        let body_mesh = data.body().pose(&data.spec().poses[key.pose]).mesh();
        let bounds = Aabb::of_points(&truth.simulated).ok_or_else(|| Error::Dataset {
            dir: data.dir().to_owned(),
            message: "a sample has no garment vertices".into(),
        })?;
        let camera = Camera::framing(bounds.min, bounds.max, 0.0);
        let settings = RenderSettings {
            width: 360,
            height: 480,
            ..RenderSettings::default()
        };
        let draw = |m: &TriMesh, colours: &[[u8; 3]]| {
            render(
                &[
                    RenderItem {
                        mesh: &body_mesh,
                        shading: Shading::Uniform(BODY_COLOR),
                    },
                    RenderItem {
                        mesh: m,
                        shading: Shading::PerVertex(colours),
                    },
                ],
                &camera,
                &settings,
            )
        };
        let colours = heat_colors(&errors.whole, scale);
        let mut images = vec![draw(&mesh, &colours)?];
        if let (Some(b), Some(net)) = (base, baseline_net) {
            let pred_b = predict_baseline(net, data, &[*key], device, mirror)?.remove(0);
            let garment_b: Vec<Vec3> = truth
                .body_points
                .iter()
                .zip(pred_b.d_fitting.iter().zip(&pred_b.d_local))
                .map(|(p, (f, l))| p + (f + l))
                .collect();
            let mesh_b = TriMesh::new(garment_b, faces.clone())?;
            images.push(draw(&mesh_b, &heat_colors(&b.whole, scale))?);
        }
        let frame = data.spec().frames[key.pose];
        let png = format!("heatmap_{name}_frame{frame}.png");
        save_png(&out_dir.join(&png), &side_by_side(&images, [255, 255, 255]))?;
        let ply = format!("errors_{name}_frame{frame}.ply");
        write_ply(out_dir.join(&ply), &mesh, Some(&colours))?;
        files.push(png);
        files.push(ply);
    }
    Ok(files)
}
