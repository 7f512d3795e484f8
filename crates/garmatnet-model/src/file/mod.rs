//! Model files: the self-describing `.safetensors` format, the model that ships with the
//! library, and ensembles averaged into one file.

pub(crate) mod default_model;
pub(crate) mod ensemble;
pub(crate) mod model_file;
