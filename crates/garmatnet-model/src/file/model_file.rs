//! A trained GarMatNet model and its self-describing, versioned `.safetensors` file.
//!
//! # File layout (format version 1)
//! A standard safetensors file (loadable by `safetensors.numpy.load_file` or PyTorch):
//! - tensors, for `net` in `fitting`, `local` (f32, Burn's `[in, out]` weight layout — the
//!   transpose of `torch.nn.Linear.weight`):
//!   `{net}.pose_in.weight [w, pose_hidden]` (w = 72, or 216 with the rotation-matrix pose
//!   encoding), `{net}.pose_in.bias [pose_hidden]`,
//!   `{net}.material_in.weight [6, material_hidden]`, `{net}.material_in.bias`,
//!   `{net}.merge.weight [pose_hidden + material_hidden, hidden]`, `{net}.merge.bias`,
//!   `{net}.output.weight [hidden, 3n or k]`, `{net}.output.bias`, and with a low-rank
//!   output `{net}.basis [k, 3n]`, `{net}.basis_mean [3n]`;
//!   normalisers (f64): `{net}_norm.mean [3n]`, `{net}_norm.std [3n]`.
//! - `__metadata__`: `format = "garmatnet-model"`, `garmatnet` = a JSON document (format
//!   version, both nets' configs, displacement frame, template hash / resolution / vertex
//!   count, training provenance) and `garmatnet_checksum` = FNV-1a 64 (hex) over the document
//!   and every tensor's name, dtype, shape and bytes, so any changed byte is detected.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use burn::prelude::*;
use garmatnet_core::{DisplacementFrame, TemplateInfo};
use safetensors::{SafeTensors, tensor::TensorView};
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::net::garmatnet_net::{GarMatNet, GarMatNetConfig};
use crate::net::model_tensors::{
    Stored, TensorSource, checksum, net_from_tensors, net_tensors, norm_tensors, write_atomic,
};
use crate::net::output_normalizer::OutputNormalizer;
use crate::predict::material_range::{MaterialRange, TrainingFabric};

/// The model file format version this build writes and reads.
pub const FORMAT_VERSION: u32 = 1;

/// The `format` value in every model file's metadata.
pub const FORMAT_NAME: &str = "garmatnet-model";

/// How a model was trained: free-form, for reproducibility. Every field is optional in files.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct TrainingProvenance {
    /// Hash of the training data set.
    pub dataset_hash: String,
    /// The command line that trained the model.
    pub command: String,
    /// The random seed.
    pub seed: u64,
    /// Epochs trained (the longer of the two nets under early stopping).
    pub epochs: usize,
    /// Named final losses, e.g. `"fitting_val_mse"` (units as the trainer names them).
    pub losses: BTreeMap<String, f64>,
    /// Anything else the trainer wants to keep.
    pub extra: serde_json::Value,
    /// The normalised materials the nets were trained on, as a per-component box (absent in
    /// files written before it was recorded). [`crate::Predictor::material_range`] gives it
    /// to callers, so they can tell a prediction inside what the model learned from an
    /// extrapolation.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub material_range: Option<MaterialRange>,
    /// The fabrics the nets were trained on, in the dataset's order (empty in files written
    /// before they were recorded).
    /// [`crate::Predictor::nearest_training_fabric`] finds the one nearest a material: the
    /// farther it lies, the larger the error to expect.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub training_fabrics: Vec<TrainingFabric>,
}

impl TrainingProvenance {
    /// The key of [`TrainingProvenance::extra`] under which the trainer records the
    /// fingerprint of the split the model was trained with.
    pub const SPLIT_FINGERPRINT_KEY: &'static str = "split_fingerprint";

    /// The fingerprint of the split the model was trained with (`garmatnet-train`'s
    /// `Split::fingerprint`), kept in [`TrainingProvenance::extra`] so that files of every
    /// version share one layout (`garmatnet ensemble` records its members'); `None` for
    /// models written before it was recorded. Readers of the split file next to a model
    /// compare it with the file's, so a model is never evaluated on another run's split.
    #[must_use]
    pub fn split_fingerprint(&self) -> Option<&str> {
        self.extra
            .get(Self::SPLIT_FINGERPRINT_KEY)
            .and_then(serde_json::Value::as_str)
    }

    /// Checks that every recorded number survives JSON (a NaN or infinite loss would be
    /// written as `null`, and the file could then not be read back) and that a recorded
    /// split fingerprint is a string.
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] naming the loss or the fingerprint.
    pub fn validate(&self) -> Result<()> {
        if let Some((name, value)) = self.losses.iter().find(|(_, v)| !v.is_finite()) {
            return Err(Error::InvalidConfig(format!(
                "the recorded loss `{name}` is {value}; only finite numbers can be stored (a \
                 model file with it would not load). Train at least one epoch per net, or \
                 leave the loss out of the provenance"
            )));
        }
        // Present but not a string would read as "no fingerprint" and skip the split check.
        if self
            .extra
            .get(Self::SPLIT_FINGERPRINT_KEY)
            .is_some_and(|v| !v.is_string())
        {
            return Err(Error::InvalidConfig(format!(
                "the recorded `{}` must be the split's fingerprint, a string; the file was \
                 edited: re-train the model or restore the file",
                Self::SPLIT_FINGERPRINT_KEY
            )));
        }
        Ok(())
    }
}

/// Everything about a model that is not a weight.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelMeta {
    /// The garment template the model predicts.
    pub template: TemplateInfo,
    /// How it was trained.
    pub provenance: TrainingProvenance,
}

/// A trained GarMatNet: the generally-fitting and locally-detailed networks, their output
/// normalisers and the model's metadata.
#[derive(Debug, Clone)]
pub struct GarMatNetModel {
    /// Predicts the normalised displacement from the body to the smoothed garment.
    pub fitting: GarMatNet,
    /// Predicts the normalised displacement from the smoothed to the full garment.
    pub local: GarMatNet,
    /// De-normalises the fitting net's output (metres).
    pub fitting_norm: OutputNormalizer,
    /// De-normalises the local net's output (metres).
    pub local_norm: OutputNormalizer,
    /// Template, provenance.
    pub meta: ModelMeta,
}

/// The JSON document in the file's `__metadata__["garmatnet"]`.
#[derive(Serialize, Deserialize)]
struct Header {
    format: String,
    format_version: u32,
    displacement_frame: DisplacementFrame,
    fitting: GarMatNetConfig,
    local: GarMatNetConfig,
    template: TemplateInfo,
    provenance: TrainingProvenance,
}

/// Net options added after format version 1, with the value files that predate them meant.
fn optional_net_fields() -> [(&'static str, serde_json::Value); 2] {
    [
        ("scale_free_material", serde_json::Value::Bool(false)),
        (
            "pose_encoding",
            serde_json::Value::String("axis_angle".into()),
        ),
    ]
}

/// The model document with every [`optional_net_fields`] entry a net config lacks filled in
/// (Burn's `Config` derive requires every field, so older files would not parse otherwise).
fn with_optional_net_fields(mut document: serde_json::Value) -> serde_json::Value {
    for net in ["fitting", "local"] {
        if let Some(config) = document
            .get_mut(net)
            .and_then(serde_json::Value::as_object_mut)
        {
            for (field, value) in optional_net_fields() {
                config.entry(field).or_insert(value);
            }
        }
    }
    document
}

impl GarMatNetModel {
    /// A fresh, untrained model for `template`: both nets built from `config` on `device`
    /// (seed the device first for reproducible weights), identity normalisers.
    ///
    /// # Panics
    /// If `config` is invalid or its vertex count differs from the template's (see
    /// [`GarMatNetConfig::validate`]).
    #[must_use]
    pub fn untrained(config: &GarMatNetConfig, template: TemplateInfo, device: &Device) -> Self {
        assert_eq!(
            config.vertex_count, template.vertex_count,
            "config and template disagree"
        );
        let dim = 3 * template.vertex_count;
        Self {
            fitting: config.init(device),
            local: config.init(device),
            fitting_norm: OutputNormalizer::identity(dim),
            local_norm: OutputNormalizer::identity(dim),
            meta: ModelMeta {
                template,
                provenance: TrainingProvenance::default(),
            },
        }
    }

    /// The frame the nets' displacements are expressed in.
    #[must_use]
    pub fn displacement_frame(&self) -> DisplacementFrame {
        self.fitting.config().displacement_frame
    }

    /// The garment vertex count n.
    #[must_use]
    pub fn vertex_count(&self) -> usize {
        self.meta.template.vertex_count
    }

    /// Checks that the nets, normalisers and template agree with each other, and that the
    /// provenance can be written ([`TrainingProvenance::validate`]).
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] naming what disagrees.
    pub fn validate(&self) -> Result<()> {
        let n = self.meta.template.vertex_count;
        for (name, net, norm) in [
            ("fitting", &self.fitting, &self.fitting_norm),
            ("local", &self.local, &self.local_norm),
        ] {
            net.config().validate()?;
            if net.vertex_count() != n || norm.dim() != 3 * n {
                return Err(Error::InvalidConfig(format!(
                    "the {name} net has {} vertices and its normaliser {} values, but the \
                     template has {n} vertices ({} values)",
                    net.vertex_count(),
                    norm.dim(),
                    3 * n
                )));
            }
        }
        self.meta.provenance.validate()?;
        if let Some(range) = &self.meta.provenance.material_range
            && !range.is_valid()
        {
            return Err(Error::InvalidConfig(format!(
                "the recorded training material range is not a box of finite values with \
                 min <= max: {range:?}; re-train the model or remove the field"
            )));
        }
        let fabrics = &self.meta.provenance.training_fabrics;
        for (i, fabric) in fabrics.iter().enumerate() {
            if fabrics[..i].iter().any(|other| other.name == fabric.name) {
                return Err(Error::InvalidConfig(format!(
                    "the recorded training fabric {:?} is listed twice; re-train the model or \
                     remove the field",
                    fabric.name
                )));
            }
            let outside = self
                .meta
                .provenance
                .material_range
                .as_ref()
                .is_some_and(|range| !range.outside(&fabric.omega).is_empty());
            if fabric.name.trim().is_empty()
                || !fabric.omega.iter().all(|v| (0.0..=1.0).contains(v))
                || outside
            {
                return Err(Error::InvalidConfig(format!(
                    "the recorded training fabric {:?} needs a name and a normalised ω in \
                     [0, 1] inside the recorded training range: {:?}; re-train the model or \
                     remove the field",
                    fabric.name, fabric.omega
                )));
            }
        }
        if self.fitting.config().displacement_frame != self.local.config().displacement_frame {
            return Err(Error::InvalidConfig(
                "the fitting and local nets must use the same displacement frame".into(),
            ));
        }
        Ok(())
    }

    /// A fingerprint of everything that sets the model's predictions: both nets'
    /// configurations and weights and their output normalisers (FNV-1a 64 in hex, as the
    /// file's checksum, but not over the provenance, so re-saving a model or editing its
    /// training notes keeps it). Two models trained with different seeds differ here even
    /// when template and training fabrics agree. It reads every weight, so callers that
    /// need it often keep it ([`crate::Predictor::model_fingerprint`]).
    #[must_use]
    pub fn weights_fingerprint(&self) -> String {
        // The configurations' JSON stands for the document the file checksum covers.
        let document = serde_json::to_string(&(self.fitting.config(), self.local.config()))
            .unwrap_or_default();
        format!(
            "{:016x}",
            stored_checksum(&document, &self.stored_tensors())
        )
    }

    /// Every tensor a model file stores (both nets' weights, both normalisers), by name.
    fn stored_tensors(&self) -> Vec<Stored> {
        let mut tensors = net_tensors("fitting", &self.fitting);
        tensors.extend(net_tensors("local", &self.local));
        tensors.extend(norm_tensors("fitting_norm", &self.fitting_norm));
        tensors.extend(norm_tensors("local_norm", &self.local_norm));
        tensors.sort_by(|a, b| a.name.cmp(&b.name));
        tensors
    }

    /// Refuses a model trained for another garment template.
    ///
    /// # Errors
    /// [`Error::TemplateMismatch`] if `hash` or `vertex_count` differ from the model's.
    pub fn ensure_template(&self, hash: &str, vertex_count: usize) -> Result<()> {
        let t = &self.meta.template;
        if t.hash != hash || t.vertex_count != vertex_count {
            return Err(Error::TemplateMismatch {
                model_hash: t.hash.clone(),
                model_vertices: t.vertex_count,
                garment_hash: hash.to_owned(),
                garment_vertices: vertex_count,
            });
        }
        Ok(())
    }

    /// Writes the model to `path` atomically (a temporary file in the same directory,
    /// renamed over `path` once complete).
    ///
    /// # Errors
    /// [`Error::InvalidConfig`] if the model is inconsistent or its provenance holds a
    /// number JSON cannot store (NaN, infinity); nothing is written then. [`Error::Io`] if
    /// the file cannot be written.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        self.validate()?;
        let header = Header {
            format: FORMAT_NAME.into(),
            format_version: FORMAT_VERSION,
            displacement_frame: self.displacement_frame(),
            fitting: self.fitting.config().clone(),
            local: self.local.config().clone(),
            template: self.meta.template.clone(),
            provenance: self.meta.provenance.clone(),
        };
        let document = serde_json::to_string(&header)
            .map_err(|e| Error::InvalidConfig(format!("cannot serialise the model header: {e}")))?;
        let tensors = self.stored_tensors();
        let checksum = stored_checksum(&document, &tensors);
        let metadata = HashMap::from([
            ("format".to_owned(), FORMAT_NAME.to_owned()),
            ("garmatnet".to_owned(), document),
            ("garmatnet_checksum".to_owned(), format!("{checksum:016x}")),
        ]);
        let views = tensors.iter().map(|t| {
            let view = TensorView::new(t.dtype, t.shape.clone(), &t.bytes)
                .unwrap_or_else(|e| panic!("tensor {} has inconsistent bytes: {e}", t.name));
            (t.name.clone(), view)
        });
        let bytes = safetensors::serialize(views, Some(metadata))
            .map_err(|e| Error::InvalidConfig(format!("cannot encode the model: {e}")))?;
        write_atomic(path, &bytes)
    }

    /// Reads and fully validates a model file: format and version, checksum, tensor shapes
    /// against the stored configs, finiteness of every weight.
    ///
    /// # Errors
    /// [`Error::Io`] if the file cannot be read; [`Error::UnsupportedVersion`] for another
    /// format version; [`Error::Corrupt`] for anything damaged or inconsistent.
    pub fn load(path: impl AsRef<Path>, device: &Device) -> Result<Self> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|source| Error::Io {
            path: path.to_owned(),
            source,
        })?;
        let corrupt = |message: String| Error::Corrupt {
            path: path.to_owned(),
            message,
        };
        let file = SafeTensors::deserialize(&bytes)
            .map_err(|e| corrupt(format!("not a readable safetensors file ({e})")))?;
        let (_, raw_meta) = SafeTensors::read_metadata(&bytes)
            .map_err(|e| corrupt(format!("unreadable header ({e})")))?;
        let meta = raw_meta
            .metadata()
            .as_ref()
            .ok_or_else(|| corrupt("no __metadata__".into()))?;
        if meta.get("format").map(String::as_str) != Some(FORMAT_NAME) {
            return Err(corrupt(format!("metadata `format` is not `{FORMAT_NAME}`")));
        }
        let document = meta
            .get("garmatnet")
            .ok_or_else(|| corrupt("no `garmatnet` metadata".into()))?;
        let value: serde_json::Value = serde_json::from_str(document)
            .map_err(|e| corrupt(format!("the model document is not JSON ({e})")))?;
        let version = value
            .get("format_version")
            .and_then(serde_json::Value::as_u64);
        match version {
            Some(v) if v == u64::from(FORMAT_VERSION) => {}
            Some(v) => {
                return Err(Error::UnsupportedVersion {
                    path: path.to_owned(),
                    found: u32::try_from(v).unwrap_or(u32::MAX),
                    supported: FORMAT_VERSION,
                });
            }
            None => return Err(corrupt("the model document has no format_version".into())),
        }
        let mut views: Vec<(String, TensorView<'_>)> = file.tensors();
        views.sort_by(|a, b| a.0.cmp(&b.0));
        let expected = meta
            .get("garmatnet_checksum")
            .ok_or_else(|| corrupt("no checksum".into()))?;
        let actual = checksum(
            document,
            views
                .iter()
                .map(|(n, v)| (&**n, v.dtype(), v.shape(), v.data())),
        );
        if *expected != format!("{actual:016x}") {
            return Err(corrupt(format!(
                "checksum mismatch (stored {expected}, computed {actual:016x}): bytes were changed"
            )));
        }
        let header: Header = serde_json::from_value(with_optional_net_fields(value))
            .map_err(|e| corrupt(format!("the model document is malformed ({e})")))?;
        if header.format != FORMAT_NAME {
            return Err(corrupt(format!("document format is not `{FORMAT_NAME}`")));
        }
        let mut tensors = TensorSource {
            views: views.into_iter().collect(),
            path,
        };
        let mut load_net = |prefix: &str, mut config: GarMatNetConfig| -> Result<GarMatNet> {
            if config.displacement_frame != header.displacement_frame {
                return Err(corrupt(format!(
                    "the {prefix} net's displacement frame disagrees"
                )));
            }
            config.displacement_frame = header.displacement_frame;
            config
                .validate()
                .map_err(|e| corrupt(format!("the {prefix} net: {e}")))?;
            net_from_tensors(prefix, config, &mut tensors, device)
        };
        let fitting = load_net("fitting", header.fitting)?;
        let local = load_net("local", header.local)?;
        let n3 = 3 * header.template.vertex_count;
        let mut load_norm = |prefix: &str| -> Result<OutputNormalizer> {
            let mean = tensors.f64(&format!("{prefix}.mean"), &[n3])?;
            let std = tensors.f64(&format!("{prefix}.std"), &[n3])?;
            OutputNormalizer::from_parts(mean, std).map_err(|e| corrupt(format!("{prefix}: {e}")))
        };
        let fitting_norm = load_norm("fitting_norm")?;
        let local_norm = load_norm("local_norm")?;
        if let Some(extra) = tensors.views.keys().next() {
            return Err(corrupt(format!("unexpected tensor `{extra}`")));
        }
        let model = Self {
            fitting,
            local,
            fitting_norm,
            local_norm,
            meta: ModelMeta {
                template: header.template,
                provenance: header.provenance,
            },
        };
        model.validate().map_err(|e| corrupt(e.to_string()))?;
        Ok(model)
    }
}

/// The file checksum of `document` and `tensors` (FNV-1a 64 over both).
fn stored_checksum(document: &str, tensors: &[Stored]) -> u64 {
    checksum(
        document,
        tensors
            .iter()
            .map(|t| (&*t.name, t.dtype, &*t.shape, &*t.bytes)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::PoseEncoding;
    use crate::net::garmatnet_net::MATERIAL_DIM;
    use crate::test_util::{cpu, random_inputs, small_model, to_vec};
    use garmatnet_core::Real;

    fn predictions(model: &GarMatNetModel, dev: &Device) -> (Vec<f32>, Vec<f32>) {
        let (p, m) = random_inputs(3, 11, dev);
        (
            to_vec(model.fitting.forward(p.clone(), m.clone())),
            to_vec(model.local.forward(p, m)),
        )
    }

    #[test]
    fn save_load_round_trip_is_bit_exact() {
        let dev = cpu();
        let dir = tempfile::tempdir().unwrap();
        for rank in [None, Some(5)] {
            let mut model = small_model(3, rank, &dev);
            model.fitting.config.scale_free_material = rank.is_some();
            model.local.config.scale_free_material = rank.is_some();
            if rank.is_some() {
                // A rotation-matrix pose branch has a wider input layer (the low-rank head
                // starts from init's placeholder basis).
                model.fitting = model
                    .fitting
                    .config()
                    .clone()
                    .with_pose_encoding(PoseEncoding::RotationMatrix)
                    .init(&dev);
            }
            model.meta.provenance.command = "garmatnet train --seed 3".into();
            // One file with the training material range, one without (as older files).
            model.meta.provenance.material_range = rank.map(|_| MaterialRange {
                min: [0.1, 0.2, 0.0, 0.05, 0.3, 0.25],
                max: [0.7, 0.6, 0.45, 0.5, 0.9, 0.75],
            });
            if rank.is_some() {
                model.meta.provenance.training_fabrics = [
                    ("Cotton Poplin", [0.1, 0.2, 0.0, 0.05, 0.3, 0.25]),
                    ("random-0-003", [0.7, 0.6, 0.45, 0.5, 0.9, 0.75]),
                ]
                .map(|(name, omega)| TrainingFabric {
                    name: name.into(),
                    omega,
                })
                .into();
            }
            model
                .meta
                .provenance
                .losses
                .insert("fitting_val_mse".into(), 0.25);
            let path = dir.path().join("m.safetensors");
            model.save(&path).unwrap();
            let back = GarMatNetModel::load(&path, &dev).unwrap();
            assert_eq!(predictions(&model, &dev), predictions(&back, &dev));
            assert_eq!(back.meta, model.meta);
            assert_eq!(back.fitting_norm, model.fitting_norm);
            assert_eq!(back.local_norm, model.local_norm);
            assert_eq!(back.fitting.output_rank(), rank);
            assert_eq!(back.fitting.config().alpha, model.fitting.config().alpha);
            for (a, b) in [(&back.fitting, &model.fitting), (&back.local, &model.local)] {
                assert_eq!(
                    a.config().scale_free_material,
                    b.config().scale_free_material
                );
                assert_eq!(a.config().pose_encoding, b.config().pose_encoding);
            }
        }
    }

    #[test]
    fn a_training_material_range_that_is_not_a_box_is_refused() {
        let mut model = small_model(3, None, &cpu());
        model.meta.provenance.material_range = Some(MaterialRange {
            min: [0.5; MATERIAL_DIM],
            max: [0.4; MATERIAL_DIM],
        });
        let err = model.validate().unwrap_err();
        assert!(
            matches!(err, Error::InvalidConfig(_)) && err.to_string().contains("material range"),
            "{err}"
        );
    }

    #[test]
    fn a_training_fabric_without_a_name_or_outside_the_recorded_range_is_refused() {
        let mut model = small_model(3, None, &cpu());
        let inside = [0.5; MATERIAL_DIM];
        model.meta.provenance.material_range = Some(MaterialRange {
            min: [0.4; MATERIAL_DIM],
            max: [0.6; MATERIAL_DIM],
        });
        let fabric = |name: &str, omega| TrainingFabric {
            name: name.into(),
            omega,
        };
        model.meta.provenance.training_fabrics = vec![fabric("Linen", inside)];
        model.validate().unwrap();
        let mut outside = inside;
        outside[3] = 0.7;
        for bad in [
            fabric(" ", inside),
            fabric("Linen", outside),
            fabric("Linen", [Real::NAN; MATERIAL_DIM]),
        ] {
            model.meta.provenance.training_fabrics = vec![bad];
            let err = model.validate().unwrap_err();
            assert!(
                matches!(err, Error::InvalidConfig(_))
                    && err.to_string().contains("training fabric"),
                "{err}"
            );
        }
        // Without a recorded range: ω must still be normalised, and names unique.
        model.meta.provenance.material_range = None;
        for bad in [
            vec![fabric("Linen", [5.0; MATERIAL_DIM])],
            vec![fabric("Linen", inside), fabric("Linen", inside)],
        ] {
            model.meta.provenance.training_fabrics = bad;
            let err = model.validate().unwrap_err();
            assert!(err.to_string().contains("training fabric"), "{err}");
        }
    }

    #[test]
    fn net_configs_written_before_the_optional_fields_read_as_the_papers_net() {
        let config = small_model(3, None, &cpu()).fitting.config().clone();
        let mut net = serde_json::to_value(
            config
                .with_scale_free_material(true)
                .with_pose_encoding(PoseEncoding::RotationMatrix),
        )
        .unwrap();
        net.as_object_mut().unwrap().remove("scale_free_material");
        net.as_object_mut().unwrap().remove("pose_encoding");
        assert!(serde_json::from_value::<GarMatNetConfig>(net.clone()).is_err());
        let document = serde_json::json!({ "fitting": net.clone(), "local": net });
        let document = with_optional_net_fields(document);
        for name in ["fitting", "local"] {
            let back: GarMatNetConfig = serde_json::from_value(document[name].clone()).unwrap();
            assert!(!back.scale_free_material);
            assert_eq!(back.pose_encoding, PoseEncoding::AxisAngle);
        }
    }

    #[test]
    fn truncated_or_flipped_files_are_errors_not_panics() {
        let dev = cpu();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.safetensors");
        small_model(4, Some(3), &dev).save(&path).unwrap();
        let good = std::fs::read(&path).unwrap();
        let header_len = u64::from_le_bytes(good[..8].try_into().unwrap()) as usize;
        let bad = dir.path().join("bad.safetensors");
        let mut offsets: Vec<usize> = (0..good.len()).step_by(good.len() / 37).collect();
        offsets.extend([
            0,
            1,
            7,
            8,
            9,
            header_len / 2,
            header_len + 7,
            header_len + 8,
            good.len() - 1,
        ]);
        for &cut in &offsets {
            std::fs::write(&bad, &good[..cut]).unwrap();
            assert!(
                GarMatNetModel::load(&bad, &dev).is_err(),
                "truncated at {cut} loaded"
            );
            let mut flipped = good.clone();
            flipped[cut] ^= 0xFF;
            std::fs::write(&bad, &flipped).unwrap();
            let err = GarMatNetModel::load(&bad, &dev);
            assert!(err.is_err(), "byte {cut} flipped loaded");
        }
        let mut flipped = good.clone();
        flipped[header_len + 8 + 100] ^= 0x01; // one bit in the weights
        std::fs::write(&bad, &flipped).unwrap();
        assert!(matches!(
            GarMatNetModel::load(&bad, &dev),
            Err(Error::Corrupt { .. })
        ));
        assert!(matches!(
            GarMatNetModel::load(dir.path().join("missing.safetensors"), &dev),
            Err(Error::Io { .. })
        ));
    }

    #[test]
    fn other_format_versions_are_refused_with_a_version_error() {
        let dev = cpu();
        let model = small_model(5, None, &dev);
        let mut tensors = net_tensors("fitting", &model.fitting);
        tensors.sort_by(|a, b| a.name.cmp(&b.name));
        let document = r#"{"format":"garmatnet-model","format_version":99}"#.to_owned();
        let sum = checksum(
            &document,
            tensors
                .iter()
                .map(|t| (&*t.name, t.dtype, &*t.shape, &*t.bytes)),
        );
        let metadata = HashMap::from([
            ("format".to_owned(), FORMAT_NAME.to_owned()),
            ("garmatnet".to_owned(), document),
            ("garmatnet_checksum".to_owned(), format!("{sum:016x}")),
        ]);
        let views = tensors.iter().map(|t| {
            (
                t.name.clone(),
                TensorView::new(t.dtype, t.shape.clone(), &t.bytes).unwrap(),
            )
        });
        let bytes = safetensors::serialize(views, Some(metadata)).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v99.safetensors");
        std::fs::write(&path, bytes).unwrap();
        let err = GarMatNetModel::load(&path, &dev).unwrap_err();
        assert!(
            matches!(err, Error::UnsupportedVersion { found: 99, .. }),
            "{err}"
        );
    }

    #[test]
    fn template_mismatch_is_refused_with_a_message() {
        let model = small_model(6, None, &cpu());
        model.ensure_template("test-template", 50).unwrap();
        let err = model.ensure_template("other", 50).unwrap_err();
        assert!(
            err.to_string()
                .contains("trained for garment template test-template"),
            "{err}"
        );
        assert!(model.ensure_template("test-template", 51).is_err());
    }

    #[test]
    fn a_non_finite_loss_is_refused_before_anything_is_written() {
        // Serialised, NaN and infinity become `null`, which no load can read back.
        let dev = cpu();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.safetensors");
        for bad in [Real::NAN, Real::INFINITY] {
            let mut model = small_model(8, None, &dev);
            model
                .meta
                .provenance
                .losses
                .insert("fitting_dev_mse".into(), bad);
            let err = model.save(&path).unwrap_err();
            assert!(
                matches!(err, Error::InvalidConfig(_))
                    && err.to_string().contains("fitting_dev_mse"),
                "{err}"
            );
            assert!(!path.exists(), "a refused save must not leave a file");
        }
    }

    #[test]
    fn the_split_fingerprint_is_read_from_the_provenance_and_absent_in_older_files() {
        let dev = cpu();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.safetensors");
        let mut model = small_model(9, None, &dev);
        assert_eq!(model.meta.provenance.split_fingerprint(), None);
        model.save(&path).unwrap();
        let back = GarMatNetModel::load(&path, &dev).unwrap();
        assert_eq!(back.meta.provenance.split_fingerprint(), None);
        model.meta.provenance.extra = serde_json::json!({
            "train_config": {},
            (TrainingProvenance::SPLIT_FINGERPRINT_KEY): "0123456789abcdef",
        });
        model.save(&path).unwrap();
        let back = GarMatNetModel::load(&path, &dev).unwrap();
        assert_eq!(
            back.meta.provenance.split_fingerprint(),
            Some("0123456789abcdef")
        );
        // A fingerprint that is not a string would skip the split check: refused.
        model.meta.provenance.extra[TrainingProvenance::SPLIT_FINGERPRINT_KEY] =
            serde_json::json!(42);
        assert!(model.save(&path).is_err());
    }

    #[test]
    fn inconsistent_models_are_not_saved() {
        let dev = cpu();
        let mut model = small_model(7, None, &dev);
        model.fitting_norm = OutputNormalizer::identity(3);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.safetensors");
        assert!(model.save(&path).is_err());
        assert!(!path.exists(), "a refused save must not leave a file");
    }
}
