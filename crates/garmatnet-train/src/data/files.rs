//! Paths and permissions of the files a training run writes next to its model.

use std::path::{Path, PathBuf};

/// `PathBuf` of a file next to `model` named `{model stem}.{suffix}`.
pub(crate) fn sibling(model: &Path, suffix: &str) -> PathBuf {
    let stem = model
        .file_stem()
        .map_or_else(|| "model".into(), |s| s.to_string_lossy().into_owned());
    model.with_file_name(format!("{stem}.{suffix}"))
}

/// Gives a finished output file ordinary permissions (0644 on Unix): the atomic writers
/// create their temporary files 0600, which would hide reports and splits from other users.
pub(crate) fn make_readable(path: &Path) {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let _ = std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o644));
    }
    #[cfg(not(unix))]
    let _ = path;
}

/// The split file of the model at `model_path`: `{stem}.split.json` next to it.
#[must_use]
pub fn split_path(model_path: &Path) -> PathBuf {
    sibling(model_path, "split.json")
}
