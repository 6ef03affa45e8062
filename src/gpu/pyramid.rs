//! Occlusion pyramid pass: level 0 from the occluder raster, then one 2×2 reduction
//! dispatch per level, for every pose slot of a group at once (z = slot).
//! CPU twin: `hom/pyramid.rs`; layout shared through [`LevelLayout`].

use super::{GpuContext, UNIFORM_SLOT, storage_entry, texture_array_entry, uniform_entry};
use crate::hom::pyramid::LevelLayout;

/// Per-level parameters (`LevelParams` in `pyramid.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LevelParams {
    pub src_offset: u32,
    pub dst_offset: u32,
    pub src_w: u32,
    pub src_h: u32,
    pub dst_w: u32,
    pub dst_h: u32,
    pub slot_stride: u32,
    pub _pad: u32,
}

impl LevelParams {
    /// Parameters of every level; entry 0 is the level-0 fill.
    pub fn for_layout(layout: &LevelLayout) -> Vec<LevelParams> {
        (0..layout.levels())
            .map(|l| {
                let (dst_w, dst_h) = layout.dims[l];
                let (src_w, src_h) = if l == 0 {
                    (dst_w, dst_h)
                } else {
                    layout.dims[l - 1]
                };
                LevelParams {
                    src_offset: if l == 0 { 0 } else { layout.offsets[l - 1] },
                    dst_offset: layout.offsets[l],
                    src_w,
                    src_h,
                    dst_w,
                    dst_h,
                    slot_stride: layout.total,
                    _pad: 0,
                }
            })
            .collect()
    }
}

pub struct PyramidPass {
    pub layout: wgpu::BindGroupLayout,
    level0: wgpu::ComputePipeline,
    reduce: wgpu::ComputePipeline,
}

impl PyramidPass {
    pub fn new(ctx: &GpuContext) -> Self {
        let module = ctx.shader("pyramid", include_str!("shaders/pyramid.wgsl"));
        let (layout, pl) = ctx.compute_layout(
            "pyramid",
            &[
                uniform_entry(0, true, wgpu::ShaderStages::COMPUTE),
                storage_entry(1, false),
                storage_entry(2, false),
                texture_array_entry(3, wgpu::TextureSampleType::Float { filterable: false }),
            ],
        );
        let pipeline = |entry| ctx.compute_pipeline(&pl, &module, entry);
        PyramidPass {
            level0: pipeline("level0"),
            reduce: pipeline("reduce"),
            layout,
        }
    }

    /// Records level 0 and every reduction for `slots` poses. `bind_group` binds the
    /// level-parameter slots, the pyramid buffers and the raster texture array.
    pub fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        bind_group: &wgpu::BindGroup,
        layout: &LevelLayout,
        slots: u32,
    ) {
        for l in 0..layout.levels() {
            let (w, h) = layout.dims[l];
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("pyramid level"),
                timestamp_writes: None,
            });
            pass.set_pipeline(if l == 0 { &self.level0 } else { &self.reduce });
            pass.set_bind_group(0, bind_group, &[(l as u64 * UNIFORM_SLOT) as u32]);
            pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), slots);
        }
    }
}
