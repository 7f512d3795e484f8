//! Many characters per frame: batched, incremental prediction.
//!
//! [`Scene::update`] predicts only characters whose pose, material, detail or vertex subset
//! changed since the last update, in one batched forward pass per detail level; it reuses
//! the material branch's activation per material and, for characters that only need some
//! vertices (e.g. those visible or near a collider), computes only those output rows (and,
//! with mirror averaging, their twins' rows at the mirrored pose).
//! Outputs are pushed out of the posed body as [`Predictor::predict`]'s are (when the
//! predictor knows the body and push-out is on: [`Predictor::with_push_out`]).

use std::collections::{BTreeMap, HashMap};

use burn::prelude::*;
use garmatnet_core::{Pose, Real, Vec3};

use crate::error::{Error, Result};
use crate::net::garmatnet_net::{GarMatNet, MATERIAL_DIM, OutputHead};
use crate::net::output_normalizer::OutputNormalizer;
use crate::net::tensor_util::{matrix, to_f32};
use crate::predict::predictor::{Detail, Predictor, validate_inputs};

/// Material activations kept before the cache is cleared (bounds memory in long sessions).
const MATERIAL_CACHE_LIMIT: usize = 4096;

/// One character's inputs.
#[derive(Debug, Clone, PartialEq)]
pub struct Character {
    /// The body pose.
    pub pose: Pose,
    /// Normalised material coordinates ω ∈ [0, 1]⁶.
    pub material: [Real; MATERIAL_DIM],
    /// Which nets to run.
    pub detail: Detail,
    /// `Some(ids)`: compute only these template vertices (in this order); `None`: all.
    pub vertices: Option<Vec<usize>>,
}

impl Character {
    /// A character computing every vertex at full detail.
    #[must_use]
    pub fn new(pose: Pose, material: [Real; MATERIAL_DIM]) -> Self {
        Self {
            pose,
            material,
            detail: Detail::Full,
            vertices: None,
        }
    }
}

/// One character's latest prediction.
#[derive(Debug, Clone, PartialEq)]
pub struct CharacterOutput {
    /// Garment vertex positions (metres): all n, or the subset in its order.
    pub vertices: Vec<Vec3>,
    /// The template vertex ids of `vertices` when a subset was asked for.
    pub vertex_ids: Option<Vec<usize>>,
    /// The posed body points under those vertices, when the scene builds them.
    pub body_points: Option<Vec<Vec3>>,
}

/// What one [`Scene::update`] did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SceneUpdate {
    /// Characters predicted this frame, by id.
    pub recomputed: Vec<u64>,
    /// Characters skipped because nothing changed.
    pub skipped: usize,
    /// Characters whose material-branch activation was reused rather than computed.
    pub material_cache_hits: usize,
}

#[derive(Debug)]
struct Slot {
    character: Character,
    dirty: bool,
    /// Sliced output layers for the character's subset.
    heads: Option<SubsetHeads>,
    output: Option<CharacterOutput>,
}

/// The output layers (fitting, local) sliced to a character's vertex subset.
#[derive(Debug)]
struct SubsetHeads {
    /// For the subset itself.
    own: (OutputHead, OutputHead),
    /// With mirror averaging: for the subset's mirror twins, in the subset's order.
    twins: Option<(OutputHead, OutputHead)>,
}

/// A set of characters sharing one garment model.
#[derive(Debug, Default)]
pub struct Scene {
    slots: BTreeMap<u64, Slot>,
    build_body_points: bool,
    /// Material bits → (fitting, local) material-branch activations.
    material_cache: HashMap<[u64; MATERIAL_DIM], (Vec<f32>, Vec<f32>)>,
    /// The predictor the caches were built with.
    predictor_id: Option<u64>,
}

impl Scene {
    /// An empty scene that does not build body points.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Whether [`CharacterOutput::body_points`] is filled (off by default). Changing it on
    /// a scene already updated marks every character for the next update, so no output
    /// keeps the old setting.
    #[must_use]
    pub fn with_body_points(mut self, build: bool) -> Self {
        if self.build_body_points != build {
            self.build_body_points = build;
            for slot in self.slots.values_mut() {
                slot.dirty = true;
            }
        }
        self
    }

    /// Adds or replaces character `id`.
    ///
    /// # Errors
    /// [`Error::Core`] for a non-finite pose or a material outside [0, 1]⁶.
    pub fn insert(&mut self, id: u64, character: Character) -> Result<()> {
        validate_inputs(&character.pose, &character.material)?;
        self.slots.insert(
            id,
            Slot {
                character,
                dirty: true,
                heads: None,
                output: None,
            },
        );
        Ok(())
    }

    /// Removes character `id`, returning it.
    pub fn remove(&mut self, id: u64) -> Option<Character> {
        self.slots.remove(&id).map(|s| s.character)
    }

    /// Sets a character's pose; an identical pose keeps the cached result.
    ///
    /// # Errors
    /// [`Error::UnknownCharacter`]; [`Error::Core`] for a non-finite pose.
    pub fn set_pose(&mut self, id: u64, pose: Pose) -> Result<()> {
        let slot = self.slots.get_mut(&id).ok_or(Error::UnknownCharacter(id))?;
        validate_inputs(&pose, &slot.character.material)?;
        if slot.character.pose != pose {
            slot.character.pose = pose;
            slot.dirty = true;
        }
        Ok(())
    }

    /// Sets a character's material; an identical material keeps the cached result.
    ///
    /// # Errors
    /// [`Error::UnknownCharacter`]; [`Error::Core`] for a material outside [0, 1]⁶.
    pub fn set_material(&mut self, id: u64, material: [Real; MATERIAL_DIM]) -> Result<()> {
        let slot = self.slots.get_mut(&id).ok_or(Error::UnknownCharacter(id))?;
        validate_inputs(&slot.character.pose, &material)?;
        if slot.character.material != material {
            slot.character.material = material;
            slot.dirty = true;
        }
        Ok(())
    }

    /// Sets a character's detail level.
    ///
    /// # Errors
    /// [`Error::UnknownCharacter`].
    pub fn set_detail(&mut self, id: u64, detail: Detail) -> Result<()> {
        let slot = self.slots.get_mut(&id).ok_or(Error::UnknownCharacter(id))?;
        if slot.character.detail != detail {
            slot.character.detail = detail;
            slot.dirty = true;
        }
        Ok(())
    }

    /// Sets the vertex subset a character needs (`None`: all vertices).
    ///
    /// # Errors
    /// [`Error::UnknownCharacter`]. Out-of-range ids are reported by the next update.
    pub fn set_vertices(&mut self, id: u64, vertices: Option<Vec<usize>>) -> Result<()> {
        let slot = self.slots.get_mut(&id).ok_or(Error::UnknownCharacter(id))?;
        if slot.character.vertices != vertices {
            slot.character.vertices = vertices;
            slot.heads = None;
            slot.dirty = true;
        }
        Ok(())
    }

    /// Character `id`'s inputs.
    #[must_use]
    pub fn character(&self, id: u64) -> Option<&Character> {
        self.slots.get(&id).map(|s| &s.character)
    }

    /// Character `id`'s latest prediction (`None` before its first update).
    #[must_use]
    pub fn output(&self, id: u64) -> Option<&CharacterOutput> {
        self.slots.get(&id).and_then(|s| s.output.as_ref())
    }

    /// Predicts every changed character with `predictor`.
    ///
    /// # Errors
    /// [`Error::Core`] for a subset vertex id past the template;
    /// [`Error::NonFiniteOutput`] if a prediction is not finite (that character keeps its
    /// previous output and stays marked for recomputation).
    pub fn update(&mut self, predictor: &Predictor) -> Result<SceneUpdate> {
        if self.predictor_id != Some(predictor.id()) {
            // Caches and outputs belong to the previous model.
            self.material_cache.clear();
            for slot in self.slots.values_mut() {
                slot.heads = None;
                slot.dirty = true;
            }
            self.predictor_id = Some(predictor.id());
        }
        if self.material_cache.len() > MATERIAL_CACHE_LIMIT {
            self.material_cache.clear();
        }
        let mut report = SceneUpdate {
            skipped: self.slots.values().filter(|s| !s.dirty).count(),
            ..SceneUpdate::default()
        };
        for detail in [Detail::Smooth, Detail::Full] {
            let ids: Vec<u64> = self
                .slots
                .iter()
                .filter(|(_, s)| s.dirty && s.character.detail == detail)
                .map(|(&id, _)| id)
                .collect();
            if !ids.is_empty() {
                report.material_cache_hits += self.update_group(predictor, &ids, detail)?;
                report.recomputed.extend(ids);
            }
        }
        report.recomputed.sort_unstable();
        Ok(report)
    }

    /// One batched pass over the characters `ids` (all at `detail`); returns cache hits.
    fn update_group(
        &mut self,
        predictor: &Predictor,
        ids: &[u64],
        detail: Detail,
    ) -> Result<usize> {
        let model = predictor.model();
        let device = predictor.device().clone();
        let twins = predictor.averaging_twins();
        let heads_of = |v: &[usize]| -> Result<(OutputHead, OutputHead)> {
            Ok((
                model.fitting.output_head(Some(v))?,
                model.local.output_head(Some(v))?,
            ))
        };
        for &id in ids {
            let slot = self.slots.get_mut(&id).ok_or(Error::UnknownCharacter(id))?;
            if slot.heads.is_none()
                && let Some(v) = &slot.character.vertices
            {
                // A vertex past the template is refused by `output_head` before its twin
                // is looked up.
                let own = heads_of(v)?;
                let twins = match twins {
                    Some(t) => Some(heads_of(
                        &v.iter().map(|&i| t[i] as usize).collect::<Vec<_>>(),
                    )?),
                    None => None,
                };
                slot.heads = Some(SubsetHeads { own, twins });
            }
        }
        let hits = self.fill_material_cache(predictor, ids)?;
        let characters: Vec<&Character> = ids.iter().map(|id| &self.slots[id].character).collect();
        let b = characters.len();
        // With mirror averaging, rows b..2b are the mirrored poses.
        let poses: Vec<&Pose> = characters.iter().map(|c| &c.pose).collect();
        let mirrored = predictor.mirrored_poses(&poses);
        let rows: Vec<_> = characters
            .iter()
            .map(|c| (&c.pose, &c.material))
            .chain(mirrored.iter().zip(characters.iter().map(|c| &c.material)))
            .collect();
        let (pose_t, _) = predictor.input_tensors(rows.into_iter());
        let keys: Vec<_> = characters
            .iter()
            .map(|c| material_key(&c.material))
            .chain(
                mirrored
                    .iter()
                    .zip(&characters)
                    .map(|(_, c)| material_key(&c.material)),
            )
            .collect();

        let mut nets: Vec<(&GarMatNet, &OutputNormalizer, bool)> =
            vec![(&model.fitting, &model.fitting_norm, true)];
        if detail == Detail::Full {
            nets.push((&model.local, &model.local_norm, false));
        }
        // Per net, per row (the characters, then their mirrored poses): denormalised
        // displacements (subset order; a mirrored row's for the subset's twins).
        let mut displacements: Vec<Vec<Vec<Real>>> = Vec::new();
        for (net, norm, is_fitting) in nets {
            let width = net.config().material_hidden;
            let feats: Vec<f32> = keys
                .iter()
                .flat_map(|k| {
                    let (f, l) = &self.material_cache[k];
                    if is_fitting { f.clone() } else { l.clone() }
                })
                .collect();
            let material_features = matrix(feats, keys.len(), width, &device);
            let hidden = net.hidden(net.pose_features(pose_t.clone()), material_features);
            let mut per_row = vec![Vec::new(); keys.len()];
            let full_rows: Vec<usize> = (0..keys.len())
                .filter(|&r| characters[r % b].vertices.is_none())
                .collect();
            if !full_rows.is_empty() {
                let out = to_f32(net.forward_all(select_rows(&hidden, &full_rows, &device)));
                let n3 = 3 * net.vertex_count();
                for (k, &r) in full_rows.iter().enumerate() {
                    per_row[r] = norm.denormalize(&out[k * n3..(k + 1) * n3]);
                }
            }
            for r in (0..keys.len()).filter(|&r| characters[r % b].vertices.is_some()) {
                let heads = self.slots[&ids[r % b]]
                    .heads
                    .as_ref()
                    .expect("heads were built above");
                let (fit_head, loc_head) = if r < b {
                    &heads.own
                } else {
                    heads.twins.as_ref().expect("twin heads were built above")
                };
                let head = if is_fitting { fit_head } else { loc_head };
                let out = to_f32(net.forward_head(select_rows(&hidden, &[r], &device), head));
                per_row[r] = norm.denormalize_vertices(&out, head.vertices().unwrap_or(&[]));
            }
            displacements.push(per_row);
        }

        let mut outputs = Vec::with_capacity(ids.len());
        for (r, c) in characters.iter().enumerate() {
            let local = displacements.get(1).map(|d| d[r].as_slice());
            let subset = c.vertices.as_deref();
            let what = format!("character {}", ids[r]);
            // A mirrored row holds the subset's twins, in the subset's order.
            let other = (!mirrored.is_empty()).then(|| {
                (
                    displacements[0][b + r].as_slice(),
                    displacements.get(1).map(|d| d[b + r].as_slice()),
                )
            });
            let mut vertices =
                predictor.assemble(&c.pose, (&displacements[0][r], local), other, subset, &what)?;
            // Each vertex is pushed out on its own, so a subset gets what the full
            // prediction gives those vertices.
            predictor.push_out_vertices(&mut vertices, &c.pose);
            let body_points = self.build_body_points.then(|| {
                let all = predictor.body_points(&c.pose);
                match subset {
                    Some(s) => s.iter().map(|&v| all[v]).collect(),
                    None => all,
                }
            });
            outputs.push(CharacterOutput {
                vertices,
                vertex_ids: c.vertices.clone(),
                body_points,
            });
        }
        for (id, output) in ids.iter().zip(outputs) {
            let slot = self.slots.get_mut(id).ok_or(Error::UnknownCharacter(*id))?;
            slot.output = Some(output);
            slot.dirty = false;
        }
        Ok(hits)
    }

    /// Computes the material activations of `ids` missing from the cache in one pass;
    /// returns how many characters reused one (already cached or shared within the batch).
    fn fill_material_cache(&mut self, predictor: &Predictor, ids: &[u64]) -> Result<usize> {
        let mut missing: Vec<[Real; MATERIAL_DIM]> = Vec::new();
        let mut hits = 0;
        for id in ids {
            let m = self.slots[id].character.material;
            let key = material_key(&m);
            if self.material_cache.contains_key(&key)
                || missing.iter().any(|x| material_key(x) == key)
            {
                hits += 1;
            } else {
                missing.push(m);
            }
        }
        if missing.is_empty() {
            return Ok(hits);
        }
        let model = predictor.model();
        let values: Vec<f32> = missing.iter().flat_map(|m| m.map(|v| v as f32)).collect();
        let material_t = matrix(values, missing.len(), MATERIAL_DIM, predictor.device());
        let fit = to_f32(model.fitting.material_features(material_t.clone()));
        let loc = to_f32(model.local.material_features(material_t));
        let (wf, wl) = (
            model.fitting.config().material_hidden,
            model.local.config().material_hidden,
        );
        for (i, m) in missing.iter().enumerate() {
            let entry = (
                fit[i * wf..(i + 1) * wf].to_vec(),
                loc[i * wl..(i + 1) * wl].to_vec(),
            );
            self.material_cache.insert(material_key(m), entry);
        }
        Ok(hits)
    }
}

/// Exact identity of a material (the cache must not merge nearby materials).
fn material_key(m: &[Real; MATERIAL_DIM]) -> [u64; MATERIAL_DIM] {
    m.map(f64::to_bits)
}

fn select_rows(t: &Tensor<2>, rows: &[usize], device: &Device) -> Tensor<2> {
    let idx: Vec<i64> = rows.iter().map(|&r| r as i64).collect();
    let n = idx.len();
    t.clone().select(
        0,
        Tensor::<1, Int>::from_data(TensorData::new(idx, [n]), device),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{cpu, small_model, test_predictor, test_twins};
    use approx::assert_relative_eq;
    use garmatnet_core::{JointLimits, SplitMix64};

    fn predictor(rank: Option<usize>) -> Predictor {
        let dev = cpu();
        let model = small_model(21, rank, &dev);
        test_predictor(model, &dev)
    }

    fn assert_same(a: &[Vec3], b: &[Vec3]) {
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(b) {
            assert_relative_eq!(x, y, epsilon = 1e-5);
        }
    }

    #[test]
    fn every_shortcut_matches_the_full_prediction() {
        // With mirror averaging too: a subset then runs its twins' rows at the mirrored pose.
        for (rank, mirror) in [
            (None, false),
            (Some(6), false),
            (None, true),
            (Some(6), true),
        ] {
            let p = if mirror {
                predictor(rank).with_mirror_twins(&test_twins()).unwrap()
            } else {
                predictor(rank)
            };
            assert_eq!(p.mirror_averaging(), mirror);
            let mut rng = SplitMix64::new(5);
            let limits = JointLimits::default();
            let shared_material = [0.2, 0.4, 0.6, 0.8, 0.1, 0.9];
            let mut scene = Scene::new().with_body_points(true);
            let subset = vec![3usize, 17, 42, 0];
            for id in 0..4u64 {
                let mut c = Character::new(limits.sample(&mut rng, 1.0), shared_material);
                c.detail = if id % 2 == 0 {
                    Detail::Full
                } else {
                    Detail::Smooth
                };
                if id == 3 {
                    c.vertices = Some(subset.clone());
                }
                scene.insert(id, c).unwrap();
            }
            let check = |scene: &Scene| {
                for id in 0..4u64 {
                    let c = scene.character(id).unwrap();
                    let full = p
                        .predict_normalized(&c.pose, &c.material, c.detail)
                        .unwrap();
                    let out = scene.output(id).unwrap();
                    let expected: Vec<Vec3> = match &c.vertices {
                        Some(s) => s.iter().map(|&v| full.vertices[v]).collect(),
                        None => full.vertices.clone(),
                    };
                    assert_same(&out.vertices, &expected);
                    assert_eq!(out.body_points.as_ref().unwrap().len(), expected.len());
                }
            };
            let first = scene.update(&p).unwrap();
            assert_eq!(first.recomputed, vec![0, 1, 2, 3]);
            assert_eq!(
                first.material_cache_hits, 3,
                "one material, computed once for four"
            );
            check(&scene);

            // Nothing changed: everything is skipped and the outputs stay.
            let before = scene.output(2).unwrap().clone();
            scene
                .set_pose(2, scene.character(2).unwrap().pose.clone())
                .unwrap();
            let second = scene.update(&p).unwrap();
            assert!(second.recomputed.is_empty());
            assert_eq!(second.skipped, 4);
            assert_eq!(scene.output(2).unwrap(), &before);

            // A new pose for one character: only it is recomputed, from the cached material.
            scene.set_pose(2, limits.sample(&mut rng, 1.0)).unwrap();
            scene.set_pose(3, limits.sample(&mut rng, 1.0)).unwrap();
            let third = scene.update(&p).unwrap();
            assert_eq!(third.recomputed, vec![2, 3]);
            assert_eq!(third.skipped, 2);
            assert_eq!(third.material_cache_hits, 2);
            check(&scene);

            // A new material and detail.
            scene.set_material(1, [0.5; 6]).unwrap();
            scene.set_detail(3, Detail::Full).unwrap();
            scene.set_vertices(0, Some(vec![49, 1])).unwrap();
            assert_eq!(scene.update(&p).unwrap().recomputed, vec![0, 1, 3]);
            check(&scene);
        }
    }

    #[test]
    fn outputs_are_pushed_out_of_the_body_as_predictions_are() {
        let mut p = predictor(None);
        let body = garmatnet_core::CapsuleBody::smpl_neutral();
        p.set_test_body(body.clone());
        let mut rng = SplitMix64::new(8);
        let limits = JointLimits::default();
        let mut scene = Scene::new();
        let subset = vec![5usize, 0, 33];
        for id in 0..3u64 {
            let mut c =
                Character::new(limits.sample(&mut rng, 1.0), [0.3, 0.5, 0.2, 0.7, 0.6, 0.4]);
            if id == 1 {
                c.detail = Detail::Smooth;
            }
            if id == 2 {
                c.vertices = Some(subset.clone());
            }
            scene.insert(id, c).unwrap();
        }
        scene.update(&p).unwrap();
        let mut pushed = 0;
        for id in 0..3u64 {
            let c = scene.character(id).unwrap();
            let (full, _) = p
                .predict_on_body(&c.pose, &c.material, c.detail, &body.pose(&c.pose))
                .unwrap();
            let raw = p
                .predict_normalized(&c.pose, &c.material, c.detail)
                .unwrap();
            let pick = |v: &[Vec3]| -> Vec<Vec3> {
                match &c.vertices {
                    Some(s) => s.iter().map(|&i| v[i]).collect(),
                    None => v.to_vec(),
                }
            };
            let out = &scene.output(id).unwrap().vertices;
            assert_same(out, &pick(&full.vertices));
            pushed += usize::from(pick(&raw.vertices) != *out);
        }
        assert!(
            pushed > 0,
            "no character had a vertex inside the body to push out"
        );

        // Push-out turned off: every character is recomputed, none keeps a pushed output.
        let off = p
            .with_push_out(crate::PushOut {
                enabled: false,
                ..crate::PushOut::default()
            })
            .unwrap();
        assert_eq!(scene.update(&off).unwrap().recomputed, vec![0, 1, 2]);
        for id in 0..3u64 {
            let c = scene.character(id).unwrap();
            let raw = off
                .predict_normalized(&c.pose, &c.material, c.detail)
                .unwrap();
            let expected: Vec<Vec3> = match &c.vertices {
                Some(s) => s.iter().map(|&i| raw.vertices[i]).collect(),
                None => raw.vertices.clone(),
            };
            assert_same(&scene.output(id).unwrap().vertices, &expected);
        }
    }

    #[test]
    fn turning_body_points_on_refreshes_every_output() {
        let p = predictor(None);
        let mut scene = Scene::new();
        for id in 0..2u64 {
            scene
                .insert(id, Character::new(Pose::zero(), [0.5; 6]))
                .unwrap();
        }
        scene.update(&p).unwrap();
        assert!(scene.output(0).unwrap().body_points.is_none());
        let mut scene = scene.with_body_points(true);
        scene.set_pose(1, Pose::zero()).unwrap();
        assert_eq!(scene.update(&p).unwrap().recomputed, vec![0, 1]);
        for id in 0..2u64 {
            let out = scene.output(id).unwrap();
            assert_eq!(
                out.body_points.as_ref().map(Vec::len),
                Some(out.vertices.len())
            );
        }
        // Setting it to what it is marks nothing.
        let mut scene = scene.with_body_points(true);
        assert!(scene.update(&p).unwrap().recomputed.is_empty());
    }

    #[test]
    fn bad_inputs_and_ids_are_refused() {
        let p = predictor(None);
        let mut scene = Scene::new();
        assert!(
            scene
                .insert(1, Character::new(Pose::zero(), [2.0; 6]))
                .is_err()
        );
        assert!(matches!(
            scene.set_pose(9, Pose::zero()),
            Err(Error::UnknownCharacter(9))
        ));
        let mut c = Character::new(Pose::zero(), [0.5; 6]);
        c.vertices = Some(vec![50]);
        scene.insert(1, c).unwrap();
        assert!(scene.update(&p).is_err());
        scene.set_vertices(1, None).unwrap();
        scene.update(&p).unwrap();
        assert!(scene.output(1).unwrap().body_points.is_none());
        // A different predictor invalidates every cached result.
        let q = predictor(None);
        assert_eq!(scene.update(&q).unwrap().recomputed, vec![1]);
    }
}
