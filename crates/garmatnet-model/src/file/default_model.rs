//! The model that ships with the library: where it lives and how to get a predictor from it
//! (or from any model file) without building the garment by hand.

use std::path::{Path, PathBuf};

use garmatnet_core::{CapsuleBody, Garment};

use crate::error::{Error, Result};
use crate::file::model_file::GarMatNetModel;
use crate::predict::predictor::Predictor;

/// The environment variable that, when set, names the model file
/// [`Predictor::default_tshirt`] loads instead of the shipped one.
pub const MODEL_ENV: &str = "GARMATNET_MODEL";

/// The shipped T-shirt model inside this crate's source tree (`models/` next to its
/// `Cargo.toml`). `cargo` builds from a checkout or from the registry both keep it there.
pub const SHIPPED_MODEL: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/models/tshirt-default.safetensors"
);

/// The model file [`Predictor::default_tshirt`] loads: `$GARMATNET_MODEL` when set (and not
/// empty), else [`SHIPPED_MODEL`].
#[must_use]
pub fn default_model_path() -> PathBuf {
    match std::env::var_os(MODEL_ENV) {
        Some(p) if !p.is_empty() => PathBuf::from(p),
        _ => PathBuf::from(SHIPPED_MODEL),
    }
}

impl Predictor {
    /// A predictor for the model file at `path`, on the T-shirt template and SMPL-neutral
    /// capsule body it was trained with (the resolution is read from the file), with body
    /// push-out on.
    ///
    /// # Errors
    /// [`Error::MissingModel`] if there is no file at `path`; the errors of
    /// [`GarMatNetModel::load`] for unreadable or corrupt files; [`Error::TemplateMismatch`]
    /// if the file was trained on a garment other than this library's T-shirt.
    pub fn from_file(path: impl AsRef<Path>, device: &burn::prelude::Device) -> Result<Self> {
        let path = path.as_ref();
        if !path.is_file() {
            return Err(Error::MissingModel {
                path: path.to_path_buf(),
            });
        }
        let model = GarMatNetModel::load(path, device)?;
        let body = CapsuleBody::smpl_neutral();
        let template = &model.meta.template;
        let garment = Garment::for_template(template.resolution, &template.hash, &body)?;
        Self::for_garment(model, &garment, body, device)
    }

    /// The shipped T-shirt model (or the one `$GARMATNET_MODEL` names; see
    /// [`default_model_path`]) as a ready predictor: no files to fetch.
    ///
    /// ```no_run
    /// use garmatnet_model::{Detail, Predictor, select_device};
    /// use garmatnet_core::{Material, Pose};
    ///
    /// let predictor = Predictor::default_tshirt(&select_device("cpu")?)?;
    /// let shirt = predictor.predict(&Pose::zero(), &Material::preset("silk chiffon")?, Detail::Full)?;
    /// assert_eq!(shirt.vertices.len(), predictor.vertex_count());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    ///
    /// # Errors
    /// As [`Predictor::from_file`].
    pub fn default_tshirt(device: &burn::prelude::Device) -> Result<Self> {
        Self::from_file(default_model_path(), device)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{GarMatNetConfig, select_device};
    use garmatnet_core::TemplateInfo;
    use garmatnet_core::{Material, Pose, Resolution};

    #[test]
    fn from_file_builds_the_template_the_model_names() -> anyhow::Result<()> {
        let device = select_device("cpu")?;
        let body = CapsuleBody::smpl_neutral();
        let garment = Garment::tshirt(Resolution::Coarse, &body)?;
        let config = GarMatNetConfig::new(garment.vertex_count(), 8, 4, 8);
        let model = GarMatNetModel::untrained(&config, TemplateInfo::of(&garment), &device);
        let dir = tempfile::tempdir()?;
        let path = dir.path().join("m.safetensors");
        model.save(&path)?;
        let predictor = Predictor::from_file(&path, &device)?;
        assert_eq!(predictor.vertex_count(), garment.vertex_count());
        let mesh = predictor.predict(
            &Pose::zero(),
            &Material::preset("denim heavy")?,
            crate::Detail::Full,
        )?;
        assert_eq!(*mesh.faces, *garment.rest.faces);
        Ok(())
    }

    #[test]
    fn a_missing_model_names_the_path_and_the_remedy() -> anyhow::Result<()> {
        let device = select_device("cpu")?;
        let err = Predictor::from_file("/nonexistent/model.safetensors", &device)
            .expect_err("no file there");
        let message = err.to_string();
        assert!(
            message.contains("/nonexistent/model.safetensors"),
            "{message}"
        );
        assert!(message.contains(MODEL_ENV), "{message}");
        Ok(())
    }

    #[test]
    fn the_shipped_model_path_is_inside_the_crate() {
        assert!(SHIPPED_MODEL.ends_with("models/tshirt-default.safetensors"));
        assert!(Path::new(SHIPPED_MODEL).starts_with(env!("CARGO_MANIFEST_DIR")));
    }
}
