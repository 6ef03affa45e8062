//! A resident scene ready to cull: prepared structures plus the backend that runs them.
//!
//! [`Backend`] is the choice made once per process (the GPU when an adapter exists,
//! else the CPU reference, with a warning; `HOMCULL_REQUIRE_GPU=1` turns a missing
//! adapter into an error: see [`crate::core::gpu::open_gpu`]). Every scene's
//! [`Engine`] builds its own [`Culler`] from it.

use std::sync::Arc;

use homcull_proto::CullOptions;

use crate::core::camera::Camera;
use crate::core::cull::{CullError, CullSettings, Culler, PassTimes, PoseResult, PreparedScene};
use crate::core::gpu::{GpuBackend, GpuContext, GpuError, open_gpu};
use crate::core::hom::ReferenceBackend;
use crate::core::occluders::OccluderParams;
use crate::core::scene::Scene;

/// Which backend culls: chosen once, shared by every scene.
#[derive(Clone)]
pub enum Backend {
    /// The wgpu backend on an opened device.
    Gpu(Arc<GpuContext>),
    /// The CPU reference of every pass (slow: the fallback without an adapter).
    Reference,
}

impl Backend {
    /// The GPU if one exists, else the CPU reference (an error instead with
    /// `HOMCULL_REQUIRE_GPU=1`).
    pub fn open() -> Result<Self, GpuError> {
        Ok(open_gpu()?.map(Arc::new).into())
    }

    /// The adapter (or the CPU reference) in words.
    pub fn describe(&self) -> String {
        match self {
            Backend::Gpu(ctx) => ctx.describe(),
            Backend::Reference => ReferenceBackend.describe(),
        }
    }

    /// The opened GPU, if this is the GPU backend.
    pub fn gpu(&self) -> Option<&Arc<GpuContext>> {
        match self {
            Backend::Gpu(ctx) => Some(ctx),
            Backend::Reference => None,
        }
    }

    fn culler(&self, prepared: &PreparedScene) -> Box<dyn Culler + Send> {
        match self {
            Backend::Gpu(ctx) => Box::new(GpuBackend::new(ctx.clone(), prepared)),
            Backend::Reference => Box::new(ReferenceBackend),
        }
    }
}

impl From<Option<Arc<GpuContext>>> for Backend {
    fn from(gpu: Option<Arc<GpuContext>>) -> Self {
        gpu.map_or(Backend::Reference, Backend::Gpu)
    }
}

pub struct Engine {
    /// Shared so that read-only work (the pyramid debug view) runs beside the worker.
    pub prepared: Arc<PreparedScene>,
    backend: Box<dyn Culler + Send>,
    /// True when no GPU was available and the CPU reference runs.
    pub cpu_fallback: bool,
}

impl Engine {
    pub fn new(scene: Scene, occluder_params: OccluderParams, backend: impl Into<Backend>) -> Self {
        Self::from_prepared(PreparedScene::new(scene, occluder_params), backend)
    }

    /// An engine over an already prepared scene (uploads its buffers to the GPU).
    pub fn from_prepared(prepared: PreparedScene, backend: impl Into<Backend>) -> Self {
        let backend = backend.into();
        Engine {
            backend: backend.culler(&prepared),
            cpu_fallback: matches!(backend, Backend::Reference),
            prepared: Arc::new(prepared),
        }
    }

    /// The adapter (or CPU fallback) in use.
    pub fn adapter(&self) -> String {
        self.backend.describe()
    }

    /// Settings for the given options with this scene's defaults.
    pub fn settings(&self, options: CullOptions) -> CullSettings {
        CullSettings::new(options, &self.prepared)
    }

    /// See [`Culler::set_profiling`].
    pub fn set_profiling(&mut self, on: bool) -> bool {
        self.backend.set_profiling(on)
    }

    /// See [`Culler::take_pass_times`].
    pub fn take_pass_times(&mut self) -> Option<PassTimes> {
        self.backend.take_pass_times()
    }

    pub fn cull(
        &mut self,
        cams: &[Camera],
        settings: &CullSettings,
    ) -> Result<Vec<PoseResult>, CullError> {
        self.backend.cull(&self.prepared, cams, settings)
    }

    /// See [`Culler::cull_preferring`].
    pub fn cull_preferring(
        &mut self,
        cams: &[Camera],
        settings: &CullSettings,
        prefer: &[&[u32]],
    ) -> Result<Vec<PoseResult>, CullError> {
        self.backend
            .cull_preferring(&self.prepared, cams, settings, prefer)
    }
}
