//! What the training fabrics themselves say about a test fabric: where it lies against their
//! range of ω, and how well their true drapes would stand in for its own (the nearest
//! fabric in ω, and the best one chosen with the answer in hand).

use garmatnet_model::material_range::nearest;

use crate::data::loader::{SampleKey, TrainingDataset};
use crate::data::split::Split;
use crate::error::Result;
use crate::evaluation::prediction_errors::{
    Prediction, VertexErrors, error_stats, truth_as_prediction, vertex_errors,
};
use crate::evaluation::report::{FabricLookup, MaterialSupport};

/// Each test material against the range of the materials in the split's training set.
pub(crate) fn material_support(data: &TrainingDataset, split: &Split) -> Vec<MaterialSupport> {
    let spec = data.spec();
    let omega = |m: usize| spec.materials[m].omega_normalized;
    let Some(range) = split.material_range(spec) else {
        return Vec::new();
    };
    split
        .test_materials
        .iter()
        .map(|&m| MaterialSupport {
            material: spec.materials[m].name.clone(),
            outside: range.outside(&omega(m)),
        })
        .collect()
}

/// The training fabrics' true drapes as predictions of the `comparison` samples (see
/// [`FabricLookup`]); `None` when no training fabric was draped at those poses.
pub(crate) fn fabric_lookup(
    data: &TrainingDataset,
    split: &Split,
    comparison: &[SampleKey],
) -> Result<Option<FabricLookup>> {
    let spec = data.spec();
    let training: Vec<usize> = (0..spec.materials.len())
        .filter(|m| !split.test_materials.contains(m) && !split.dev_materials.contains(m))
        .collect();
    let have = |material: usize, pose: usize| {
        data.records()
            .binary_search_by_key(&(material, pose), |r| (r.material, r.pose))
            .is_ok()
    };
    let omega = |m: usize| spec.materials[m].omega_normalized;
    let mut nearest_to = Vec::new();
    let mut targets = Vec::new();
    for &target in &split.test_materials {
        let Some((nearest, _)) = nearest(&omega(target), training.iter().map(|&m| (m, omega(m))))
        else {
            return Ok(None);
        };
        nearest_to.push((
            spec.materials[target].name.clone(),
            spec.materials[nearest].name.clone(),
        ));
        targets.push((target, nearest));
    }
    let mut poses: Vec<usize> = comparison
        .iter()
        .filter(|k| split.test_materials.contains(&k.material))
        .map(|k| k.pose)
        .collect();
    poses.sort_unstable();
    poses.dedup();
    let (mut nearest_errors, mut best_errors) = (Vec::new(), Vec::new());
    for pose in poses {
        // Every training fabric's drape at this pose, read and decomposed once for all targets.
        let others = training
            .iter()
            .filter(|&&m| have(m, pose))
            .map(|&m| {
                let other = data.truth(SampleKey { material: m, pose })?;
                Ok((m, truth_as_prediction(&other)?))
            })
            .collect::<Result<Vec<(usize, Prediction)>>>()?;
        for &(target, nearest) in &targets {
            let key = SampleKey {
                material: target,
                pose,
            };
            if !comparison.contains(&key) {
                continue;
            }
            let truth = data.truth(key)?;
            let mut best: Option<(f64, VertexErrors)> = None;
            for (m, other) in &others {
                let errors = vertex_errors(&truth, other);
                if *m == nearest {
                    nearest_errors.push(errors.clone());
                }
                let whole: f64 = errors.whole.iter().sum();
                if best.as_ref().is_none_or(|(b, _)| whole < *b) {
                    best = Some((whole, errors));
                }
            }
            let Some((_, best)) = best else {
                return Ok(None);
            };
            best_errors.push(best);
        }
    }
    if nearest_errors.len() != best_errors.len() || best_errors.is_empty() {
        return Ok(None);
    }
    Ok(Some(FabricLookup {
        nearest_material: error_stats(nearest_errors.iter()),
        nearest_to,
        best_material: error_stats(best_errors.iter()),
    }))
}
