//! A resident scene ready to cull: prepared structures plus the backend that runs them.
//!
//! [`Backend`] is the choice made once per process from a [`BackendChoice`]
//! (`--backend`, `HOMCULL_BACKEND`): `gpu` opens an adapter (software ones count) or
//! fails; `cpu` runs the native CPU backend (`core::native`); `auto` takes a hardware
//! adapter if one opens and the native CPU backend otherwise, and a software Vulkan
//! adapter (lavapipe) only when asked for: `--backend gpu`, or
//! `HOMCULL_REQUIRE_GPU=1`, which makes `auto` mean `gpu`. The CPU reference
//! (`core::reference`) is a backend for tests, never chosen by these. Every scene's
//! [`Engine`] builds its own [`Culler`] from the choice.

use std::sync::{Arc, Mutex};

use homcull_proto::CullOptions;

use crate::camera::Camera;
use crate::cull::{
    CullError, CullSettings, Culler, PassTimes, Passes, Placed, PoseResult, PreparedScene,
    StartedCull,
};
use crate::dynamic::{Dynamics, snapshot};
use crate::gpu::{GpuBackend, GpuContext, GpuError, require_gpu};
use crate::native::NativeBackend;
use crate::occluders::OccluderParams;
use crate::reference::ReferenceBackend;
use crate::region;
use crate::scene::Scene;

/// The backend a process asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BackendChoice {
    /// A hardware GPU if there is one, else the native CPU backend.
    #[default]
    Auto,
    /// A wgpu adapter, software ones included; none is an error.
    Gpu,
    /// The native CPU backend.
    Cpu,
}

impl std::str::FromStr for BackendChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(BackendChoice::Auto),
            "gpu" => Ok(BackendChoice::Gpu),
            "cpu" => Ok(BackendChoice::Cpu),
            _ => Err(format!("unknown backend `{s}` (auto, gpu or cpu)")),
        }
    }
}

impl std::fmt::Display for BackendChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            BackendChoice::Auto => "auto",
            BackendChoice::Gpu => "gpu",
            BackendChoice::Cpu => "cpu",
        })
    }
}

/// Which backend culls: chosen once, shared by every scene.
#[derive(Clone)]
pub enum Backend {
    /// The wgpu backend on an opened device.
    Gpu(Arc<GpuContext>),
    /// The native CPU backend (span rasterizer, tile bounds, rayon over poses).
    Native,
    /// The CPU reference of every pass (slow: the test oracle, not a serving path).
    Reference,
}

impl Backend {
    /// The backend `choice` asks for (see the module docs).
    pub fn open(choice: BackendChoice) -> Result<Self, GpuError> {
        let choice = if choice == BackendChoice::Auto && require_gpu() {
            BackendChoice::Gpu
        } else {
            choice
        };
        match choice {
            BackendChoice::Gpu => Ok(Backend::Gpu(Arc::new(GpuContext::new()?))),
            BackendChoice::Cpu => Ok(Backend::Native),
            BackendChoice::Auto => match GpuContext::new() {
                Ok(ctx) if ctx.info.device_type != wgpu::DeviceType::Cpu => {
                    Ok(Backend::Gpu(Arc::new(ctx)))
                }
                Ok(ctx) => {
                    tracing::info!(
                        "{} is a software adapter; culling on the native CPU backend \
                         (`--backend gpu` to use it)",
                        ctx.info.name
                    );
                    Ok(Backend::Native)
                }
                Err(e) => {
                    tracing::info!("{e}; culling on the native CPU backend");
                    Ok(Backend::Native)
                }
            },
        }
    }

    /// The backend's short name: `gpu`, `cpu` (native) or `reference`.
    pub fn name(&self) -> &'static str {
        match self {
            Backend::Gpu(_) => "gpu",
            Backend::Native => "cpu",
            Backend::Reference => "reference",
        }
    }

    /// The adapter (or CPU implementation) in words.
    pub fn describe(&self) -> String {
        match self {
            Backend::Gpu(ctx) => ctx.describe(),
            Backend::Native => NativeBackend.describe(),
            Backend::Reference => ReferenceBackend.describe(),
        }
    }

    /// The opened GPU, if this is the GPU backend.
    pub fn gpu(&self) -> Option<&Arc<GpuContext>> {
        match self {
            Backend::Gpu(ctx) => Some(ctx),
            Backend::Native | Backend::Reference => None,
        }
    }

    fn culler(&self, prepared: &PreparedScene) -> Box<dyn Culler + Send> {
        match self {
            Backend::Gpu(ctx) => Box::new(GpuBackend::new(ctx.clone(), prepared)),
            Backend::Native => Box::new(NativeBackend),
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
    /// The scene at the version culled last. Shared so that read-only work (the
    /// pyramid debug view) runs beside the worker.
    pub prepared: Arc<PreparedScene>,
    backend: Box<dyn Culler + Send>,
    /// The scene as loaded, which placements are relative to.
    base: Arc<PreparedScene>,
    /// Placements sent by writers; the engine moves to their version when it culls.
    dynamics: Arc<Mutex<Dynamics>>,
    /// The version of `prepared`.
    version: u64,
    /// The placements of `prepared`'s moved objects, and the table answers carry.
    placements: std::collections::BTreeMap<u32, [f32; 16]>,
    placed: Option<Placed>,
}

impl Engine {
    pub fn new(scene: Scene, occluder_params: OccluderParams, backend: impl Into<Backend>) -> Self {
        Self::from_prepared(PreparedScene::new(scene, occluder_params), backend)
    }

    /// An engine over an already prepared scene (uploads its buffers to the GPU).
    pub fn from_prepared(prepared: PreparedScene, backend: impl Into<Backend>) -> Self {
        let backend = backend.into();
        let backend = backend.culler(&prepared);
        let prepared = Arc::new(prepared);
        Engine {
            backend,
            base: prepared.clone(),
            dynamics: Arc::new(Mutex::new(Dynamics::new(prepared.clone()))),
            prepared,
            version: 0,
            placements: Default::default(),
            placed: None,
        }
    }

    /// The placements of this scene's objects, for writers to update (see
    /// `core::dynamic`); the next cull runs on their version.
    pub fn dynamics(&self) -> Arc<Mutex<Dynamics>> {
        self.dynamics.clone()
    }

    /// Moves to the latest version the writers made, if it is newer.
    pub fn refresh(&mut self) {
        let changes = self
            .dynamics
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .take_changes(self.version);
        let Some(changes) = changes else { return };
        let t = std::time::Instant::now();
        let next = snapshot::advance(&self.base, &self.prepared, &changes);
        let changed: Vec<(u32, glam::Mat4)> = (changes.objects.iter())
            .map(|(id, p)| (*id, p.map_or(glam::Mat4::IDENTITY, |p| p.matrix)))
            .collect();
        self.backend.scene_changed(&next, &changed);
        self.prepared = Arc::new(next);
        self.version = changes.version;
        for (id, p) in &changes.objects {
            match p {
                Some(p) => self.placements.insert(*id, p.matrix.to_cols_array()),
                None => self.placements.remove(id),
            };
        }
        self.placed = (!self.placements.is_empty())
            .then(|| self.placements.iter().map(|(&id, &m)| (id, m)).collect());
        tracing::debug!(
            target: "homcull::timing",
            version = self.version,
            objects = changed.len(),
            ms = t.elapsed().as_secs_f64() * 1e3,
            "moved the scene"
        );
    }

    fn named(&self, mut results: Vec<PoseResult>) -> Vec<PoseResult> {
        for r in &mut results {
            r.stats.scene_version = self.version;
            r.placed = self.placed.clone();
        }
        results
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
        self.cull_preferring(cams, settings, &[])
    }

    /// See [`Culler::cull_preferring`].
    pub fn cull_preferring(
        &mut self,
        cams: &[Camera],
        settings: &CullSettings,
        prefer: &[&[u32]],
    ) -> Result<Vec<PoseResult>, CullError> {
        let started = self.start_cull(cams, settings, prefer)?;
        let results = self.finish_cull(started)?;
        Ok(self.named(results))
    }

    /// See [`Culler::start_cull`]: plans and submits without waiting for the device.
    pub fn start_cull(
        &mut self,
        cams: &[Camera],
        settings: &CullSettings,
        prefer: &[&[u32]],
    ) -> Result<StartedCull, CullError> {
        self.refresh();
        // Region poses are answered here, on the CPU, whatever the backend
        // (`core::region`); the backend plans and culls the others.
        if !cams.iter().any(|c| c.region.is_some()) {
            return self.start_planned(cams, settings, prefer);
        }
        if settings.passes() == Some(Passes::Exact) {
            return Err(CullError::RegionUnsupported {
                method: settings.method.name(),
            });
        }
        settings.validate()?;
        let (mut points, mut point_prefer) = (Vec::new(), Vec::new());
        let mut regions = Vec::new();
        for (k, cam) in cams.iter().enumerate() {
            match &cam.region {
                Some(r) => regions.push((k, cam, *r)),
                None => {
                    points.push(cam.clone());
                    point_prefer.push(prefer.get(k).copied().unwrap_or(&[]));
                }
            }
        }
        let prep = &self.prepared;
        let answered = {
            use rayon::prelude::*;
            regions
                .par_iter()
                .map(|(k, cam, r)| (*k, region::cull(prep, cam, r, settings)))
                .collect()
        };
        Ok(self
            .start_planned(&points, settings, &point_prefer)?
            .with_answered(answered))
    }

    /// [`Engine::start_cull`] of cameras without a region: the backend's.
    fn start_planned(
        &mut self,
        cams: &[Camera],
        settings: &CullSettings,
        prefer: &[&[u32]],
    ) -> Result<StartedCull, CullError> {
        let mut started = self
            .backend
            .start_cull(&self.prepared, cams, settings, prefer)?;
        started.scene_version = self.version;
        started.placed = self.placed.clone();
        Ok(started)
    }

    /// See [`Culler::finish_cull`]: waits for a cull this engine started.
    pub fn finish_cull(&mut self, started: StartedCull) -> Result<Vec<PoseResult>, CullError> {
        self.backend.finish_cull(&self.prepared, started)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::demo_city;

    #[test]
    fn a_backend_and_its_culler_share_one_short_name() {
        let prep = PreparedScene::new(demo_city(), OccluderParams::default());
        for b in [Backend::Native, Backend::Reference] {
            assert_eq!(b.culler(&prep).name(), b.name());
        }
    }
}
