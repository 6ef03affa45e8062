//! Per-object test pass: one invocation per (pose, test box), HOM or HZB, writing
//! one visibility bit per object and pose. CPU twin: `hom/test.rs`.

use homcull_proto::{DebVariant, Method};

use super::device::GpuDevice;
use super::encode::{record_wide, storage_entry, texture_array_entry, uniform_entry};
use super::pyramid::buffer_levels;
use crate::core::hom::{MAX_LEVELS, pyramid::LevelLayout};

/// `TestConfig` in `test.wgsl`: what is the same for every pose of a batch.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TestConfig {
    pub levels: u32,
    pub method: u32,
    pub deb: u32,
    pub deb_tile: u32,
    pub deb_cols: u32,
    pub deb_rows: u32,
    pub words_per_pose: u32,
    pub slot_stride: u32,
    pub dims: [[u32; 4]; MAX_LEVELS],
    pub thresholds: [[f32; 4]; MAX_LEVELS],
}

impl TestConfig {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        method: Method,
        deb: DebVariant,
        layout: &LevelLayout,
        thresholds: &[f32],
        deb_tile: u32,
        deb_cols: u32,
        deb_rows: u32,
        words_per_pose: u32,
    ) -> Self {
        let (dims, slot_stride) = buffer_levels(layout);
        let mut thr = [[0.0; 4]; MAX_LEVELS];
        for (t, &o) in thr.iter_mut().zip(thresholds).take(layout.levels()) {
            t[0] = o;
        }
        TestConfig {
            levels: layout.levels() as u32,
            method: (method == Method::Hzb) as u32,
            deb: match deb {
                DebVariant::Plane => 0,
                DebVariant::Tiles => 1,
                DebVariant::Raster => 2,
            },
            deb_tile,
            deb_cols,
            deb_rows,
            words_per_pose,
            slot_stride,
            dims,
            thresholds: thr,
        }
    }
}

/// `GroupParams` in `test.wgsl` (also used by the oracle collect pass).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GroupParams {
    pub a: u32,
    pub b: u32,
    pub c: u32,
    pub d: u32,
}

pub struct TestPass {
    pub layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
}

/// Workgroup size of the test kernel.
const WG: u32 = 64;

impl TestPass {
    pub fn new(ctx: &GpuDevice) -> Self {
        let module = ctx.shader("test", include_str!("shaders/test.wgsl"));
        let entries: Vec<_> = [
            uniform_entry(0, false, wgpu::ShaderStages::COMPUTE),
            uniform_entry(1, true, wgpu::ShaderStages::COMPUTE),
        ]
        .into_iter()
        .chain((2..=7).map(|b| storage_entry(b, true)))
        .chain([
            storage_entry(8, false),
            texture_array_entry(9, wgpu::TextureSampleType::Float { filterable: false }),
        ])
        .collect();
        let (layout, pl) = ctx.compute_layout("test", &entries);
        let pipeline = ctx.compute_pipeline(&pl, &module, "main");
        TestPass { layout, pipeline }
    }

    /// Records the test of `count` candidates of group `group` (its params slot).
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        bind_group: &wgpu::BindGroup,
        group: u32,
        count: u32,
    ) {
        record_wide(
            encoder,
            "object test",
            &self.pipeline,
            bind_group,
            group,
            count,
            WG,
        );
    }
}
