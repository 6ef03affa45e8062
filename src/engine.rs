//! A resident scene ready to cull: prepared structures plus a backend.
//!
//! The GPU backend is used when an adapter exists; otherwise the CPU reference runs,
//! with a warning (and `HOMCULL_REQUIRE_GPU=1` turns a missing adapter into an error
//! before an engine is ever built: see [`crate::gpu::open_gpu`]).

use std::sync::Arc;

use homcull_proto::CullOptions;

use crate::camera::Camera;
use crate::cull::{CpuBackend, CullError, CullSettings, Culler, PoseResult, PreparedScene};
use crate::gpu::profile::PassTimes;
use crate::gpu::{GpuBackend, GpuContext};
use crate::occluders::OccluderParams;
use crate::scene::Scene;

pub struct Engine {
    /// Shared so that read-only work (the pyramid debug view) runs beside the GPU worker.
    pub prepared: Arc<PreparedScene>,
    backend: Box<dyn Culler + Send>,
    /// True when no GPU was available and the CPU reference runs.
    pub cpu_fallback: bool,
}

impl Engine {
    pub fn new(
        scene: Scene,
        occluder_params: OccluderParams,
        gpu: Option<Arc<GpuContext>>,
    ) -> Self {
        Self::from_prepared(PreparedScene::new(scene, occluder_params), gpu)
    }

    /// An engine over an already prepared scene (uploads its buffers to the GPU).
    pub fn from_prepared(prepared: PreparedScene, gpu: Option<Arc<GpuContext>>) -> Self {
        let (backend, cpu_fallback): (Box<dyn Culler + Send>, bool) = match gpu {
            Some(ctx) => (Box::new(GpuBackend::new(ctx, &prepared)), false),
            None => (Box::new(CpuBackend), true),
        };
        Engine {
            prepared: Arc::new(prepared),
            backend,
            cpu_fallback,
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
