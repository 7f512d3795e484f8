//! Ensembles: several trained models averaged into one model file that is itself a GarMatNet.
//!
//! Nets trained from different random initialisations on the same data disagree most where
//! they have seen least — at poses between the training poses — and their mean errs less
//! than any of them (measured in book/src/experiments/ensembles.md). Averaging K members of the
//! paper's architecture is exactly another, K-times wider net of the same architecture:
//!
//! - the pose and material branches are the members' branches side by side;
//! - the merged layer is block-diagonal (member k's block reads only member k's branches);
//! - the output layer is block-diagonal over the members' low-rank coefficients, and the
//!   basis stacks the members' bases, each scaled by 1/K and re-expressed in the first
//!   member's output normaliser (a full-width output layer stacks the same way).
//!
//! So an ensemble loads, predicts, caches material features and evaluates through every
//! existing path ([`crate::Predictor`], [`crate::Scene`], evaluation) with no change to the
//! model file format; it costs K times the members' size and time.

use burn::module::Param;
use burn::nn::{DropoutConfig, Linear};
use burn::prelude::*;

use crate::error::{Error, Result};
use crate::file::model_file::{GarMatNetModel, ModelMeta, TrainingProvenance};
use crate::net::garmatnet_net::{GarMatNet, GarMatNetConfig};
use crate::net::output_normalizer::OutputNormalizer;
use crate::net::tensor_util::{matrix, to_f32, vector};

/// A row-major `[rows, cols]` block of `f32` values read back from a tensor.
struct Dense {
    cols: usize,
    values: Vec<f32>,
}

impl Dense {
    fn of(t: Tensor<2>) -> Self {
        let [_, cols] = t.dims();
        Self {
            cols,
            values: to_f32(t),
        }
    }

    fn row(&self, r: usize) -> &[f32] {
        &self.values[r * self.cols..(r + 1) * self.cols]
    }
}

/// A `[rows, cols]` matrix under construction, zero where no member writes.
struct Assembly {
    rows: usize,
    cols: usize,
    values: Vec<f32>,
}

impl Assembly {
    fn zeros(rows: usize, cols: usize) -> Self {
        Self {
            rows,
            cols,
            values: vec![0.0; rows * cols],
        }
    }

    /// Copies `source` into row `to`, starting at column `col`.
    fn put_row(&mut self, to: usize, col: usize, source: &[f32]) {
        let start = to * self.cols + col;
        self.values[start..start + source.len()].copy_from_slice(source);
    }

    /// Copies `source ⊙ scale` into row `to`, starting at column `col`.
    fn put_scaled_row(&mut self, to: usize, col: usize, source: &[f32], scale: &[f32]) {
        let start = to * self.cols + col;
        for ((out, v), s) in self.values[start..start + source.len()]
            .iter_mut()
            .zip(source)
            .zip(scale)
        {
            *out = v * s;
        }
    }

    fn into_param(self, device: &Device) -> Param<Tensor<2>> {
        Param::from_tensor(matrix(self.values, self.rows, self.cols, device))
    }
}

fn bias_of(layer: &Linear) -> Vec<f32> {
    match &layer.bias {
        Some(b) => to_f32(b.val()),
        None => vec![0.0; layer.weight.dims()[1]],
    }
}

fn linear(weight: Assembly, bias: Vec<f32>, device: &Device) -> Linear {
    Linear {
        weight: weight.into_param(device),
        bias: Some(Param::from_tensor(vector(bias, device))),
    }
}

/// Checks that `other` can be averaged with `first`: everything but the widths and ranks
/// must agree.
fn ensure_compatible(first: &GarMatNetConfig, other: &GarMatNetConfig, what: &str) -> Result<()> {
    let describe = |c: &GarMatNetConfig| {
        [
            ("vertex_count", c.vertex_count.to_string()),
            ("alpha", c.alpha.to_string()),
            ("displacement_frame", format!("{:?}", c.displacement_frame)),
            ("scale_free_material", c.scale_free_material.to_string()),
            ("pose_encoding", format!("{:?}", c.pose_encoding)),
            (
                "output head",
                match c.output_rank {
                    Some(_) => "a low-rank output head".to_owned(),
                    None => "a full-width output layer".to_owned(),
                },
            ),
        ]
    };
    let differing = describe(first)
        .into_iter()
        .zip(describe(other))
        .find(|((_, a), (_, b))| a != b);
    match differing {
        Some(((field, a), (_, b))) => Err(Error::InvalidConfig(format!(
            "cannot average these models: the {what} nets differ in {field} ({a} in the first \
             model, {b} in another); ensemble members must be trained with the same options \
             except --seed (and, if you like, the hidden sizes and rank)"
        ))),
        None => Ok(()),
    }
}

/// The mean of `nets`' de-normalised outputs, as one net whose output is normalised by
/// `shared`. Each item is a net and the normaliser of its output.
fn average_nets(
    nets: &[(&GarMatNet, &OutputNormalizer)],
    shared: &OutputNormalizer,
    what: &str,
    device: &Device,
) -> Result<GarMatNet> {
    let first = nets[0].0.config();
    for (net, _) in &nets[1..] {
        ensure_compatible(first, net.config(), what)?;
    }
    let k = nets.len() as f64;
    let sum = |f: fn(&GarMatNetConfig) -> usize| nets.iter().map(|(n, _)| f(n.config())).sum();
    let pose_hidden: usize = sum(|c| c.pose_hidden);
    let material_hidden: usize = sum(|c| c.material_hidden);
    let hidden: usize = sum(|c| c.hidden);
    let rank: Option<usize> = first
        .output_rank
        .map(|_| sum(|c| c.output_rank.unwrap_or(0)));
    let out_dim = first.output_dim();
    let pose_width = first.pose_encoding.width();

    // Member k's de-normalised output is (y ⊙ s_k + μ_k); in the shared normaliser (μ, s)
    // that is y ⊙ (s_k / s) + (μ_k − μ) / s. Each output column of member k is scaled by
    // s_k / s and by 1/K; the offsets sum into the shared bias or basis mean.
    let scale: Vec<Vec<f32>> = nets
        .iter()
        .map(|(_, norm)| {
            norm.std()
                .iter()
                .zip(shared.std())
                .map(|(s_k, s)| (s_k / s / k) as f32)
                .collect()
        })
        .collect();
    // The offsets of every member, summed in f64: the ensemble's basis mean or output bias.
    let mut offset = vec![0.0f64; out_dim];
    for (_, norm) in nets {
        for ((o, (m_k, m)), s) in offset
            .iter_mut()
            .zip(norm.mean().iter().zip(shared.mean()))
            .zip(shared.std())
        {
            *o += (m_k - m) / s / k;
        }
    }

    let mut pose_w = Assembly::zeros(pose_width, pose_hidden);
    let mut material_w = Assembly::zeros(first.material_dim, material_hidden);
    let mut merge_w = Assembly::zeros(pose_hidden + material_hidden, hidden);
    let out_cols = rank.unwrap_or(out_dim);
    let mut output_w = Assembly::zeros(hidden, out_cols);
    let mut basis = rank.map(|r| Assembly::zeros(r, out_dim));
    let (mut pose_b, mut material_b, mut merge_b, mut output_b) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut p_off, mut m_off, mut h_off, mut r_off) = (0, 0, 0, 0);
    for ((net, _), col_scale) in nets.iter().zip(&scale) {
        let c = net.config();
        let w = Dense::of(net.pose_in.weight.val());
        for r in 0..pose_width {
            pose_w.put_row(r, p_off, w.row(r));
        }
        pose_b.extend(bias_of(&net.pose_in));
        let w = Dense::of(net.material_in.weight.val());
        for r in 0..c.material_dim {
            material_w.put_row(r, m_off, w.row(r));
        }
        material_b.extend(bias_of(&net.material_in));
        let w = Dense::of(net.merge.weight.val());
        for r in 0..c.pose_hidden {
            merge_w.put_row(p_off + r, h_off, w.row(r));
        }
        for r in 0..c.material_hidden {
            merge_w.put_row(pose_hidden + m_off + r, h_off, w.row(c.pose_hidden + r));
        }
        merge_b.extend(bias_of(&net.merge));
        let w = Dense::of(net.output.weight.val());
        let b = bias_of(&net.output);
        // What the member adds to every output before its normaliser: the basis mean of a
        // low-rank head, the bias of a full-width one.
        let member_offset = match (&mut basis, &net.basis, &net.basis_mean) {
            (Some(stacked), Some(member_basis), Some(member_mean)) => {
                for r in 0..c.hidden {
                    output_w.put_row(h_off + r, r_off, w.row(r));
                }
                output_b.extend(b);
                let mb = Dense::of(member_basis.val());
                let r_k = member_basis.dims()[0];
                for r in 0..r_k {
                    stacked.put_scaled_row(r_off + r, 0, mb.row(r), col_scale);
                }
                r_off += r_k;
                to_f32(member_mean.val())
            }
            (None, None, None) => {
                for r in 0..c.hidden {
                    output_w.put_scaled_row(h_off + r, 0, w.row(r), col_scale);
                }
                b
            }
            _ => {
                return Err(Error::InvalidConfig(format!(
                    "the {what} net's output head does not match its configuration"
                )));
            }
        };
        for ((acc, v), s) in offset.iter_mut().zip(member_offset).zip(col_scale) {
            *acc += f64::from(v) * f64::from(*s);
        }
        p_off += c.pose_hidden;
        m_off += c.material_hidden;
        h_off += c.hidden;
    }
    let config = GarMatNetConfig {
        pose_hidden,
        material_hidden,
        hidden,
        output_rank: rank,
        ..first.clone()
    };
    config.validate()?;
    let combined_offset: Vec<f32> = offset.iter().map(|&v| v as f32).collect();
    let (output, basis, basis_mean) = match basis {
        Some(stacked) => (
            linear(output_w, output_b, device),
            Some(stacked.into_param(device)),
            Some(Param::from_tensor(vector(combined_offset, device))),
        ),
        None => (linear(output_w, combined_offset, device), None, None),
    };
    Ok(GarMatNet {
        pose_in: linear(pose_w, pose_b, device),
        material_in: linear(material_w, material_b, device),
        merge: linear(merge_w, merge_b, device),
        dropout: DropoutConfig::new(config.dropout).init(),
        output,
        basis,
        basis_mean,
        config,
    })
}

impl GarMatNetModel {
    /// Averages `members` into one model whose prediction is the mean of theirs (exactly, up
    /// to `f32` rounding): the module documentation says how.
    ///
    /// The members must be trained for the same template on the same dataset, with the same
    /// training fabrics, displacement frame, α, pose encoding and material projection; the
    /// hidden sizes and ranks may differ. The result's normalisers are the first member's,
    /// its provenance the first member's with every member's seed, command, epochs and
    /// losses listed under `extra.ensemble` (the caller may replace `command`).
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] for fewer than two members or members that disagree, naming
    /// what differs; anything [`GarMatNetModel::validate`] finds in a member.
    pub fn average(members: &[GarMatNetModel], device: &Device) -> Result<Self> {
        let [first, rest @ ..] = members else {
            return Err(Error::InvalidConfig(
                "an ensemble needs at least two models; got none".into(),
            ));
        };
        if rest.is_empty() {
            return Err(Error::InvalidConfig(
                "an ensemble needs at least two models; got one".into(),
            ));
        }
        for (i, m) in members.iter().enumerate() {
            m.validate()
                .map_err(|e| Error::InvalidConfig(format!("ensemble member {}: {e}", i + 1)))?;
        }
        for (i, m) in rest.iter().enumerate() {
            let differs = |what: &str| {
                Err(Error::InvalidConfig(format!(
                    "cannot average these models: member {} differs from the first in its \
                     {what}; ensemble members must be trained on the same dataset and \
                     fabrics, for the same template, with the same options except --seed",
                    i + 2
                )))
            };
            if m.meta.template != first.meta.template {
                return differs("garment template");
            }
            if m.meta.provenance.dataset_hash != first.meta.provenance.dataset_hash {
                return differs("training dataset");
            }
            if m.meta.provenance.material_range != first.meta.provenance.material_range
                || m.meta.provenance.training_fabrics != first.meta.provenance.training_fabrics
            {
                return differs("training fabrics");
            }
        }
        let fitting: Vec<_> = members
            .iter()
            .map(|m| (&m.fitting, &m.fitting_norm))
            .collect();
        let local: Vec<_> = members.iter().map(|m| (&m.local, &m.local_norm)).collect();
        let model = Self {
            fitting: average_nets(&fitting, &first.fitting_norm, "fitting", device)?,
            local: average_nets(&local, &first.local_norm, "local", device)?,
            fitting_norm: first.fitting_norm.clone(),
            local_norm: first.local_norm.clone(),
            meta: ModelMeta {
                template: first.meta.template.clone(),
                provenance: ensemble_provenance(members),
            },
        };
        model.validate()?;
        Ok(model)
    }
}

fn ensemble_provenance(members: &[GarMatNetModel]) -> TrainingProvenance {
    let first = &members[0].meta.provenance;
    let listed: Vec<serde_json::Value> = members
        .iter()
        .map(|m| {
            let p = &m.meta.provenance;
            serde_json::json!({
                "seed": p.seed,
                "command": p.command,
                "epochs": p.epochs,
                "losses": p.losses,
            })
        })
        .collect();
    TrainingProvenance {
        dataset_hash: first.dataset_hash.clone(),
        command: first.command.clone(),
        seed: first.seed,
        epochs: members
            .iter()
            .map(|m| m.meta.provenance.epochs)
            .max()
            .unwrap_or(0),
        losses: Default::default(),
        extra: serde_json::json!({ "ensemble": listed }),
        material_range: first.material_range,
        training_fabrics: first.training_fabrics.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{TEST_VERTICES, cpu, random_inputs, small_model};

    /// Every member's de-normalised output of both nets, for the same inputs.
    fn outputs(model: &GarMatNetModel, seed: u64, dev: &Device) -> [Vec<f64>; 2] {
        let (p, m) = random_inputs(7, seed, dev);
        let fit = to_f32(model.fitting.forward(p.clone(), m.clone()));
        let loc = to_f32(model.local.forward(p, m));
        [
            fit.chunks(3 * TEST_VERTICES)
                .flat_map(|c| model.fitting_norm.denormalize(c))
                .collect(),
            loc.chunks(3 * TEST_VERTICES)
                .flat_map(|c| model.local_norm.denormalize(c))
                .collect(),
        ]
    }

    fn assert_is_the_mean(members: &[GarMatNetModel], dev: &Device) {
        let merged = GarMatNetModel::average(members, dev).unwrap();
        let got = outputs(&merged, 11, dev);
        let each: Vec<_> = members.iter().map(|m| outputs(m, 11, dev)).collect();
        for net in 0..2 {
            let mut worst = 0.0f64;
            let mut spread = 0.0f64;
            for (i, g) in got[net].iter().enumerate() {
                let mean = each.iter().map(|o| o[net][i]).sum::<f64>() / each.len() as f64;
                worst = worst.max((g - mean).abs());
                spread = spread.max((each[0][net][i] - mean).abs());
            }
            // f32 sums over a few hundred terms: micrometres at most; the members themselves
            // differ by millimetres, so a wrong weighting could not pass.
            assert!(
                worst < 2e-6,
                "net {net}: off the members' mean by {worst} m"
            );
            assert!(
                spread > 1e-4,
                "net {net}: members too alike to test ({spread} m)"
            );
        }
    }

    #[test]
    fn an_ensemble_predicts_the_mean_of_its_members_low_rank() {
        let dev = cpu();
        let members: Vec<_> = (1..=3).map(|s| small_model(s, Some(12), &dev)).collect();
        assert_is_the_mean(&members, &dev);
    }

    #[test]
    fn an_ensemble_predicts_the_mean_of_its_members_full_width() {
        let dev = cpu();
        let members: Vec<_> = (1..=2).map(|s| small_model(s, None, &dev)).collect();
        assert_is_the_mean(&members, &dev);
    }

    #[test]
    fn members_of_different_widths_and_ranks_average_too() {
        let dev = cpu();
        let mut wide = small_model(5, Some(20), &dev);
        dev.seed(9);
        let cfg = GarMatNetConfig::new(TEST_VERTICES, 48, 8, 24).with_output_rank(Some(20));
        wide.fitting = cfg.init(&dev);
        let members = [small_model(4, Some(12), &dev), wide];
        assert_is_the_mean(&members, &dev);
        let merged = GarMatNetModel::average(&members, &dev).unwrap();
        let c = merged.fitting.config();
        assert_eq!(
            (c.pose_hidden, c.material_hidden, c.hidden, c.output_rank),
            (32 + 48, 16 + 8, 32 + 24, Some(32))
        );
    }

    #[test]
    fn the_ensemble_survives_a_save_and_load() {
        let dev = cpu();
        let members: Vec<_> = (1..=2).map(|s| small_model(s, Some(12), &dev)).collect();
        let merged = GarMatNetModel::average(&members, &dev).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("ensemble.safetensors");
        merged.save(&path).unwrap();
        let loaded = GarMatNetModel::load(&path, &dev).unwrap();
        assert_eq!(outputs(&loaded, 3, &dev), outputs(&merged, 3, &dev));
        let listed = &loaded.meta.provenance.extra["ensemble"];
        assert_eq!(listed.as_array().map(Vec::len), Some(2), "{listed}");
    }

    #[test]
    fn incompatible_members_are_refused_with_the_reason() {
        let dev = cpu();
        let a = small_model(1, Some(12), &dev);
        let err = |members: &[GarMatNetModel]| {
            GarMatNetModel::average(members, &dev)
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default()
        };
        assert!(err(&[]).contains("at least two"), "{}", err(&[]));
        assert!(err(std::slice::from_ref(&a)).contains("got one"));

        let mut other_alpha = small_model(2, Some(12), &dev);
        other_alpha.local.config.alpha = 0.3;
        assert!(err(&[a.clone(), other_alpha]).contains("alpha"));

        let full = small_model(2, None, &dev);
        assert!(err(&[a.clone(), full]).contains("output head"));

        let mut other_template = small_model(2, Some(12), &dev);
        other_template.meta.template.hash = "another".into();
        assert!(err(&[a.clone(), other_template]).contains("garment template"));

        let mut other_data = small_model(2, Some(12), &dev);
        other_data.meta.provenance.dataset_hash = "another".into();
        assert!(err(&[a.clone(), other_data]).contains("training dataset"));

        let mut other_fabrics = small_model(2, Some(12), &dev);
        other_fabrics.meta.provenance.training_fabrics = vec![crate::TrainingFabric {
            name: "Linen".into(),
            omega: [0.5; garmatnet_core::MATERIAL_DIM],
        }];
        assert!(err(&[a, other_fabrics]).contains("training fabrics"));
    }
}
