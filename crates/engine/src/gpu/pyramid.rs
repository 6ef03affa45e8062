//! Occlusion pyramid pass: two levels per dispatch (`pyramid.wgsl`), every pose slot
//! of a group at once (z = slot, level 0 read from the slot's rectangle of the atlas), so a 960×540 pyramid of 11 levels takes five
//! dispatches. Level 0 stays in the raster texture, which the test pass reads; the
//! pyramid buffers hold levels 1.. only ([`buffer_levels`]: three quarters of the
//! pixels' worth of memory less per slot than the CPU layout, which keeps level 0).
//! CPU twin: `hom/pyramid.rs`; layout shared through [`LevelLayout`].

use super::counted::ComputePass;
use super::device::GpuDevice;
use super::encode::{record_grid, slotted, storage_entry, texture_entry, uniform_entry};
use crate::reference::{MAX_LEVELS, pyramid::LevelLayout};

/// Levels one dispatch writes after the one it reads.
const LEVELS_PER_STEP: usize = 2;

/// `Step` in `pyramid.wgsl`: the level a dispatch reads.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Step {
    src_level: u32,
    _pad: [u32; 3],
}

/// `Levels` in `pyramid.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Levels {
    count: u32,
    slot_stride: u32,
    /// Slots per atlas row ([`super::targets::SlotTargets::cols`]).
    atlas_cols: u32,
    _pad: u32,
    dims: [[u32; 4]; MAX_LEVELS],
}

/// Levels 1.. of `layout` as the GPU buffers hold them: `[width, height, offset, 0]`
/// per level (offsets counted from level 1; level 0's is unused, it is read from the
/// occlusion map), and the per-pose stride in texels (at least 1, so that a 1×1
/// viewport still gets a buffer).
pub(crate) fn buffer_levels(layout: &LevelLayout) -> ([[u32; 4]; MAX_LEVELS], u32) {
    let level0 = layout.dims[0].0 * layout.dims[0].1;
    let mut dims = [[0; 4]; MAX_LEVELS];
    for (l, d) in dims.iter_mut().enumerate().take(layout.levels()) {
        let offset = if l == 0 {
            0
        } else {
            layout.offsets[l] - level0
        };
        *d = [layout.dims[l].0, layout.dims[l].1, offset, 0];
    }
    (dims, (layout.total - level0).max(1))
}

/// The levels each dispatch reads: 0, 2, 4, … while a level follows.
fn steps(layout: &LevelLayout) -> Vec<Step> {
    (0..layout.levels() - 1)
        .step_by(LEVELS_PER_STEP)
        .map(|l| Step {
            src_level: l as u32,
            _pad: [0; 3],
        })
        .collect()
}

pub struct PyramidPass {
    layout: wgpu::BindGroupLayout,
    downsample: wgpu::ComputePipeline,
}

impl PyramidPass {
    pub fn new(ctx: &GpuDevice) -> Self {
        let module = ctx.shader("pyramid", include_str!("shaders/pyramid.wgsl"));
        let (layout, pl) = ctx.compute_layout(
            "pyramid",
            &[
                uniform_entry(0, true, wgpu::ShaderStages::COMPUTE),
                storage_entry(1, false),
                storage_entry(2, false),
                texture_entry(3, wgpu::TextureSampleType::Float { filterable: false }),
                uniform_entry(4, false, wgpu::ShaderStages::COMPUTE),
            ],
        );
        PyramidPass {
            downsample: ctx.compute_pipeline(&pl, &module, "downsample"),
            layout,
        }
    }

    /// The bind group of the pyramid of `layout` in `opacity` and `depth`
    /// (slot-strided), built from the occlusion atlas `raster` (`atlas_cols` slots a row).
    pub(crate) fn bind_group(
        &self,
        gpu: &GpuDevice,
        layout: &LevelLayout,
        atlas_cols: u32,
        opacity: &wgpu::Buffer,
        depth: &wgpu::Buffer,
        raster: &wgpu::TextureView,
    ) -> wgpu::BindGroup {
        let (dims, slot_stride) = buffer_levels(layout);
        let levels = Levels {
            count: layout.levels() as u32,
            slot_stride,
            atlas_cols,
            _pad: 0,
            dims,
        };
        let usage = wgpu::BufferUsages::UNIFORM;
        let steps = gpu.buffer_init("pyramid steps", &slotted(&steps(layout)), usage);
        let levels = gpu.buffer_init("pyramid levels", bytemuck::bytes_of(&levels), usage);
        gpu.bind_group(
            "pyramid",
            &self.layout,
            vec![
                wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &steps,
                    offset: 0,
                    size: wgpu::BufferSize::new(std::mem::size_of::<Step>() as u64),
                }),
                opacity.as_entire_binding(),
                depth.as_entire_binding(),
                wgpu::BindingResource::TextureView(raster),
                levels.as_entire_binding(),
            ],
        )
    }

    /// Records every level for `slots` poses with a bind group from
    /// [`PyramidPass::bind_group`] for the same `layout`.
    pub(crate) fn record(
        &self,
        pass: &mut ComputePass<'_>,
        bind_group: &wgpu::BindGroup,
        layout: &LevelLayout,
        slots: u32,
    ) {
        for (k, step) in steps(layout).iter().enumerate() {
            // One invocation per 2×2 texels of the first level written.
            let (w, h) = layout.dims[step.src_level as usize + 1];
            let (w, h) = (w.div_ceil(2), h.div_ceil(2));
            record_grid(pass, &self.downsample, bind_group, k as u32, w, h, slots);
        }
    }
}
