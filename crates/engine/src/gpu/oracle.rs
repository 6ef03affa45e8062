//! Exact oracle, second half: reads the ID buffers of a group of poses and sets the
//! visibility bit of every object that owns at least one pixel.
//! CPU twin: `reference/oracle.rs` (`reference::raster::raster_ids` plus a scan of the ID buffer).

use super::arena::{BindCache, GrowBuffer, Upload};
use super::counted::ComputePass;
use super::device::GpuDevice;
use super::encode::{
    record_grid, slotted, storage_entry, texture_entry, uniform_entry, uniform_slot,
};
use super::targets::SlotTargets;

/// `CollectParams` in `oracle.wgsl`: one group's poses in the ID atlas, a uniform slot
/// per group.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CollectParams {
    pub width: u32,
    pub height: u32,
    pub words_per_pose: u32,
    /// The group's first pose (its slot 0).
    pub first_pose: u32,
    /// Slots per atlas row.
    pub atlas_cols: u32,
    pub _pad: [u32; 3],
}

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
                texture_entry(1, wgpu::TextureSampleType::Uint),
                storage_entry(2, false),
            ],
        );
        let pipeline = ctx.compute_pipeline(&pl, &module, "collect");
        OraclePass { layout, pipeline }
    }

    /// Records the collect dispatch of one group (`group` = its params slot).
    pub(crate) fn record(
        &self,
        pass: &mut ComputePass<'_>,
        bind_group: &wgpu::BindGroup,
        group: u32,
        width: u32,
        height: u32,
        slots: u32,
    ) {
        record_grid(
            pass,
            &self.pipeline,
            bind_group,
            group,
            width,
            height,
            slots,
        );
    }
}

/// The collect pass's per-group params and bind group, kept between batches.
pub(crate) struct OracleInputs {
    params: GrowBuffer,
    bind: BindCache,
}

impl OracleInputs {
    pub(crate) fn new() -> Self {
        OracleInputs {
            params: GrowBuffer::new("collect params", wgpu::BufferUsages::UNIFORM),
            bind: BindCache::default(),
        }
    }

    /// Writes the params of `groups` and makes (or keeps) the bind group on `t`'s ID
    /// atlas (made here on first use) and the visibility `mask`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn prepare(
        &mut self,
        gpu: &GpuDevice,
        upload: &mut Upload,
        pass: &OraclePass,
        t: &SlotTargets,
        groups: &[(u32, u32)],
        words_per_pose: u32,
        mask: &GrowBuffer,
    ) {
        let params: Vec<CollectParams> = groups
            .iter()
            .map(|&(a, _)| CollectParams {
                width: t.width,
                height: t.height,
                words_per_pose,
                first_pose: a,
                atlas_cols: t.cols,
                _pad: [0; 3],
            })
            .collect();
        self.params.write(gpu, upload, &slotted(&params));
        let ids = t.ids(&gpu.device);
        let key = [t.generation, self.params.id(), mask.id()];
        let OracleInputs { params, bind } = self;
        bind.get(&key, || {
            gpu.bind_group(
                "oracle",
                &pass.layout,
                vec![
                    uniform_slot::<CollectParams>(params.get()),
                    wgpu::BindingResource::TextureView(&ids.view),
                    mask.get().as_entire_binding(),
                ],
            )
        });
    }

    /// The bind group of the last [`OracleInputs::prepare`].
    pub(crate) fn bind_group(&self) -> &wgpu::BindGroup {
        self.bind.current()
    }
}
