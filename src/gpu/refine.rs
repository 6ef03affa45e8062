//! Refinement of HOM's box test (`CullOptions::refine`): the objects that passed it are
//! rasterized once more, and each fragment that is not behind the occluders marks its
//! object visible. The box test's losses are almost all of this kind (report section
//! 1b, `crate::loss`): a box's screen rect covers pixels the object does not.
//!
//! Two steps per group of poses, after the test pass:
//! 1. `filter_draws` (compute, `refine.wgsl`) sets each indirect draw's instance count
//!    to 0 or 1 from the box test's bit, so only survivors are drawn;
//! 2. one render pass per pose with the occluder raster's own vertex stage (so coverage
//!    and depth match the occluder raster and the oracle), no colour target, writing a
//!    second bitmask. Where the adapter can force early depth tests (Vulkan, GL), the
//!    pass tests against the pose's occluder depth buffer (`fs_refine_early`,
//!    `GreaterEqual`, no writes): fragments behind the occluders never reach the
//!    shader, and a pixel the oracle gives to an object always passes, since the oracle
//!    keeps the nearest of a superset of the same fragments. Elsewhere every fragment
//!    runs `fs_refine`, which compares with the occlusion map and the box test's depth
//!    margin. CPU twin: `CpuBackend::refine` (the early-test comparison on the CPU
//!    rasterizer's own depths; all three are conservative and differ only on depth
//!    near-ties).

use super::raster::{DepthTest, DrawList, RasterPass, triangle_pipeline};
use super::scene_buffers::SceneBuffers;
use super::{GpuContext, UNIFORM_SLOT, record_wide, storage_entry, uniform_entry};

/// `FilterParams` in `refine.wgsl` and `RefineParams` in `raster.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RefineParams {
    pub a: u32,
    pub b: u32,
    pub words_per_pose: u32,
    pub _pad: u32,
}

pub struct RefinePass {
    pub filter_layout: wgpu::BindGroupLayout,
    filter: wgpu::ComputePipeline,
    pub raster_layout: wgpu::BindGroupLayout,
    raster: wgpu::RenderPipeline,
}

/// Workgroup size of `filter_draws`.
const WG: u32 = 64;

impl RefinePass {
    pub fn new(ctx: &GpuContext, raster: &RasterPass) -> Self {
        let device = &ctx.device;
        let module = ctx.shader("refine", include_str!("shaders/refine.wgsl"));
        let (filter_layout, filter_pl) = ctx.compute_layout(
            "refine filter",
            &[
                uniform_entry(0, true, wgpu::ShaderStages::COMPUTE),
                storage_entry(1, true),
                storage_entry(2, true),
                storage_entry(3, false),
            ],
        );
        let filter = ctx.compute_pipeline(&filter_pl, &module, "filter_draws");

        let fragment = |binding, ty| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty,
            count: None,
        };
        let storage = |read_only| wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        };
        let raster_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("refine raster"),
            entries: &[
                fragment(
                    0,
                    wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                ),
                fragment(1, storage(true)),
                fragment(2, storage(false)),
                uniform_entry(3, true, wgpu::ShaderStages::FRAGMENT),
            ],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("refine raster"),
            bind_group_layouts: &[Some(&raster.pose_layout), Some(&raster_layout)],
            immediate_size: 0,
        });
        // Tested against the occluders' depth only, never against the other refined
        // objects (no depth writes).
        let (fs, depth) = if ctx.early_depth_test {
            ("fs_refine_early", DepthTest::NotBehind)
        } else {
            ("fs_refine", DepthTest::Off)
        };
        let pipeline = triangle_pipeline(device, &layout, &raster.module, fs, &[], depth);
        RefinePass {
            filter_layout,
            filter,
            raster_layout,
            raster: pipeline,
        }
    }

    /// Records the filter of `count` draws of one group (its params slot `group`).
    pub fn record_filter(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        bind_group: &wgpu::BindGroup,
        group: u32,
        count: u32,
    ) {
        record_wide(
            encoder,
            "refine filter",
            &self.filter,
            bind_group,
            group,
            count,
            WG,
        );
    }

    /// Records one pose's refinement raster (`refine` bound with its params slot `pose`)
    /// on `depth`, the pose's occluder depth layer.
    #[allow(clippy::too_many_arguments)]
    pub fn record_raster(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        depth: &wgpu::TextureView,
        poses: &wgpu::BindGroup,
        refine: &wgpu::BindGroup,
        pose: u32,
        scene: &SceneBuffers,
        draws: DrawList<'_>,
    ) {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("refine raster"),
            color_attachments: &[],
            // The occluder depth is read, not written, and not needed afterwards.
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.raster);
        let offset = (pose as u64 * UNIFORM_SLOT) as u32;
        pass.set_bind_group(0, poses, &[offset]);
        pass.set_bind_group(1, refine, &[offset]);
        RasterPass::draw(&mut pass, scene, draws);
    }
}
