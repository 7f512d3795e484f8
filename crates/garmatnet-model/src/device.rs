//! Choosing the compute device at run time (Burn 0.22 backends are features, not types).

use burn::prelude::*;

use crate::error::Result;

/// The device named `name`:
/// - `"cpu"`: the pure-Rust `flex` backend (always available);
/// - `"gpu"`: WebGPU/Vulkan through `wgpu` (only in builds with the `wgpu` feature, and only
///   where wgpu finds an adapter: a GPU's driver, or a software one such as Mesa's lavapipe);
/// - `"auto"`: the GPU when this build has wgpu compiled in and wgpu finds a hardware
///   adapter, else the CPU (a software adapter such as lavapipe is 5–14× slower than the
///   CPU backend: "gpu" still takes one, "auto" does not).
///
/// wgpu itself opens its device lazily and panics on first use where it finds no adapter;
/// asking for the adapters here turns that into an error before any work is queued.
///
/// # Errors
/// [`crate::Error::DeviceUnavailable`] for `"gpu"` in a build without the `wgpu` feature or
/// on a machine where wgpu finds no adapter (the message says what to install);
/// [`crate::Error::UnknownName`] for any other name.
pub fn select_device(name: &str) -> Result<Device> {
    match name.trim().to_ascii_lowercase().as_str() {
        "cpu" => Ok(Device::flex()),
        "gpu" => gpu_device(),
        "auto" => Ok(auto_device()),
        other => Err(crate::error::Error::UnknownName {
            kind: "device",
            name: other.to_owned(),
            options: "`cpu`, `gpu` or `auto`",
        }),
    }
}

#[cfg(feature = "wgpu")]
fn gpu_device() -> Result<Device> {
    if Device::enumerate(burn::tensor::DeviceType::Wgpu).is_empty() {
        return Err(crate::error::Error::DeviceUnavailable(
            "wgpu finds no GPU adapter on this machine: install the GPU's Vulkan driver \
             (Linux: the vendor's driver, or `mesa-vulkan-drivers libvulkan1` for Mesa's; \
             Metal on macOS, DX12 on Windows), or use `cpu`"
                .into(),
        ));
    }
    Ok(Device::wgpu(DeviceKind::DefaultDevice))
}

/// A hardware GPU when this build has wgpu and wgpu lists one, else the CPU (one listing of
/// the adapters).
fn auto_device() -> Device {
    #[cfg(feature = "wgpu")]
    if hardware_gpu() {
        return Device::wgpu(DeviceKind::DefaultDevice);
    }
    Device::flex()
}

/// Whether wgpu finds a hardware adapter: a discrete, integrated or virtual GPU, not a
/// software rasteriser (wgpu lists those as CPUs).
#[cfg(feature = "wgpu")]
fn hardware_gpu() -> bool {
    let found = Device::enumerate(burn::tensor::DeviceType::Wgpu);
    [
        DeviceKind::DiscreteGpu(0),
        DeviceKind::IntegratedGpu(0),
        DeviceKind::VirtualGpu(0),
    ]
    .into_iter()
    .any(|kind| found.contains(&Device::wgpu(kind)))
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
        assert!(
            matches!(&err, crate::Error::UnknownName { kind: "device", name, .. } if name == "tpu"),
            "{err}"
        );
        assert!(err.to_string().contains("use `cpu`, `gpu` or `auto`"));
    }

    /// `auto` is the CPU unless wgpu lists a hardware GPU (CI's machines list only Mesa's
    /// software lavapipe, so there it is the CPU); `gpu` takes whatever adapter there is.
    #[test]
    fn auto_takes_a_hardware_gpu_or_the_cpu() {
        let auto = select_device("auto").unwrap();
        #[cfg(not(feature = "wgpu"))]
        assert!(auto == Device::flex());
        #[cfg(feature = "wgpu")]
        {
            assert_eq!(auto == Device::flex(), !hardware_gpu());
            let listed = Device::enumerate(burn::tensor::DeviceType::Wgpu);
            eprintln!("wgpu lists {listed:?}; auto = {auto:?}");
            assert_eq!(select_device("gpu").is_ok(), !listed.is_empty());
        }
    }

    #[cfg(not(feature = "wgpu"))]
    #[test]
    fn gpu_without_the_feature_says_how_to_get_it() {
        let err = select_device("gpu").unwrap_err();
        assert!(matches!(err, crate::error::Error::DeviceUnavailable(_)));
        assert!(err.to_string().contains("--features wgpu"));
    }
}
