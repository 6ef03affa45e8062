//! Exact oracle, second half: reads the ID buffers of a group of poses and sets the
//! visibility bit of every object that owns at least one pixel.
//! CPU twin: `hom::raster::raster_ids` plus a scan in `cull.rs`.

use super::{GpuContext, UNIFORM_SLOT, storage_entry, texture_array_entry, uniform_entry};

pub struct OraclePass {
    pub layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
}

impl OraclePass {
    pub fn new(ctx: &GpuContext) -> Self {
        let module = ctx.shader("oracle", include_str!("shaders/oracle.wgsl"));
        let (layout, pl) = ctx.compute_layout(
            "oracle",
            &[
                uniform_entry(0, true, wgpu::ShaderStages::COMPUTE),
                texture_array_entry(1, wgpu::TextureSampleType::Uint),
                storage_entry(2, false),
            ],
        );
        let pipeline = ctx.compute_pipeline(&pl, &module, "collect");
        OraclePass { layout, pipeline }
    }

    /// Records the collect dispatch of one group (`group` = its params slot).
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        bind_group: &wgpu::BindGroup,
        group: u32,
        width: u32,
        height: u32,
        slots: u32,
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("oracle collect"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, bind_group, &[(group as u64 * UNIFORM_SLOT) as u32]);
        pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), slots);
    }
}
