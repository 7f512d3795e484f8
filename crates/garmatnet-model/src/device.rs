//! Choosing the compute device at run time (Burn 0.22 backends are features, not types).

use burn::prelude::*;

use crate::error::Result;

/// The device named `name`:
/// - `"cpu"`: the pure-Rust `flex` backend (always available);
/// - `"gpu"`: WebGPU/Vulkan through `wgpu` (only in builds with the `wgpu` feature);
/// - `"auto"`: the GPU when this build has one compiled in, else the CPU.
///
/// `wgpu` devices start lazily: a machine without a usable adapter fails on first use, not
/// here.
///
/// # Errors
/// [`crate::Error::DeviceUnavailable`] for `"gpu"` in a build without the `wgpu` feature;
/// [`crate::Error::Core`] (invalid argument) for any other name.
pub fn select_device(name: &str) -> Result<Device> {
    match name.trim().to_ascii_lowercase().as_str() {
        "cpu" => Ok(Device::flex()),
        "gpu" => gpu_device(),
        "auto" => Ok(gpu_device().unwrap_or_else(|_| Device::flex())),
        other => Err(garmatnet_core::Error::InvalidArgument(format!(
            "unknown device `{other}`; use `cpu`, `gpu` or `auto`"
        ))
        .into()),
    }
}

#[cfg(feature = "wgpu")]
fn gpu_device() -> Result<Device> {
    Ok(Device::wgpu(DeviceKind::DefaultDevice))
}

#[cfg(not(feature = "wgpu"))]
fn gpu_device() -> Result<Device> {
    Err(crate::error::Error::DeviceUnavailable(
        "this build has no GPU backend; rebuild with `--features wgpu` to use `gpu`".into(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_always_works_and_unknown_names_are_refused() {
        assert!(select_device("cpu").is_ok());
        assert!(select_device(" CPU ").is_ok());
        assert!(select_device("auto").is_ok());
        let err = select_device("tpu").unwrap_err();
        assert!(err.to_string().contains("use `cpu`, `gpu` or `auto`"));
    }

    #[cfg(not(feature = "wgpu"))]
    #[test]
    fn gpu_without_the_feature_says_how_to_get_it() {
        let err = select_device("gpu").unwrap_err();
        assert!(matches!(err, crate::error::Error::DeviceUnavailable(_)));
        assert!(err.to_string().contains("--features wgpu"));
    }
}
