//! [`BatchInputs`]: what a batch writes before it records, kept between batches.
//!
//! Every buffer here is a [`GrowBuffer`] and every bind group a [`BindCache`]
//! (`super::arena`): a batch writes its pose uniforms, draws and pass inputs with
//! `queue.write_buffer` and clears its bitmasks on the GPU, so once the buffers have
//! grown to the largest batch seen, a batch creates no buffers and no bind groups.

use super::arena::{BindCache, GrowBuffer, Upload};
use super::device::GpuDevice;
use super::encode::{UNIFORM_SLOT, slotted};
use super::oracle::OracleInputs;
use super::passes::SharedPasses;
use super::raster::{DrawList, indirect_args, object_draws};
use super::refine::RefineInputs;
use super::scene_buffers::SceneBuffers;
use super::targets::SlotTargets;
use super::test::{TestConfig, TestInputs};
use crate::camera::PoseUniform;
use crate::cull::{CullSettings, Passes, PosePlan, words_per_pose};
use crate::reference::level_thresholds;

/// A batch's inputs: pose uniforms, the visibility bitmask, each pose's draws (all
/// candidates for the oracle, else occluders), the groups of poses sharing the atlas,
/// and each pass's own inputs.
pub(crate) struct BatchInputs {
    pub(crate) poses_count: u32,
    pub(crate) words: u32,
    /// `(first pose, end pose)` of every group.
    pub(crate) groups: Vec<(u32, u32)>,
    poses: GrowBuffer,
    pose_bind: BindCache,
    pub(crate) mask: GrowBuffer,
    draws: GrowBuffer,
    /// Per pose: `(first, count)` in `draws`.
    ranges: Vec<(u32, u32)>,
    /// Per pose: its direct draws (where indirect draws are missing).
    direct: Vec<Vec<(u32, u32, u32)>>,
    indirect: bool,
    pub(crate) test: TestInputs,
    pub(crate) refine: RefineInputs,
    pub(crate) oracle: OracleInputs,
    /// What the batch writes, sent as one block ([`Upload::flush`] before recording).
    pub(crate) upload: Upload,
}

impl BatchInputs {
    pub(crate) fn new() -> Self {
        BatchInputs {
            poses_count: 0,
            words: 0,
            groups: Vec::new(),
            poses: GrowBuffer::new(
                "poses",
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::STORAGE,
            ),
            pose_bind: BindCache::default(),
            mask: GrowBuffer::new(
                "visibility mask",
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            ),
            draws: GrowBuffer::new("indirect draws", wgpu::BufferUsages::INDIRECT),
            ranges: Vec::new(),
            direct: Vec::new(),
            indirect: false,
            test: TestInputs::new(),
            refine: RefineInputs::new(),
            oracle: OracleInputs::new(),
            upload: Upload::new(),
        }
    }

    /// Writes everything the batch `plans` needs on the atlas `t` under `s`, and makes
    /// (or keeps) the bind groups its passes record with. `objects` holds every
    /// object's `(first_index, index_count)`; `moving` is the bitmask of moving
    /// objects (`PreparedScene::moving`).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn write(
        &mut self,
        gpu: &GpuDevice,
        passes: &SharedPasses,
        t: &SlotTargets,
        scene: &SceneBuffers,
        objects: &[(u32, u32)],
        moving: &[u32],
        plans: &[PosePlan],
        s: &CullSettings,
        work: Passes,
    ) {
        let (test, refine) = match work {
            Passes::Exact => (None, false),
            Passes::Occlusion { test, refine } => (Some(test), refine),
        };
        let exact = test.is_none();
        self.poses_count = plans.len() as u32;
        self.words = words_per_pose(objects.len()) as u32;
        self.groups = (0..self.poses_count)
            .step_by(t.slots as usize)
            .map(|a| (a, (a + t.slots).min(self.poses_count)))
            .collect();
        let uniforms: Vec<PoseUniform> = plans
            .iter()
            .map(|p| PoseUniform::new(&p.cam, p.deb.depth[0]))
            .collect();
        self.poses.write(gpu, &mut self.upload, &slotted(&uniforms));
        self.mask.reserve(gpu, self.mask_bytes());
        let poses = &self.poses;
        self.pose_bind.get(&[poses.id()], || {
            gpu.bind_group(
                "pose",
                &passes.raster.pose_layout,
                vec![
                    wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                        buffer: poses.get(),
                        offset: 0,
                        size: wgpu::BufferSize::new(UNIFORM_SLOT),
                    }),
                    // The scene's buffers live as long as these inputs: one key is enough.
                    scene.placements.as_entire_binding(),
                ],
            )
        });
        let drawn = plans.iter().map(|p| {
            let ids = if exact {
                &p.candidates
            } else {
                &p.occluders.ids
            };
            object_draws(objects, ids)
        });
        self.indirect = gpu.indirect_draws;
        if self.indirect {
            let (args, ranges) = indirect_args(drawn);
            self.draws.write(gpu, &mut self.upload, &args);
            self.ranges = ranges;
        } else {
            self.direct = drawn.collect();
        }
        let Some(test) = test else {
            let (groups, words) = (&self.groups, self.words);
            let upload = &mut self.upload;
            self.oracle
                .prepare(gpu, upload, &passes.oracle, t, groups, words, &self.mask);
            return;
        };
        let deb = &plans[0].deb;
        let cfg = TestConfig::new(
            test,
            s.options.deb,
            &t.layout,
            &level_thresholds(s.options.threshold, t.layout.levels()),
            deb.tile,
            deb.cols,
            deb.rows,
            self.words,
            t.cols,
        );
        self.test
            .write(gpu, &mut self.upload, &cfg, plans, &self.groups);
        self.test
            .bind(gpu, &passes.test, t, &self.poses, &scene.boxes, &self.mask);
        if refine {
            self.refine.write(
                gpu,
                &mut self.upload,
                &passes.refine,
                t,
                scene,
                moving,
                objects,
                plans,
                &self.groups,
                &self.mask,
                self.words,
            );
        }
    }

    /// Bytes of the visibility bitmask this batch.
    pub(crate) fn mask_bytes(&self) -> u64 {
        (self.poses_count * self.words) as u64 * 4
    }

    /// The pose uniforms' bind group (one uniform slot per pose).
    pub(crate) fn pose_bind_group(&self) -> &wgpu::BindGroup {
        self.pose_bind.current()
    }

    /// Pose `p`'s draws.
    pub(crate) fn draw_list(&self, p: u32) -> DrawList<'_> {
        if self.indirect {
            let (first, count) = self.ranges[p as usize];
            DrawList::Indirect(self.draws.get(), first, count)
        } else {
            DrawList::Direct(&self.direct[p as usize])
        }
    }
}
