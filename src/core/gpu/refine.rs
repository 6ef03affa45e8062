//! Refinement of HOM's box test (`CullOptions::refine`): the objects that passed it are
//! rasterized once more, and each fragment that is not behind the occluders marks its
//! object visible. The box test's losses are almost all of this kind (report section
//! 1b, `crate::eval::loss`): a box's screen rect covers pixels the object does not.
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
//!    margin. CPU twin: `hom::refine::refine` (the early-test comparison on the CPU
//!    rasterizer's own depths; all three are conservative and differ only on depth
//!    near-ties).

use wgpu::util::DeviceExt;

use super::device::GpuDevice;
use super::encode::{
    UNIFORM_SLOT, record_wide, slotted, storage_buffer, storage_entry, uniform_entry, uniform_slot,
};
use super::raster::{
    DepthTest, DrawList, RasterPass, indirect_draws, object_draws, triangle_pipeline,
};
use super::scene_buffers::SceneBuffers;
use crate::core::cull::PosePlan;

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
    pub fn new(ctx: &GpuDevice, raster: &RasterPass) -> Self {
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

/// The refinement's draws: indirect (filtered on the GPU) or one call per candidate.
pub(crate) enum RefineDraws {
    Indirect {
        buffer: wgpu::Buffer,
        ranges: Vec<(u32, u32)>,
        filter_bg: wgpu::BindGroup,
    },
    Direct(Vec<Vec<(u32, u32, u32)>>),
}

/// What the refinement of one batch records with.
pub(crate) struct RefineBatch {
    draws: RefineDraws,
    /// Indirect draws per group (for the filter dispatch).
    group_draws: Vec<u32>,
    pub(crate) refined: wgpu::Buffer,
    raster_bg: wgpu::BindGroup,
}

impl RefineBatch {
    /// Buffers and bind groups of the refinement pass for a batch: every pose's
    /// candidates as draws (filtered on the GPU to the box test's survivors when draws
    /// are indirect), the second bitmask, and per-pose and per-group params.
    /// `object_ranges` holds every object's `(first_index, index_count)`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        gpu: &GpuDevice,
        pass: &RefinePass,
        object_ranges: &[(u32, u32)],
        plans: &[PosePlan],
        groups: &[(u32, u32)],
        box_mask: &wgpu::Buffer,
        occlusion: &wgpu::TextureView,
        words: u32,
    ) -> Self {
        let device = &gpu.device;
        let draws = plans
            .iter()
            .map(|p| object_draws(object_ranges, &p.candidates));
        let mut group_draws = Vec::new();
        let draws = if gpu.indirect_draws {
            let (buffer, ranges) = indirect_draws(device, draws, wgpu::BufferUsages::STORAGE);
            let draw_pose: Vec<u32> = ranges
                .iter()
                .enumerate()
                .flat_map(|(p, &(_, n))| std::iter::repeat_n(p as u32, n as usize))
                .collect();
            let params: Vec<RefineParams> = groups
                .iter()
                .map(|&(a, b)| {
                    let first = ranges[a as usize].0;
                    let (last, n) = ranges[b as usize - 1];
                    RefineParams {
                        a: first,
                        b: last + n - first,
                        words_per_pose: words,
                        _pad: 0,
                    }
                })
                .collect();
            group_draws = params.iter().map(|p| p.b).collect();
            let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("refine filter params"),
                contents: &slotted(&params),
                usage: wgpu::BufferUsages::UNIFORM,
            });
            let draw_pose = storage_buffer(device, "draw pose", bytemuck::cast_slice(&draw_pose));
            let filter_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("refine filter"),
                layout: &pass.filter_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: uniform_slot(&params),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: box_mask.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: draw_pose.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: buffer.as_entire_binding(),
                    },
                ],
            });
            RefineDraws::Indirect {
                buffer,
                ranges,
                filter_bg,
            }
        } else {
            RefineDraws::Direct(draws.collect())
        };
        let refined = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("refined visibility mask"),
            size: (plans.len() as u32 * words) as u64 * 4,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let pose_params: Vec<RefineParams> = groups
            .iter()
            .flat_map(|&(a, b)| {
                (a..b).map(move |p| RefineParams {
                    a: p - a,
                    b: p,
                    words_per_pose: words,
                    _pad: 0,
                })
            })
            .collect();
        let pose_params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("refine params"),
            contents: &slotted(&pose_params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let raster_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("refine raster"),
            layout: &pass.raster_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(occlusion),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: box_mask.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: refined.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: uniform_slot(&pose_params),
                },
            ],
        });
        RefineBatch {
            draws,
            group_draws,
            refined,
            raster_bg,
        }
    }

    /// Records the refinement of poses `range` (group `g`), after its test pass.
    /// `depth` holds the per-slot occluder depth targets of the group.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn record(
        &self,
        pass: &RefinePass,
        encoder: &mut wgpu::CommandEncoder,
        depth: &[wgpu::TextureView],
        pose_bg: &wgpu::BindGroup,
        scene: &SceneBuffers,
        g: usize,
        range: std::ops::Range<u32>,
    ) {
        let r = self;
        if let RefineDraws::Indirect { filter_bg, .. } = &r.draws {
            pass.record_filter(encoder, filter_bg, g as u32, r.group_draws[g]);
        }
        let first = range.start;
        for p in range {
            let draws = match &r.draws {
                RefineDraws::Indirect { buffer, ranges, .. } => {
                    let (first, count) = ranges[p as usize];
                    DrawList::Indirect(buffer, first, count)
                }
                RefineDraws::Direct(lists) => DrawList::Direct(lists[p as usize].clone()),
            };
            pass.record_raster(
                encoder,
                &depth[(p - first) as usize],
                pose_bg,
                &r.raster_bg,
                p,
                scene,
                draws,
            );
        }
    }
}
