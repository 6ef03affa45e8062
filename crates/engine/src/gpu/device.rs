//! The wgpu adapter, device and queue homcull renders with, and the optional features
//! it found there. The lowest floor of the GPU backend: every pass is built on it.

use wgpu::util::DeviceExt;

use super::counted::{Counters, Encoder, RecordCounts};
use crate::cull::CullError;

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

impl From<GpuError> for CullError {
    fn from(e: GpuError) -> Self {
        CullError::Backend {
            backend: "GPU",
            message: e.to_string(),
        }
    }
}

/// Optional adapter features homcull uses where the adapter has them. Turning one
/// off exercises the path that adapters without it take (tests do).
#[derive(Debug, Clone, Copy)]
pub struct GpuOptions {
    /// See [`GpuDevice::indirect_draws`]; env `HOMCULL_NO_INDIRECT` turns it off.
    pub indirect_draws: bool,
    /// See [`GpuDevice::indirect_count`]; env `HOMCULL_NO_INDIRECT_COUNT` turns it off.
    pub indirect_count: bool,
    /// See [`GpuDevice::early_depth_test`]; env `HOMCULL_NO_EARLY_Z` turns it off.
    pub early_depth_test: bool,
}

impl GpuOptions {
    pub fn from_env() -> Self {
        GpuOptions {
            indirect_draws: std::env::var_os("HOMCULL_NO_INDIRECT").is_none(),
            indirect_count: std::env::var_os("HOMCULL_NO_INDIRECT_COUNT").is_none(),
            early_depth_test: std::env::var_os("HOMCULL_NO_EARLY_Z").is_none(),
        }
    }
}

/// The wgpu device and queue homcull renders with.
pub struct GpuDevice {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    /// All of a pose's draws go out as one `multi_draw_indexed_indirect` (needs
    /// indirect execution and a non-zero first instance in indirect draws); without
    /// it, one draw call per object.
    pub indirect_draws: bool,
    /// The refinement draws only the box test's survivors, compacted on the GPU and
    /// drawn with a count the GPU wrote (`multi_draw_indexed_indirect_count`, feature
    /// `MULTI_DRAW_INDIRECT_COUNT`); without it, every candidate with an instance count
    /// of 0 or 1.
    pub indirect_count: bool,
    /// The refinement tests its fragments against the occluders' own depth buffer
    /// before its fragment shader runs (`@early_depth_test(force)`, feature
    /// `SHADER_EARLY_DEPTH_TEST`); without it, the shader compares with the occlusion
    /// map (`crate::gpu::refine`).
    pub early_depth_test: bool,
    /// Timestamps can be written between passes (`TIMESTAMP_QUERY_INSIDE_ENCODERS`),
    /// so batches can be profiled pass by pass (`crate::gpu::profile`).
    pub timestamps: bool,
    /// What has been created and recorded ([`GpuDevice::counts`]).
    counters: Counters,
}

impl GpuDevice {
    /// Opens the adapter chosen by `WGPU_ADAPTER_NAME` / `WGPU_BACKEND` /
    /// `WGPU_POWER_PREF`, or the default one, using only the optional features
    /// `options` allows.
    pub fn with_options(options: GpuOptions) -> Result<Self, GpuError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        if std::env::var_os("WGPU_BACKEND").is_none() {
            // Vulkan/Metal/DX12 only: GL lacks what the passes need and its probe is noisy.
            desc.backends = wgpu::Backends::PRIMARY;
        }
        if !cfg!(windows) && std::env::var_os("WGPU_VALIDATION_INDIRECT_CALL").is_none() {
            // wgpu checks every indirect draw's arguments on the GPU in release builds:
            // per render pass a staging buffer, a copy, a dispatch and three barrier
            // sets, and host work per draw. Ours need none of it. Every argument is
            // written by `raster::indirect_draws` from the scene's own index ranges
            // (within the index buffer they were cut from), a non-zero first instance
            // comes with INDIRECT_FIRST_INSTANCE (required whenever indirect draws are
            // used), and no vertex buffer steps per instance. Kept on Windows: without
            // it DX12 leaves `first_instance` out of `@builtin(instance_index)`, which
            // the vertex stage reads as the object ID. `WGPU_VALIDATION_INDIRECT_CALL=1`
            // turns it back on.
            desc.flags
                .remove(wgpu::InstanceFlags::VALIDATION_INDIRECT_CALL);
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
        // Placements are read in the vertex stage (`gpu/scene_buffers.rs`).
        if !(adapter.get_downlevel_capabilities().flags)
            .contains(wgpu::DownlevelFlags::VERTEX_STORAGE)
        {
            return Err(GpuError::NoAdapter(format!(
                "adapter {} cannot read storage buffers in the vertex stage, which homcull needs",
                info.name
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
        let indirect_count = indirect_draws
            && options.indirect_count
            && adapter
                .features()
                .contains(wgpu::Features::MULTI_DRAW_INDIRECT_COUNT);
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
        if indirect_count {
            required_features |= wgpu::Features::MULTI_DRAW_INDIRECT_COUNT;
        }
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("homcull"),
            required_limits: limits,
            required_features,
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device(e.to_string()))?;
        Ok(GpuDevice {
            device,
            queue,
            info,
            indirect_draws,
            indirect_count,
            early_depth_test,
            timestamps,
            counters: Default::default(),
        })
    }

    /// What this device has created and recorded so far.
    pub fn counts(&self) -> RecordCounts {
        self.counters.snapshot()
    }

    pub(crate) fn buffer(&self, desc: &wgpu::BufferDescriptor<'_>) -> wgpu::Buffer {
        self.counters.buffer();
        self.device.create_buffer(desc)
    }

    pub(crate) fn buffer_init(
        &self,
        label: &str,
        contents: &[u8],
        usage: wgpu::BufferUsages,
    ) -> wgpu::Buffer {
        self.counters.buffer();
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
    }

    /// A bind group of `layout` with `resources` at bindings 0, 1, 2, …
    pub(crate) fn bind_group(
        &self,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        resources: Vec<wgpu::BindingResource<'_>>,
    ) -> wgpu::BindGroup {
        self.counters.bind_group();
        let entries: Vec<wgpu::BindGroupEntry> = resources
            .into_iter()
            .enumerate()
            .map(|(binding, resource)| wgpu::BindGroupEntry {
                binding: binding as u32,
                resource,
            })
            .collect();
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout,
            entries: &entries,
        })
    }

    /// A command encoder whose passes are counted.
    pub(crate) fn encoder(&self) -> Encoder<'_> {
        Encoder::new(
            self.device.create_command_encoder(&Default::default()),
            &self.counters,
        )
    }

    /// Submits what `encoder` recorded; the index lets a wait target this submission.
    pub(crate) fn submit(&self, encoder: Encoder<'_>) -> wgpu::SubmissionIndex {
        self.counters.submission();
        self.queue.submit([encoder.finish()])
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

    /// Compiles a kernel with the constants shared with Rust (`super::prelude`) and the
    /// definitions of `common.wgsl` prepended.
    pub fn shader(&self, label: &str, source: &str) -> wgpu::ShaderModule {
        let code = format!(
            "{}\n{}\n{}",
            super::prelude::wgsl(),
            include_str!("shaders/common.wgsl"),
            source
        );
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
