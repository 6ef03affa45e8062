//! [`GpuBackend`]: all passes of a batch of poses in one submission, one readback.
//!
//! Poses are processed in groups of up to [`super::targets::MAX_SLOTS`] that share
//! per-slot targets (a texture array layer and a pyramid region per pose), so memory
//! stays bounded however large the batch: group g's raster, pyramid and test passes
//! are recorded before group g+1's, and wgpu orders them. Every pose writes its own
//! region of one visibility bitmask, copied back once at the end.
//!
//! A batch is recorded in three steps: [`BatchInputs`] (what every method uploads: pose
//! uniforms, the bitmask, the groups and their draws), then the method's passes
//! ([`GpuBackend::record_exact`] or [`GpuBackend::record_occlusion`]), then one
//! submission and readback ([`GpuBackend::read_masks`]).

use std::sync::Arc;

use homcull_proto::Method;
use wgpu::util::DeviceExt;

use super::context::GpuContext;
use super::device::GpuError;
use super::encode::{UNIFORM_SLOT, slotted, storage_buffer, uniform_slot};
use super::passes::SharedPasses;
use super::profile::Stamps;
use super::pyramid::buffer_levels;
use super::raster::{DrawList, RasterKind, indirect_draws, object_draws};
use super::readback::{read_buffer, read_occlusion};
use super::refine::RefineBatch;
use super::scene_buffers::SceneBuffers;
use super::targets::SlotTargets;
use super::test::{GroupParams, TestConfig};
use crate::core::camera::PoseUniform;
use crate::core::cull::{
    CullError, CullSettings, Culler, Pass, PassTimes, PosePlan, PreparedScene, words_per_pose,
};
use crate::core::hom::level_thresholds;

/// The GPU culler of one scene: its buffers, and the device's shared passes.
pub struct GpuBackend {
    ctx: Arc<GpuContext>,
    scene: SceneBuffers,
    passes: Arc<SharedPasses>,
    /// `(first_index, index_count)` of every object, for draw calls.
    draws: Vec<(u32, u32)>,
    /// GPU time per pass since profiling started (`Some` while profiling).
    profile: Option<PassTimes>,
}

impl GpuBackend {
    pub fn new(ctx: Arc<GpuContext>, prep: &PreparedScene) -> Self {
        GpuBackend {
            scene: SceneBuffers::new(&ctx.device, &prep.scene),
            passes: ctx.passes(),
            draws: prep
                .scene
                .objects
                .iter()
                .map(|o| (o.first_index, o.index_count))
                .collect(),
            profile: None,
            ctx,
        }
    }

    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// Locks the shared slot targets (serialising batches on this device), sized for
    /// `width` × `height`.
    fn targets(&self, width: u32, height: u32) -> std::sync::MutexGuard<'_, Option<SlotTargets>> {
        let mut t = self
            .passes
            .targets
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        if t.as_ref()
            .is_none_or(|t| (t.width, t.height) != (width, height))
        {
            *t = None; // free the old targets before allocating new ones
            *t = Some(SlotTargets::new(
                &self.ctx.device,
                &self.passes.pyramid,
                width,
                height,
            ));
        }
        t
    }

    /// Runs the occluder raster and pyramid of one group of plans (at most one group
    /// of slots) and returns the opacity and depth pyramids in the CPU twin's layout
    /// (`LevelLayout`, one after another per pose; level 0 read back from the occlusion
    /// map). For GPU-vs-CPU tests and debug images.
    pub fn pyramids(
        &mut self,
        plans: &[PosePlan],
        s: &CullSettings,
    ) -> Result<(Vec<f32>, Vec<f32>), GpuError> {
        let guard = self.targets(plans[0].cam.width, plans[0].cam.height);
        let slots = guard.as_ref().expect("targets exist").slots;
        if plans.len() > slots as usize {
            return Err(GpuError::Readback(format!(
                "{} poses do not fit the {slots} pyramid slots",
                plans.len()
            )));
        }
        self.record_with(guard.as_ref().expect("targets exist"), plans, s, false)?;
        let t = guard.as_ref().expect("targets exist after a batch");
        let n = plans.len();
        let (_, stride) = buffer_levels(&t.layout);
        let read = |buffer| -> Result<Vec<f32>, GpuError> {
            let enc = self.ctx.device.create_command_encoder(&Default::default());
            let bytes = read_buffer(&self.ctx, enc, buffer, stride as u64 * n as u64 * 4)?;
            Ok(bytemuck::pod_collect_to_vec(&bytes))
        };
        let (upper_opacity, upper_depth) = (read(&t.opacity)?, read(&t.pyramid_depth)?);
        let level0 = read_occlusion(&self.ctx, t, n as u32)?;
        let (w, h) = t.layout.dims[0];
        let pixels = (w * h) as usize;
        let upper = t.layout.total as usize - pixels;
        let (mut opacity, mut depth) = (Vec::new(), Vec::new());
        for k in 0..n {
            let d0 = &level0[k * pixels..][..pixels];
            opacity.extend(d0.iter().map(|&d| if d > 0.0 { 1.0 } else { 0.0 }));
            depth.extend_from_slice(d0);
            let at = k * stride as usize;
            opacity.extend_from_slice(&upper_opacity[at..at + upper]);
            depth.extend_from_slice(&upper_depth[at..at + upper]);
        }
        Ok((opacity, depth))
    }

    fn record_and_read(
        &mut self,
        plans: &[PosePlan],
        s: &CullSettings,
    ) -> Result<Vec<Vec<u32>>, GpuError> {
        let profile = self.profile.is_some();
        let (masks, times) = {
            let guard = self.targets(plans[0].cam.width, plans[0].cam.height);
            self.record_with(guard.as_ref().expect("targets exist"), plans, s, profile)?
        };
        if let (Some(total), Some(t)) = (&mut self.profile, times) {
            for (sum, ms) in total.ms.iter_mut().zip(t.ms) {
                *sum += ms;
            }
            total.poses += t.poses;
        }
        Ok(masks)
    }

    /// Records, submits and reads back one batch on the (locked) slot targets `t`;
    /// with `profile` (and timestamp support), also its GPU time per pass.
    fn record_with(
        &self,
        t: &SlotTargets,
        plans: &[PosePlan],
        s: &CullSettings,
        profile: bool,
    ) -> Result<(Vec<Vec<u32>>, Option<PassTimes>), GpuError> {
        let started = std::time::Instant::now();
        let exact = s.options.method == Method::Exact;
        let inputs = BatchInputs::new(self, t, plans, exact);
        let mut encoder = self.ctx.device.create_command_encoder(&Default::default());
        let stamps_per_group = if exact { 2 } else { 3 + s.refines() as u32 };
        let mut stamps = if profile && self.ctx.timestamps {
            Stamps::new(
                &self.ctx.device,
                1 + inputs.groups.len() as u32 * stamps_per_group,
            )
        } else {
            None
        };
        mark(&mut stamps, &mut encoder, None);
        let refined = if exact {
            self.record_exact(&mut encoder, t, &inputs, &mut stamps);
            None
        } else {
            self.record_occlusion(&mut encoder, t, &inputs, plans, s, &mut stamps)
        };
        tracing::debug!(
            target: "homcull::timing",
            poses = plans.len(),
            record_ms = started.elapsed().as_secs_f64() * 1e3,
            "recorded a batch"
        );
        let result = refined.as_ref().unwrap_or(&inputs.mask);
        self.read_masks(encoder, result, &inputs, stamps.as_ref())
    }

    /// The exact oracle: every candidate rasterized into the ID buffer, then collected.
    fn record_exact(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        t: &SlotTargets,
        inputs: &BatchInputs,
        stamps: &mut Option<Stamps>,
    ) {
        let device = &self.ctx.device;
        let ids = t.ids(device);
        let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("oracle"),
            layout: &self.passes.oracle.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniform_slot(&inputs.group_buf),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&ids.array),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: inputs.mask.as_entire_binding(),
                },
            ],
        });
        for (g, &(a, b)) in inputs.groups.iter().enumerate() {
            for p in a..b {
                self.passes.raster.record(
                    encoder,
                    RasterKind::ObjectIds,
                    &ids.layers[(p - a) as usize],
                    &t.depth.layers[(p - a) as usize],
                    &inputs.pose_bg,
                    p,
                    &self.scene,
                    inputs.draw_list(p),
                );
            }
            mark(stamps, encoder, Some(Pass::IdRaster));
            self.passes
                .oracle
                .record(encoder, &bg, g as u32, t.width, t.height, b - a);
            mark(stamps, encoder, Some(Pass::Collect));
        }
    }

    /// HOM or HZB: occluder raster, pyramid and box test per group, and the refinement
    /// when the settings ask for it. Returns the refined bitmask, if any.
    fn record_occlusion(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        t: &SlotTargets,
        inputs: &BatchInputs,
        plans: &[PosePlan],
        s: &CullSettings,
        stamps: &mut Option<Stamps>,
    ) -> Option<wgpu::Buffer> {
        let test_bg = self.test_bind_group(t, inputs, plans, s);
        let refine = s.refines().then(|| {
            RefineBatch::new(
                &self.ctx,
                &self.passes.refine,
                &self.draws,
                plans,
                &inputs.groups,
                &inputs.mask,
                &t.occlusion.array,
                inputs.words,
            )
        });
        for (g, &(a, b)) in inputs.groups.iter().enumerate() {
            for p in a..b {
                self.passes.raster.record(
                    encoder,
                    RasterKind::OccluderDepth,
                    &t.occlusion.layers[(p - a) as usize],
                    &t.depth.layers[(p - a) as usize],
                    &inputs.pose_bg,
                    p,
                    &self.scene,
                    inputs.draw_list(p),
                );
            }
            mark(stamps, encoder, Some(Pass::OccluderRaster));
            self.passes
                .pyramid
                .record(encoder, &t.pyramid_bg, &t.layout, b - a);
            mark(stamps, encoder, Some(Pass::Pyramid));
            self.passes
                .test
                .record(encoder, &test_bg, g as u32, inputs.group_params[g].b);
            mark(stamps, encoder, Some(Pass::BoxTest));
            if let Some(r) = &refine {
                let group_depth = &t.depth.layers[..(b - a) as usize];
                r.record(
                    &self.passes.refine,
                    encoder,
                    group_depth,
                    &inputs.pose_bg,
                    &self.scene,
                    g,
                    a..b,
                );
                mark(stamps, encoder, Some(Pass::Refine));
            }
        }
        refine.map(|r| r.refined)
    }

    /// The box test's bind group: its config, the candidates' test boxes, the DEB tiles,
    /// the pyramids and the bitmask.
    fn test_bind_group(
        &self,
        t: &SlotTargets,
        inputs: &BatchInputs,
        plans: &[PosePlan],
        s: &CullSettings,
    ) -> wgpu::BindGroup {
        let device = &self.ctx.device;
        let deb0 = &plans[0].deb;
        let cfg = TestConfig::new(
            s.options.method,
            s.options.deb,
            &t.layout,
            &level_thresholds(s.options.threshold, t.layout.levels()),
            deb0.tile,
            deb0.cols,
            deb0.rows,
            inputs.words,
        );
        let cfg_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("test config"),
            contents: bytemuck::bytes_of(&cfg),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let deb_tiles: Vec<f32> = plans
            .iter()
            .flat_map(|p| p.deb.depth.iter().copied())
            .collect();
        let cand_buf = storage_buffer(
            device,
            "candidates",
            bytemuck::cast_slice(&inputs.candidates),
        );
        let deb_buf = storage_buffer(device, "deb tiles", bytemuck::cast_slice(&deb_tiles));
        let resources = [
            cfg_buf.as_entire_binding(),
            uniform_slot(&inputs.group_buf),
            inputs.poses.as_entire_binding(),
            self.scene.boxes.as_entire_binding(),
            cand_buf.as_entire_binding(),
            deb_buf.as_entire_binding(),
            t.opacity.as_entire_binding(),
            t.pyramid_depth.as_entire_binding(),
            inputs.mask.as_entire_binding(),
            wgpu::BindingResource::TextureView(&t.occlusion.array),
        ];
        let entries: Vec<wgpu::BindGroupEntry> = resources
            .into_iter()
            .enumerate()
            .map(|(binding, resource)| wgpu::BindGroupEntry {
                binding: binding as u32,
                resource,
            })
            .collect();
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("test"),
            layout: &self.passes.test.layout,
            entries: &entries,
        })
    }

    /// Submits the batch, reads back the bitmask `result` (one region per pose) and,
    /// when profiling, the timestamps.
    fn read_masks(
        &self,
        mut encoder: wgpu::CommandEncoder,
        result: &wgpu::Buffer,
        inputs: &BatchInputs,
        stamps: Option<&Stamps>,
    ) -> Result<(Vec<Vec<u32>>, Option<PassTimes>), GpuError> {
        let poses = inputs.poses_count;
        let words = inputs.words;
        let resolved = stamps.map(|st| st.resolve(&mut encoder));
        let bytes = read_buffer(&self.ctx, encoder, result, (poses * words) as u64 * 4)?;
        let all: &[u32] = bytemuck::cast_slice(&bytes);
        let masks = all
            .chunks_exact(words as usize)
            .map(|c| c.to_vec())
            .collect();
        let times = match (stamps, resolved) {
            (Some(st), Some((buffer, size))) => {
                let encoder = self.ctx.device.create_command_encoder(&Default::default());
                let ticks = read_buffer(&self.ctx, encoder, buffer, size)?;
                let mut times = PassTimes {
                    poses: poses as u64,
                    ..Default::default()
                };
                let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&ticks);
                st.accumulate(&ticks, self.ctx.queue.get_timestamp_period(), &mut times);
                Some(times)
            }
            _ => None,
        };
        Ok((masks, times))
    }
}

/// Writes a timestamp closing `pass` (or the opening one) when profiling.
fn mark(stamps: &mut Option<Stamps>, encoder: &mut wgpu::CommandEncoder, pass: Option<Pass>) {
    if let Some(st) = stamps {
        st.mark(encoder, pass);
    }
}

/// What every method of a batch uploads: the pose uniforms and their bind group, the
/// visibility bitmask, the groups of poses sharing the slots with their box-test
/// candidates, and each pose's draws (all candidates for the oracle, else occluders).
struct BatchInputs {
    poses_count: u32,
    words: u32,
    poses: wgpu::Buffer,
    pose_bg: wgpu::BindGroup,
    mask: wgpu::Buffer,
    /// `(first pose, end pose)` of every group.
    groups: Vec<(u32, u32)>,
    /// `[pose, test box]` of every box test, group after group.
    candidates: Vec<[u32; 2]>,
    group_params: Vec<GroupParams>,
    group_buf: wgpu::Buffer,
    /// One indirect multi-draw range per pose, or the direct draws per pose.
    draws: Draws,
}

enum Draws {
    Indirect(wgpu::Buffer, Vec<(u32, u32)>),
    Direct(Vec<Vec<(u32, u32, u32)>>),
}

impl BatchInputs {
    fn new(backend: &GpuBackend, t: &SlotTargets, plans: &[PosePlan], exact: bool) -> Self {
        let device = &backend.ctx.device;
        let (w, h) = (t.width, t.height);
        let poses_count = plans.len() as u32;
        let words = words_per_pose(backend.draws.len()) as u32;
        let pose_uniforms: Vec<PoseUniform> = plans
            .iter()
            .map(|p| PoseUniform::new(&p.cam, p.deb.depth[0]))
            .collect();
        let poses = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("poses"),
            contents: &slotted(&pose_uniforms),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::STORAGE,
        });
        let pose_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("pose"),
            layout: &backend.passes.raster.pose_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &poses,
                    offset: 0,
                    size: wgpu::BufferSize::new(UNIFORM_SLOT),
                }),
            }],
        });
        let mask = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("visibility mask"),
            size: (poses_count * words) as u64 * 4,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let groups: Vec<(u32, u32)> = (0..poses_count)
            .step_by(t.slots as usize)
            .map(|a| (a, (a + t.slots).min(poses_count)))
            .collect();
        let mut candidates: Vec<[u32; 2]> = Vec::new();
        let mut group_params = Vec::new();
        for &(a, b) in &groups {
            let start = candidates.len() as u32;
            for p in a..b {
                candidates.extend(plans[p as usize].test_boxes.iter().map(|&bx| [p, bx]));
            }
            let count = candidates.len() as u32 - start;
            group_params.push(if exact {
                GroupParams {
                    a: w,
                    b: h,
                    c: words,
                    d: a,
                }
            } else {
                GroupParams {
                    a: start,
                    b: count,
                    c: a,
                    d: 0,
                }
            });
        }
        let group_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("group params"),
            contents: &slotted(&group_params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let drawn = |p: &PosePlan| {
            let ids = if exact {
                &p.candidates
            } else {
                &p.occluders.ids
            };
            object_draws(&backend.draws, ids)
        };
        let draws = if backend.ctx.indirect_draws {
            let (buffer, ranges) =
                indirect_draws(device, plans.iter().map(drawn), wgpu::BufferUsages::empty());
            Draws::Indirect(buffer, ranges)
        } else {
            Draws::Direct(plans.iter().map(drawn).collect())
        };
        BatchInputs {
            poses_count,
            words,
            poses,
            pose_bg,
            mask,
            groups,
            candidates,
            group_params,
            group_buf,
            draws,
        }
    }

    /// Pose `p`'s draws.
    fn draw_list(&self, p: u32) -> DrawList<'_> {
        match &self.draws {
            Draws::Indirect(buffer, ranges) => {
                let (first, count) = ranges[p as usize];
                DrawList::Indirect(buffer, first, count)
            }
            Draws::Direct(lists) => DrawList::Direct(lists[p as usize].clone()),
        }
    }
}

impl Culler for GpuBackend {
    fn describe(&self) -> String {
        self.ctx.describe()
    }

    fn set_profiling(&mut self, on: bool) -> bool {
        self.profile = (on && self.ctx.timestamps).then(PassTimes::default);
        self.profile.is_some()
    }

    fn take_pass_times(&mut self) -> Option<PassTimes> {
        self.profile.as_mut().map(std::mem::take)
    }

    fn visibility(
        &mut self,
        _prep: &PreparedScene,
        plans: &[PosePlan],
        s: &CullSettings,
    ) -> Result<Vec<Vec<u32>>, CullError> {
        if plans.is_empty() {
            return Ok(Vec::new());
        }
        Ok(self.record_and_read(plans, s)?)
    }
}
