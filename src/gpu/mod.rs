//! GPU backend on wgpu: headless device, one file per pass.
//!
//! - [`GpuContext`]: adapter, device and queue (honours `WGPU_*` environment variables).
//! - [`scene_buffers`]: a scene's vertices, indices and test boxes, uploaded once.
//! - [`raster`]: occluder raster (view depth) and oracle raster (object IDs), sharing
//!   one invariant vertex stage.
//! - [`pyramid`]: the 2×2 reductions, two levels per dispatch (compute); level 0 is
//!   the occlusion map itself.
//! - [`test_pass`]: the per-object HOM / HZB test (compute), writing a bitmask.
//! - [`refine`]: HOM's refinement: the box test's survivors re-rasterized against the
//!   occluders' depth buffer (early depth tests where the adapter can force them),
//!   writing a second bitmask.
//! - [`oracle`]: ID buffer → visibility bitmask (compute).
//! - [`batch`]: [`GpuBackend`], which records all passes of a batch of poses into one
//!   submission with one readback.
//! - [`profile`]: GPU time per pass from timestamps written between the passes.
//!
//! Every pass has a CPU twin in `hom/` (the refinement's is `CpuBackend::refine`);
//! tests run both on the same input.

pub mod batch;
pub mod oracle;
pub mod profile;
pub mod pyramid;
pub mod raster;
pub mod refine;
pub mod scene_buffers;
pub mod test_pass;

pub use batch::GpuBackend;

use std::sync::Arc;

/// Why the GPU could not be used.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error("no GPU adapter found: {0}")]
    NoAdapter(String),
    #[error("could not open the GPU device: {0}")]
    Device(String),
    #[error("GPU readback failed: {0}")]
    Readback(String),
}

/// Optional adapter features homcull uses where the adapter has them. Turning one
/// off exercises the path that adapters without it take (tests do).
#[derive(Debug, Clone, Copy)]
pub struct GpuOptions {
    /// See [`GpuContext::indirect_draws`]; env `HOMCULL_NO_INDIRECT` turns it off.
    pub indirect_draws: bool,
    /// See [`GpuContext::early_depth_test`]; env `HOMCULL_NO_EARLY_Z` turns it off.
    pub early_depth_test: bool,
}

impl GpuOptions {
    pub fn from_env() -> Self {
        GpuOptions {
            indirect_draws: std::env::var_os("HOMCULL_NO_INDIRECT").is_none(),
            early_depth_test: std::env::var_os("HOMCULL_NO_EARLY_Z").is_none(),
        }
    }
}

/// The wgpu device and queue homcull renders with.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    /// All of a pose's draws go out as one `multi_draw_indexed_indirect` (needs
    /// indirect execution and a non-zero first instance in indirect draws); without
    /// it, one draw call per object.
    pub indirect_draws: bool,
    /// The refinement tests its fragments against the occluders' own depth buffer
    /// before its fragment shader runs (`@early_depth_test(force)`, feature
    /// `SHADER_EARLY_DEPTH_TEST`); without it, the shader compares with the occlusion
    /// map (`crate::gpu::refine`).
    pub early_depth_test: bool,
    /// Timestamps can be written between passes (`TIMESTAMP_QUERY_INSIDE_ENCODERS`),
    /// so batches can be profiled pass by pass (`crate::gpu::profile`).
    pub timestamps: bool,
    /// Pipelines and targets every scene's backend shares (built on first use).
    pub(crate) shared_passes: std::sync::OnceLock<Arc<batch::SharedPasses>>,
}

impl GpuContext {
    /// Opens the adapter chosen by `WGPU_ADAPTER_NAME` / `WGPU_BACKEND` /
    /// `WGPU_POWER_PREF`, or the default one.
    pub fn new() -> Result<Self, GpuError> {
        Self::with_options(GpuOptions::from_env())
    }

    /// [`GpuContext::new`] using only the optional features `options` allows.
    pub fn with_options(options: GpuOptions) -> Result<Self, GpuError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        if std::env::var_os("WGPU_BACKEND").is_none() {
            // Vulkan/Metal/DX12 only: GL lacks what the passes need and its probe is noisy.
            desc.backends = wgpu::Backends::PRIMARY;
        }
        let instance = wgpu::Instance::new(desc);
        let adapter = pollster::block_on(choose_adapter(&instance))?;
        let info = adapter.get_info();
        let limits = adapter.limits();
        if limits.max_storage_buffers_per_shader_stage < 8 {
            return Err(GpuError::NoAdapter(format!(
                "adapter {} allows {} storage buffers per stage, homcull needs 8",
                info.name, limits.max_storage_buffers_per_shader_stage
            )));
        }
        let indirect_draws = adapter
            .features()
            .contains(wgpu::Features::INDIRECT_FIRST_INSTANCE)
            && adapter
                .get_downlevel_capabilities()
                .flags
                .contains(wgpu::DownlevelFlags::INDIRECT_EXECUTION)
            && options.indirect_draws;
        let early_depth_test = options.early_depth_test
            && adapter
                .features()
                .contains(wgpu::Features::SHADER_EARLY_DEPTH_TEST);
        let timestamp_features =
            wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS;
        let timestamps = adapter.features().contains(timestamp_features);
        let mut required_features = wgpu::Features::empty();
        if timestamps {
            required_features |= timestamp_features;
        }
        if indirect_draws {
            required_features |= wgpu::Features::INDIRECT_FIRST_INSTANCE;
        }
        if early_depth_test {
            required_features |= wgpu::Features::SHADER_EARLY_DEPTH_TEST;
        }
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("homcull"),
            required_limits: limits,
            required_features,
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device(e.to_string()))?;
        Ok(GpuContext {
            device,
            queue,
            info,
            indirect_draws,
            early_depth_test,
            timestamps,
            shared_passes: Default::default(),
        })
    }

    /// A one-line description: adapter name and backend.
    pub fn describe(&self) -> String {
        format!(
            "{} ({:?}, {:?})",
            self.info.name, self.info.backend, self.info.device_type
        )
    }

    /// A bind group layout from `entries` and a pipeline layout holding just it, the
    /// shape every compute pass here uses.
    pub(crate) fn compute_layout(
        &self,
        label: &str,
        entries: &[wgpu::BindGroupLayoutEntry],
    ) -> (wgpu::BindGroupLayout, wgpu::PipelineLayout) {
        let bind = self
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(label),
                entries,
            });
        let pipeline = self
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: &[Some(&bind)],
                immediate_size: 0,
            });
        (bind, pipeline)
    }

    /// A compute pipeline for one entry point of `module`.
    pub(crate) fn compute_pipeline(
        &self,
        layout: &wgpu::PipelineLayout,
        module: &wgpu::ShaderModule,
        entry: &str,
    ) -> wgpu::ComputePipeline {
        self.device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(layout),
                module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
    }

    /// Compiles a kernel with the shared definitions of `common.wgsl` prepended.
    pub fn shader(&self, label: &str, source: &str) -> wgpu::ShaderModule {
        let code = format!("{}\n{}", include_str!("shaders/common.wgsl"), source);
        self.device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(code.into()),
            })
    }
}

/// The adapter `WGPU_ADAPTER_NAME` names (a case-insensitive substring of its name),
/// else the default one for `WGPU_POWER_PREF`. Unlike wgpu's own helper, a name that
/// matches nothing is an error that lists the adapters there are, not a panic.
async fn choose_adapter(instance: &wgpu::Instance) -> Result<wgpu::Adapter, GpuError> {
    if let Ok(wanted) = std::env::var("WGPU_ADAPTER_NAME") {
        let adapters = instance.enumerate_adapters(wgpu::Backends::all()).await;
        let names: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
        return adapters
            .into_iter()
            .find(|a| {
                a.get_info()
                    .name
                    .to_lowercase()
                    .contains(&wanted.to_lowercase())
            })
            .ok_or_else(|| {
                GpuError::NoAdapter(format!(
                    "WGPU_ADAPTER_NAME={wanted:?} matches none of the adapters: {names:?}"
                ))
            });
    }
    instance
        .request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::from_env().unwrap_or_default(),
            ..Default::default()
        })
        .await
        .map_err(|e| GpuError::NoAdapter(e.to_string()))
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

pub(crate) fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

pub(crate) fn uniform_entry(
    binding: u32,
    dynamic: bool,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: dynamic,
            min_binding_size: None,
        },
        count: None,
    }
}

pub(crate) fn texture_array_entry(
    binding: u32,
    sample_type: wgpu::TextureSampleType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type,
            view_dimension: wgpu::TextureViewDimension::D2Array,
            multisampled: false,
        },
        count: None,
    }
}

/// Records a 1-D compute pass of `invocations` threads in workgroups of `wg`, with
/// `bind_group` bound at uniform slot `slot`; nothing when `invocations` is 0. Wide
/// dispatches wrap into rows of at most 65535 workgroups (the per-dimension limit), so
/// kernels index `g.x + g.y · num_workgroups.x · wg`.
pub(crate) fn record_wide(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    bind_group: &wgpu::BindGroup,
    slot: u32,
    invocations: u32,
    wg: u32,
) {
    const MAX_DIM: u32 = 65_535;
    if invocations == 0 {
        return;
    }
    let groups = invocations.div_ceil(wg);
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes: None,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, bind_group, &[(slot as u64 * UNIFORM_SLOT) as u32]);
    let x = groups.min(MAX_DIM);
    pass.dispatch_workgroups(x, groups.div_ceil(x), 1);
}

/// Records a compute pass of 8×8 workgroups over a `width` × `height` grid for each of
/// `slots` pose slots (z = slot), with `bind_group` bound at uniform slot `slot`: the
/// shape of the per-pixel passes (pyramid, oracle collect).
#[allow(clippy::too_many_arguments)]
pub(crate) fn record_grid(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    bind_group: &wgpu::BindGroup,
    slot: u32,
    width: u32,
    height: u32,
    slots: u32,
) {
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes: None,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, bind_group, &[(slot as u64 * UNIFORM_SLOT) as u32]);
    pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), slots);
}

/// Uniform slots are 256 bytes apart (the dynamic-offset alignment every adapter accepts).
pub const UNIFORM_SLOT: u64 = 256;

/// Packs `items` into 256-byte slots for dynamic-offset binding.
pub(crate) fn slotted<T: bytemuck::Pod>(items: &[T]) -> Vec<u8> {
    let mut out = vec![0u8; items.len().max(1) * UNIFORM_SLOT as usize];
    for (i, it) in items.iter().enumerate() {
        let b = bytemuck::bytes_of(it);
        out[i * UNIFORM_SLOT as usize..][..b.len()].copy_from_slice(b);
    }
    out
}
