//! Backend selection by cargo feature: `flex` (default), `ndarray`, or `wgpu`.

use burn::tensor::Device;

/// The device of the compiled-in backend, preferring flex, then ndarray, then wgpu (when
/// several are enabled, e.g. with `--all-features`).
pub fn default_device() -> Device {
    #[cfg(feature = "flex")]
    {
        Device::flex()
    }
    #[cfg(all(not(feature = "flex"), feature = "ndarray"))]
    {
        #[allow(deprecated)]
        Device::ndarray()
    }
    #[cfg(all(not(feature = "flex"), not(feature = "ndarray"), feature = "wgpu"))]
    {
        Device::wgpu(Default::default())
    }
}

/// The same device with automatic differentiation, for training.
pub fn training_device() -> Device {
    default_device().autodiff()
}

/// The name of the backend [`default_device`] uses, for logs and reports.
pub fn backend_name() -> &'static str {
    if cfg!(feature = "flex") {
        "flex"
    } else if cfg!(feature = "ndarray") {
        "ndarray"
    } else {
        "wgpu"
    }
}

#[cfg(not(any(feature = "flex", feature = "ndarray", feature = "wgpu")))]
compile_error!("lucid-nerf needs a backend: enable the `flex`, `ndarray` or `wgpu` feature");
