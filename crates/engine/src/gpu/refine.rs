//! Refinement of HOM's box test (`CullOptions::refine`): the objects that passed it are
//! rasterized once more, and each fragment that is not behind the occluders marks its
//! object visible. The box test's losses are almost all of this kind (report section
//! 1b, `loss.rs` of homcull-eval): a box's screen rect covers pixels the object does not.
//!
//! Two steps per group of poses, after the test pass:
//! 1. `filter_draws` (compute, `refine.wgsl`) expands each candidate `(pose, object)`
//!    into its draw from the scene's index ranges: where the adapter draws with an
//!    indirect count, only the box test's survivors, appended to their pose's region
//!    and counted, so the raster issues only survivors; elsewhere every candidate with
//!    an instance count of 0 or 1;
//! 2. one render pass over the group's atlas (each pose in its slot: viewport, scissor
//!    and uniform offsets) with the occluder raster's own vertex stage (so coverage and
//!    depth match the occluder raster and the oracle), no colour target, writing a
//!    second bitmask. Where the adapter can force early depth tests (Vulkan, GL), the
//!    pass tests against the pose's occluder depth buffer (`fs_refine_early`,
//!    `GreaterEqual`, no writes): fragments behind the occluders never reach the
//!    shader, and a pixel the oracle gives to an object always passes, since the oracle
//!    keeps the nearest of a superset of the same fragments. Elsewhere every fragment
//!    runs `fs_refine`, which compares with the occlusion map and the box test's depth
//!    margin. CPU twin: `reference::refine::refine` (the early-test comparison on the CPU
//!    rasterizer's own depths; all three are conservative and differ only on depth
//!    near-ties).

use super::arena::{BindCache, GrowBuffer, Upload};
use super::counted::{ComputePass, Encoder};
use super::device::GpuDevice;
use super::encode::{
    UNIFORM_SLOT, record_wide, slotted, storage_entry, uniform_entry, uniform_slot,
};
use super::prelude::MOVING_OBJECT;
use super::raster::{
    DRAW_ARGS_BYTES, DepthTest, DrawList, RasterPass, object_draws, triangle_pipeline,
};
use super::scene_buffers::SceneBuffers;
use super::targets::{DepthUse, SlotTargets};
use crate::cull::{PosePlan, has_bit};

/// `FilterParams` in `refine.wgsl`: one group's indirect draws, a uniform slot each.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct FilterParams {
    pub first_draw: u32,
    pub draw_count: u32,
    pub words_per_pose: u32,
    /// 1: survivors appended to their pose's region and counted.
    pub compact: u32,
}

/// `RefineParams` in `raster.wgsl`: one pose, a uniform slot each.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RefineParams {
    /// The pose's index in the batch (its region of the bitmasks).
    pub pose: u32,
    pub words_per_pose: u32,
    pub _pad: [u32; 2],
}

pub struct RefinePass {
    pub filter_layout: wgpu::BindGroupLayout,
    filter: wgpu::ComputePipeline,
    pub raster_layout: wgpu::BindGroupLayout,
    raster: wgpu::RenderPipeline,
}

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
                storage_entry(3, true),
                storage_entry(4, true),
                storage_entry(5, false),
                storage_entry(6, false),
                storage_entry(7, false),
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
                        view_dimension: wgpu::TextureViewDimension::D2,
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
}

/// The refinement's inputs and bind groups, kept between batches (`super::arena`):
/// every pose's candidates as `(pose, object)` pairs, expanded on the GPU into the
/// draws of the box test's survivors (or, where indirect draws are missing, one call
/// per candidate), the second bitmask, and the per-group and per-pose params.
pub(crate) struct RefineInputs {
    /// `[pose, object]` of every candidate with triangles, pose after pose.
    draw_objects: GrowBuffer,
    /// Per pose: its first entry in `draw_objects` (and its region of `draws`).
    pose_first: GrowBuffer,
    /// The draws, written by the filter.
    draws: GrowBuffer,
    /// Per pose: survivors appended to its region (when compacting).
    pub(crate) counts: GrowBuffer,
    filter_params: GrowBuffer,
    pose_params: GrowBuffer,
    pub(crate) refined: GrowBuffer,
    /// Per pose: `(first, count)` in `draw_objects`.
    ranges: Vec<(u32, u32)>,
    /// Per pose: its direct draws (without indirect draws).
    direct: Vec<Vec<(u32, u32, u32)>>,
    /// Candidates per group (for the filter dispatch).
    group_draws: Vec<u32>,
    filter_bind: BindCache,
    raster_bind: BindCache,
    indirect: bool,
    /// Survivors are compacted and drawn with a GPU-written count.
    compact: bool,
    /// Bytes of the refined bitmask this batch.
    mask_bytes: u64,
    poses: u32,
    /// Poses `pose_params` holds (its contents depend only on the pose index and the
    /// scene's words per pose, so a batch writes them only when it has more poses).
    params_poses: u32,
}

impl RefineInputs {
    pub(crate) fn new() -> Self {
        let storage = wgpu::BufferUsages::STORAGE;
        let uniform = wgpu::BufferUsages::UNIFORM;
        let indirect = wgpu::BufferUsages::INDIRECT;
        RefineInputs {
            draw_objects: GrowBuffer::new("refine candidates", storage),
            pose_first: GrowBuffer::new("refine pose first draw", storage),
            draws: GrowBuffer::new("refine draws", indirect | storage),
            counts: GrowBuffer::new(
                "refine draw counts",
                indirect | storage | wgpu::BufferUsages::COPY_SRC,
            ),
            filter_params: GrowBuffer::new("refine filter params", uniform),
            pose_params: GrowBuffer::new("refine params", uniform),
            refined: GrowBuffer::new(
                "refined visibility mask",
                storage | wgpu::BufferUsages::COPY_SRC,
            ),
            ranges: Vec::new(),
            direct: Vec::new(),
            group_draws: Vec::new(),
            filter_bind: BindCache::default(),
            raster_bind: BindCache::default(),
            indirect: false,
            compact: false,
            mask_bytes: 0,
            poses: 0,
            params_poses: 0,
        }
    }

    /// Writes a batch's refinement inputs and binds them on `t` with the box test's
    /// bitmask `box_mask`. `object_ranges` holds every object's `(first_index,
    /// index_count)`, `moving` the bitmask of moving objects (empty: none), which
    /// are answered by the box test alone.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn write(
        &mut self,
        gpu: &GpuDevice,
        upload: &mut Upload,
        pass: &RefinePass,
        t: &SlotTargets,
        scene: &SceneBuffers,
        moving: &[u32],
        object_ranges: &[(u32, u32)],
        plans: &[PosePlan],
        groups: &[(u32, u32)],
        box_mask: &GrowBuffer,
        words: u32,
    ) {
        self.indirect = gpu.indirect_draws;
        self.compact = gpu.indirect_count;
        let is_moving = |id: u32| !moving.is_empty() && has_bit(moving, id);
        self.poses = plans.len() as u32;
        self.group_draws.clear();
        if self.indirect {
            let mut pairs: Vec<[u32; 2]> = Vec::new();
            self.ranges.clear();
            for (p, plan) in plans.iter().enumerate() {
                let first = pairs.len() as u32;
                let drawn = plan
                    .candidates
                    .iter()
                    .filter(|&&id| object_ranges[id as usize].1 > 0);
                // Moving objects are flagged: the filter answers them from the box test.
                let flagged = |id: u32| {
                    if is_moving(id) {
                        id | MOVING_OBJECT
                    } else {
                        id
                    }
                };
                pairs.extend(drawn.map(|&id| [p as u32, flagged(id)]));
                self.ranges.push((first, pairs.len() as u32 - first));
            }
            let params: Vec<FilterParams> = groups
                .iter()
                .map(|&(a, b)| {
                    let first = self.ranges[a as usize].0;
                    let (last, n) = self.ranges[b as usize - 1];
                    FilterParams {
                        first_draw: first,
                        draw_count: last + n - first,
                        words_per_pose: words,
                        compact: self.compact as u32,
                    }
                })
                .collect();
            self.group_draws.extend(params.iter().map(|p| p.draw_count));
            self.filter_params.write(gpu, upload, &slotted(&params));
            self.draw_objects
                .write(gpu, upload, bytemuck::cast_slice(&pairs));
            let firsts: Vec<u32> = self.ranges.iter().map(|r| r.0).collect();
            self.pose_first
                .write(gpu, upload, bytemuck::cast_slice(&firsts));
            self.draws
                .reserve(gpu, pairs.len() as u64 * DRAW_ARGS_BYTES);
            self.counts.reserve(gpu, self.poses as u64 * 4);
        } else {
            // Moving objects are not drawn: `GpuBackend` answers them.
            let still = |p: &PosePlan| -> Vec<u32> {
                let ids = p.candidates.iter().copied();
                ids.filter(|&id| !is_moving(id)).collect()
            };
            self.direct = plans
                .iter()
                .map(|p| object_draws(object_ranges, &still(p)))
                .collect();
        }
        self.mask_bytes = (plans.len() as u32 * words) as u64 * 4;
        self.refined.reserve(gpu, self.mask_bytes);
        if self.poses > self.params_poses {
            let pose_params: Vec<RefineParams> = (0..self.poses)
                .map(|pose| RefineParams {
                    pose,
                    words_per_pose: words,
                    _pad: [0; 2],
                })
                .collect();
            self.pose_params.write(gpu, upload, &slotted(&pose_params));
            self.params_poses = self.poses;
        }
        self.bind(gpu, pass, t, scene, box_mask);
    }

    /// Makes (or keeps) the filter's and the raster's bind groups.
    fn bind(
        &mut self,
        gpu: &GpuDevice,
        pass: &RefinePass,
        t: &SlotTargets,
        scene: &SceneBuffers,
        mask: &GrowBuffer,
    ) {
        let RefineInputs {
            draw_objects,
            pose_first,
            draws,
            counts,
            filter_params,
            pose_params,
            refined,
            filter_bind,
            raster_bind,
            indirect,
            ..
        } = self;
        if *indirect {
            let key = [
                mask.id(),
                draw_objects.id(),
                pose_first.id(),
                draws.id(),
                counts.id(),
                filter_params.id(),
                refined.id(),
            ];
            filter_bind.get(&key, || {
                gpu.bind_group(
                    "refine filter",
                    &pass.filter_layout,
                    vec![
                        uniform_slot::<FilterParams>(filter_params.get()),
                        mask.get().as_entire_binding(),
                        draw_objects.get().as_entire_binding(),
                        scene.objects.as_entire_binding(),
                        pose_first.get().as_entire_binding(),
                        draws.get().as_entire_binding(),
                        counts.get().as_entire_binding(),
                        refined.get().as_entire_binding(),
                    ],
                )
            });
        }
        let key = [t.generation, mask.id(), refined.id(), pose_params.id()];
        raster_bind.get(&key, || {
            gpu.bind_group(
                "refine raster",
                &pass.raster_layout,
                vec![
                    wgpu::BindingResource::TextureView(&t.occlusion.view),
                    mask.get().as_entire_binding(),
                    refined.get().as_entire_binding(),
                    uniform_slot::<RefineParams>(pose_params.get()),
                ],
            )
        });
    }

    /// Clears the refined bitmask and the draw counts (before the batch's first group).
    pub(crate) fn clear(&self, encoder: &mut Encoder<'_>) {
        encoder
            .raw
            .clear_buffer(self.refined.get(), 0, Some(self.mask_bytes));
        if self.compact {
            let bytes = self.poses as u64 * 4;
            encoder.raw.clear_buffer(self.counts.get(), 0, Some(bytes));
        }
    }

    /// Whether the last batch compacted its draws (so [`RefineInputs::counts`] holds
    /// the draws each pose issued).
    pub(crate) fn compacted(&self) -> bool {
        self.indirect && self.compact
    }

    /// Records group `g`'s filter dispatch (after its box test, in the same compute
    /// pass): the draws of the box test's survivors.
    pub(crate) fn record_filter(&self, pass: &RefinePass, cp: &mut ComputePass<'_>, g: usize) {
        if self.indirect {
            let filter_bg = self.filter_bind.current();
            record_wide(cp, &pass.filter, filter_bg, g as u32, self.group_draws[g]);
        }
    }

    /// Records the refinement raster of poses `range` (group `g`, after its filter):
    /// one render pass over the atlas, each pose in its slot.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn record_raster(
        &self,
        pass: &RefinePass,
        encoder: &mut Encoder<'_>,
        t: &SlotTargets,
        pose_bg: &wgpu::BindGroup,
        scene: &SceneBuffers,
        range: std::ops::Range<u32>,
    ) {
        let raster_bg = self.raster_bind.current();
        // The occluder depth is read, not written, and not needed afterwards.
        let mut rp = t.begin_pass(encoder, "refine raster", None, DepthUse::LoadDiscard);
        rp.set_pipeline(&pass.raster);
        RasterPass::bind_geometry(&mut rp, scene);
        let first = range.start;
        for p in range {
            t.bind_slot(&mut rp, p - first);
            let offset = (p as u64 * UNIFORM_SLOT) as u32;
            rp.set_bind_group(0, pose_bg, &[offset]);
            rp.set_bind_group(1, raster_bg, &[offset]);
            let draws = if !self.indirect {
                DrawList::Direct(&self.direct[p as usize])
            } else {
                let (first, count) = self.ranges[p as usize];
                if self.compact {
                    DrawList::IndirectCount {
                        buffer: self.draws.get(),
                        first,
                        counts: self.counts.get(),
                        at: p,
                        max: count,
                    }
                } else {
                    DrawList::Indirect(self.draws.get(), first, count)
                }
            };
            RasterPass::draw(&mut rp, draws);
        }
    }
}
