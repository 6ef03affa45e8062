//! Exact oracle, second half: reads the ID buffers of a group of poses and sets the
//! visibility bit of every object that owns at least one pixel.
//! CPU twin: `hom/oracle.rs` (`hom::raster::raster_ids` plus a scan of the ID buffer).

use super::device::GpuDevice;
use super::encode::{record_grid, storage_entry, texture_array_entry, uniform_entry};

pub struct OraclePass {
    pub layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
}

impl OraclePass {
    pub fn new(ctx: &GpuDevice) -> Self {
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
        record_grid(
            encoder,
            "oracle collect",
            &self.pipeline,
            bind_group,
            group,
            width,
            height,
            slots,
        );
    }
}
