//! Per-object test pass: one invocation per (pose, test box), HOM or HZB, writing
//! one visibility bit per object and pose. CPU twin: `hom/test.rs`.

use homcull_proto::DebVariant;

use super::arena::{BindCache, GrowBuffer, Upload};
use super::counted::ComputePass;
use super::device::GpuDevice;
use super::encode::{
    record_wide, slotted, storage_entry, texture_entry, uniform_entry, uniform_slot,
};
use super::prelude::{deb_code, test_code};
use super::pyramid::buffer_levels;
use super::targets::SlotTargets;
use crate::cull::{BoxTest, PosePlan};
use crate::reference::{MAX_LEVELS, pyramid::LevelLayout};

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
    /// Slots per atlas row ([`SlotTargets::cols`]).
    pub atlas_cols: u32,
    pub _pad: [u32; 3],
    pub dims: [[u32; 4]; MAX_LEVELS],
    pub thresholds: [[f32; 4]; MAX_LEVELS],
}

impl TestConfig {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        test: BoxTest,
        deb: DebVariant,
        layout: &LevelLayout,
        thresholds: &[f32],
        deb_tile: u32,
        deb_cols: u32,
        deb_rows: u32,
        words_per_pose: u32,
        atlas_cols: u32,
    ) -> Self {
        let (dims, slot_stride) = buffer_levels(layout);
        let mut thr = [[0.0; 4]; MAX_LEVELS];
        for (t, &o) in thr.iter_mut().zip(thresholds).take(layout.levels()) {
            t[0] = o;
        }
        TestConfig {
            levels: layout.levels() as u32,
            method: test_code(test),
            deb: deb_code(deb),
            deb_tile,
            deb_cols,
            deb_rows,
            words_per_pose,
            slot_stride,
            atlas_cols,
            _pad: [0; 3],
            dims,
            thresholds: thr,
        }
    }
}

/// `TestGroup` in `test.wgsl`: one group's candidates, one uniform slot per group.
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct TestGroup {
    /// The group's first candidate in the batch's candidate list.
    pub cand_start: u32,
    pub cand_count: u32,
    /// The group's first pose (its slot 0).
    pub first_pose: u32,
    pub _pad: u32,
}

pub struct TestPass {
    pub layout: wgpu::BindGroupLayout,
    pipeline: wgpu::ComputePipeline,
}

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
            texture_entry(9, wgpu::TextureSampleType::Float { filterable: false }),
        ])
        .collect();
        let (layout, pl) = ctx.compute_layout("test", &entries);
        let pipeline = ctx.compute_pipeline(&pl, &module, "main");
        TestPass { layout, pipeline }
    }

    /// Records the test of `count` candidates of group `group` (its params slot).
    pub(crate) fn record(
        &self,
        pass: &mut ComputePass<'_>,
        bind_group: &wgpu::BindGroup,
        group: u32,
        count: u32,
    ) {
        record_wide(pass, &self.pipeline, bind_group, group, count);
    }
}

/// What the box test binds beyond the targets, kept between batches
/// (`super::arena`): its config, per-group params, candidates and DEB tiles.
pub(crate) struct TestInputs {
    config: GrowBuffer,
    groups: GrowBuffer,
    candidates: GrowBuffer,
    deb_tiles: GrowBuffer,
    bind: BindCache,
    /// Candidates per group of the last batch written.
    pub(crate) counts: Vec<u32>,
}

impl TestInputs {
    pub(crate) fn new() -> Self {
        let storage = wgpu::BufferUsages::STORAGE;
        TestInputs {
            config: GrowBuffer::new("test config", wgpu::BufferUsages::UNIFORM),
            groups: GrowBuffer::new("test groups", wgpu::BufferUsages::UNIFORM),
            candidates: GrowBuffer::new("test candidates", storage),
            deb_tiles: GrowBuffer::new("deb tiles", storage),
            bind: BindCache::default(),
            counts: Vec::new(),
        }
    }

    /// Writes a batch's test inputs: `cfg`, and per group of `plans` its candidates
    /// (`[pose, test box]`, group after group) and first pose; the DEB tiles per pose.
    pub(crate) fn write(
        &mut self,
        gpu: &GpuDevice,
        upload: &mut Upload,
        cfg: &TestConfig,
        plans: &[PosePlan],
        groups: &[(u32, u32)],
    ) {
        let mut candidates: Vec<[u32; 2]> = Vec::new();
        let mut params = Vec::with_capacity(groups.len());
        self.counts.clear();
        for &(a, b) in groups {
            let start = candidates.len() as u32;
            for p in a..b {
                candidates.extend(plans[p as usize].test_boxes.iter().map(|&bx| [p, bx]));
            }
            let count = candidates.len() as u32 - start;
            self.counts.push(count);
            params.push(TestGroup {
                cand_start: start,
                cand_count: count,
                first_pose: a,
                _pad: 0,
            });
        }
        let deb_tiles: Vec<f32> = plans
            .iter()
            .flat_map(|p| p.deb.depth.iter().copied())
            .collect();
        self.config.write(gpu, upload, bytemuck::bytes_of(cfg));
        self.groups.write(gpu, upload, &slotted(&params));
        self.candidates
            .write(gpu, upload, bytemuck::cast_slice(&candidates));
        self.deb_tiles
            .write(gpu, upload, bytemuck::cast_slice(&deb_tiles));
    }

    /// Makes (or keeps) the test's bind group on `t`, with the batch's `poses`, the
    /// scene's `boxes` and the visibility `mask`.
    pub(crate) fn bind(
        &mut self,
        gpu: &GpuDevice,
        pass: &TestPass,
        t: &SlotTargets,
        poses: &GrowBuffer,
        boxes: &wgpu::Buffer,
        mask: &GrowBuffer,
    ) {
        let TestInputs {
            config,
            groups,
            candidates,
            deb_tiles,
            bind,
            ..
        } = self;
        let key = [
            t.generation,
            poses.id(),
            mask.id(),
            config.id(),
            groups.id(),
            candidates.id(),
            deb_tiles.id(),
        ];
        bind.get(&key, || {
            gpu.bind_group(
                "test",
                &pass.layout,
                vec![
                    config.get().as_entire_binding(),
                    uniform_slot::<TestGroup>(groups.get()),
                    poses.get().as_entire_binding(),
                    boxes.as_entire_binding(),
                    candidates.get().as_entire_binding(),
                    deb_tiles.get().as_entire_binding(),
                    t.opacity.as_entire_binding(),
                    t.pyramid_depth.as_entire_binding(),
                    mask.get().as_entire_binding(),
                    wgpu::BindingResource::TextureView(&t.occlusion.view),
                ],
            )
        });
    }

    /// The bind group of the last [`TestInputs::bind`].
    pub(crate) fn bind_group(&self) -> &wgpu::BindGroup {
        self.bind.current()
    }
}
