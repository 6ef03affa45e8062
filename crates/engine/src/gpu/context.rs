//! [`GpuContext`]: one opened device plus the pipelines and targets that every scene's
//! backend on it shares, built on first use. What callers open and pass around.

use std::sync::{Arc, OnceLock};

use super::device::{GpuDevice, GpuError, GpuOptions};
use super::passes::SharedPasses;

/// An opened device and its shared passes. Derefs to the [`GpuDevice`].
pub struct GpuContext {
    gpu: GpuDevice,
    /// Pipelines and targets every scene's backend shares (built on first use).
    passes: OnceLock<Arc<SharedPasses>>,
}

impl std::ops::Deref for GpuContext {
    type Target = GpuDevice;
    fn deref(&self) -> &GpuDevice {
        &self.gpu
    }
}

impl GpuContext {
    /// Opens the adapter chosen by `WGPU_ADAPTER_NAME` / `WGPU_BACKEND` /
    /// `WGPU_POWER_PREF`, or the default one.
    pub fn new() -> Result<Self, GpuError> {
        Self::with_options(GpuOptions::from_env())
    }

    /// [`GpuContext::new`] using only the optional features `options` allows.
    pub fn with_options(options: GpuOptions) -> Result<Self, GpuError> {
        Ok(GpuContext {
            gpu: GpuDevice::with_options(options)?,
            passes: OnceLock::new(),
        })
    }

    /// The passes every scene on this device shares.
    pub(crate) fn passes(&self) -> Arc<SharedPasses> {
        self.passes
            .get_or_init(|| Arc::new(SharedPasses::new(&self.gpu)))
            .clone()
    }
}

/// Opens a GPU if one exists. With `HOMCULL_REQUIRE_GPU=1` a missing adapter is an
/// error; otherwise it is a warning and the CPU reference takes over.
pub fn open_gpu() -> Result<Option<GpuContext>, GpuError> {
    match GpuContext::new() {
        Ok(ctx) => Ok(Some(ctx)),
        Err(e) if require_gpu() => Err(e),
        Err(e) => {
            tracing::warn!("{e}; falling back to the CPU reference implementation (slow)");
            Ok(None)
        }
    }
}

/// Whether `HOMCULL_REQUIRE_GPU` asks for a real adapter.
pub fn require_gpu() -> bool {
    std::env::var("HOMCULL_REQUIRE_GPU").is_ok_and(|v| v == "1" || v.eq_ignore_ascii_case("true"))
}
