//! [`GpuBackend`]: all passes of a batch of poses in one submission, one readback.
//!
//! Poses are processed in groups of up to [`SlotTargets::slots`] (up to
//! [`super::targets::MAX_SLOTS`]) that share one atlas, a viewport-sized slot per pose,
//! so memory stays bounded however large the batch. A group is a fixed number of
//! passes whatever its size: one occluder render pass, the pyramid's dispatches, one
//! box-test dispatch, and for the refinement one filter dispatch and one render pass
//! (or, for the exact oracle, one ID render pass and one collect dispatch). Every pose
//! writes its own region of one visibility bitmask, copied back once at the end.
//!
//! A batch is recorded in three steps: [`BatchInputs::write`] (what every pass reads,
//! written into buffers kept between batches), then the method's passes
//! ([`GpuBackend::record_exact`] or [`GpuBackend::record_occlusion`]), then one
//! submission and readback ([`GpuBackend::read_masks`]).

use std::sync::Arc;

use super::context::GpuContext;
use super::counted::{ComputePass, Encoder};
use super::device::GpuError;
use super::in_flight::InFlight;
use super::inputs::BatchInputs;
use super::passes::SharedPasses;
use super::profile::Stamps;
use super::pyramid::buffer_levels;
use super::raster::RasterKind;
use super::readback::{read_buffer, read_occlusion, submit_read};
use super::scene_buffers::SceneBuffers;
use super::targets::{SlotTargets, slots_for};
use crate::cull::plan::masks_from_plans;
use crate::cull::{
    BoxTest, CullError, CullSettings, Culler, Pass, PassTimes, Passes, PosePlan, PreparedScene,
    StartedVisibility, has_bit, set_bit,
};

/// The GPU culler of one scene: its buffers, and the device's shared passes.
pub struct GpuBackend {
    ctx: Arc<GpuContext>,
    scene: SceneBuffers,
    passes: Arc<SharedPasses>,
    /// `(first_index, index_count)` of every object, for draw calls.
    draws: Vec<(u32, u32)>,
    /// GPU time per pass since profiling started (`Some` while profiling).
    profile: Option<PassTimes>,
    /// Buffers and bind groups kept between batches.
    inputs: BatchInputs,
    /// Batches submitted and not yet read back.
    in_flight: InFlight,
    /// Bitmask of the scene's moving objects (`PreparedScene::moving`; empty: none).
    moving: Vec<u32>,
    /// Per batch in flight without indirect draws: each pose's moving candidates,
    /// answered visible after the readback (see [`GpuBackend::moving_candidates`]).
    unfiltered: std::collections::VecDeque<(u64, Vec<Vec<u32>>)>,
}

/// Locks the shared atlas (serialising batches on this device), sized for `plans`:
/// remade for another viewport, or grown when it holds fewer slots than the batch has
/// poses and the budget allows more.
fn lock_targets<'p>(
    ctx: &GpuContext,
    passes: &'p SharedPasses,
    plans: &[PosePlan],
) -> std::sync::MutexGuard<'p, Option<SlotTargets>> {
    let size = (plans[0].cam.width, plans[0].cam.height);
    let poses = plans.len() as u32;
    let mut t = passes.targets.lock().unwrap_or_else(|p| p.into_inner());
    let fits = |t: &SlotTargets| {
        (t.width, t.height) == size
            && (t.slots >= poses || t.slots >= slots_for(ctx, size.0, size.1))
    };
    if !t.as_ref().is_some_and(fits) {
        *t = None; // free the old targets before allocating new ones
        *t = Some(SlotTargets::new(ctx, &passes.pyramid, size, poses));
    }
    t
}

impl GpuBackend {
    pub fn new(ctx: Arc<GpuContext>, prep: &PreparedScene) -> Self {
        GpuBackend {
            scene: SceneBuffers::new(&ctx, &prep.scene),
            passes: ctx.passes(),
            draws: prep
                .scene
                .objects
                .iter()
                .map(|o| (o.first_index, o.index_count))
                .collect(),
            profile: None,
            inputs: BatchInputs::new(),
            in_flight: InFlight::new(),
            moving: prep.moving.clone(),
            unfiltered: std::collections::VecDeque::new(),
            ctx,
        }
    }

    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// Each pose's moving candidates where the refinement cannot answer them from the
    /// box test: without indirect draws there is no filter pass, so they are answered
    /// visible wherever they are candidates (frustum culling only; conservative).
    fn moving_candidates(&self, plans: &[PosePlan], s: &CullSettings) -> Option<Vec<Vec<u32>>> {
        if self.ctx.indirect_draws || self.moving.is_empty() || !s.refines() {
            return None;
        }
        let moving = |p: &PosePlan| -> Vec<u32> {
            let ids = p.candidates.iter().copied();
            ids.filter(|&id| has_bit(&self.moving, id)).collect()
        };
        Some(plans.iter().map(moving).collect())
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
        let passes = Arc::clone(&self.passes);
        let guard = lock_targets(&self.ctx, &passes, plans);
        let t = guard.as_ref().expect("targets exist");
        if plans.len() > t.slots as usize {
            return Err(GpuError::Readback(format!(
                "{} poses do not fit the {} pyramid slots",
                plans.len(),
                t.slots
            )));
        }
        let work = Passes::Occlusion {
            test: s.box_test().unwrap_or(BoxTest::Hom),
            refine: s.refines(),
        };
        self.record_with(t, plans, s, work, false)?;
        let n = plans.len();
        let (_, stride) = buffer_levels(&t.layout);
        let read = |buffer| -> Result<Vec<f32>, GpuError> {
            let enc = self.ctx.encoder();
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

    /// Batches submitted and not yet read back (see `super::in_flight`).
    pub fn in_flight(&self) -> usize {
        self.in_flight.len()
    }

    /// The refinement draws each pose of the last refined batch issued (its box
    /// test's survivors with triangles), where the adapter compacts them on the GPU;
    /// `None` elsewhere. For tests and measurements: one extra readback.
    pub fn refine_draws(&self) -> Result<Option<Vec<u32>>, GpuError> {
        let refine = &self.inputs.refine;
        if !refine.compacted() {
            return Ok(None);
        }
        let bytes = self.inputs.poses_count as u64 * 4;
        let read = read_buffer(&self.ctx, self.ctx.encoder(), refine.counts.get(), bytes)?;
        Ok(Some(bytemuck::pod_collect_to_vec(&read)))
    }

    fn record_and_read(
        &mut self,
        plans: &[PosePlan],
        s: &CullSettings,
        work: Passes,
    ) -> Result<Vec<Vec<u32>>, GpuError> {
        let profile = self.profile.is_some();
        let passes = Arc::clone(&self.passes);
        let (masks, times) = {
            let guard = lock_targets(&self.ctx, &passes, plans);
            let t = guard.as_ref().expect("targets exist");
            self.record_with(t, plans, s, work, profile)?
        };
        if let (Some(total), Some(t)) = (&mut self.profile, times) {
            for (sum, ms) in total.ms.iter_mut().zip(t.ms) {
                *sum += ms;
            }
            total.poses += t.poses;
        }
        Ok(masks)
    }

    /// Records and submits one batch without waiting for it (see `super::in_flight`);
    /// returns the ticket its bitmasks are taken with.
    fn start(&mut self, plans: &[PosePlan], s: &CullSettings, work: Passes) -> u64 {
        let ctx = Arc::clone(&self.ctx);
        let passes = Arc::clone(&self.passes);
        let guard = lock_targets(&ctx, &passes, plans);
        let t = guard.as_ref().expect("targets exist");
        let (encoder, refined, _) = self.record(&ctx, t, plans, s, work, false);
        self.submit(encoder, refined)
    }

    /// Records, submits and reads back one batch on the (locked) atlas `t`; with
    /// `profile` (and timestamp support), also its GPU time per pass.
    fn record_with(
        &mut self,
        t: &SlotTargets,
        plans: &[PosePlan],
        s: &CullSettings,
        work: Passes,
        profile: bool,
    ) -> Result<(Vec<Vec<u32>>, Option<PassTimes>), GpuError> {
        // The encoder borrows the context's counters, not `self` (read_masks takes it).
        let ctx = Arc::clone(&self.ctx);
        let (encoder, refined, stamps) = self.record(&ctx, t, plans, s, work, profile);
        self.read_masks(encoder, refined, stamps.as_ref())
    }

    /// Writes a batch's inputs and records its passes `work` on the atlas `t` (with
    /// timestamps when `profile` and the adapter has them); returns the encoder,
    /// whether the result is the refined bitmask, and the stamps.
    fn record<'c>(
        &mut self,
        ctx: &'c GpuContext,
        t: &SlotTargets,
        plans: &[PosePlan],
        s: &CullSettings,
        work: Passes,
        profile: bool,
    ) -> (Encoder<'c>, bool, Option<Stamps>) {
        let started = std::time::Instant::now();
        let (exact, refines) = match work {
            Passes::Exact => (true, false),
            Passes::Occlusion { refine, .. } => (false, refine),
        };
        self.inputs.write(
            ctx,
            &self.passes,
            t,
            &self.scene,
            &self.draws,
            &self.moving,
            plans,
            s,
            work,
        );
        let mut encoder = ctx.encoder();
        self.inputs.upload.flush(ctx, &mut encoder);
        let inputs = &self.inputs;
        encoder
            .raw
            .clear_buffer(inputs.mask.get(), 0, Some(inputs.mask_bytes()));
        if refines {
            inputs.refine.clear(&mut encoder);
        }
        let stamps_per_group = if exact { 2 } else { 3 + refines as u32 };
        let mut stamps = if profile && ctx.timestamps {
            Stamps::new(ctx, 1 + inputs.groups.len() as u32 * stamps_per_group)
        } else {
            None
        };
        mark(&mut stamps, &mut encoder, None);
        if exact {
            self.record_exact(&mut encoder, t, &mut stamps);
        } else {
            self.record_occlusion(&mut encoder, t, refines, &mut stamps);
        }
        tracing::debug!(
            target: "homcull::timing",
            poses = plans.len(),
            method = s.method.name(),
            record_ms = started.elapsed().as_secs_f64() * 1e3,
            "recorded a batch"
        );
        (encoder, refines, stamps)
    }

    /// Submits a recorded batch with the copy of its bitmask (the refined one when
    /// `refined`) into a staging buffer of its own; returns its ticket.
    fn submit(&mut self, encoder: Encoder<'_>, refined: bool) -> u64 {
        let inputs = &self.inputs;
        let result = if refined {
            inputs.refine.refined.get()
        } else {
            inputs.mask.get()
        };
        let mut staging = self.in_flight.staging();
        let read = submit_read(
            &self.ctx,
            encoder,
            result,
            inputs.mask_bytes(),
            &mut staging,
        );
        self.in_flight.push(read, staging, inputs.words)
    }

    /// The exact oracle: per group, every candidate rasterized into the ID atlas (one
    /// render pass), then collected (one dispatch).
    fn record_exact(
        &self,
        encoder: &mut Encoder<'_>,
        t: &SlotTargets,
        stamps: &mut Option<Stamps>,
    ) {
        let inputs = &self.inputs;
        let pose_bg = inputs.pose_bind_group();
        for (g, &(a, b)) in inputs.groups.iter().enumerate() {
            self.passes.raster.record_group(
                encoder,
                RasterKind::ObjectIds,
                t,
                pose_bg,
                a..b,
                &self.scene,
                |p| inputs.draw_list(p),
            );
            mark(stamps, encoder, Some(Pass::IdRaster));
            {
                let mut cp = encoder.compute_pass("oracle collect");
                let bind_group = inputs.oracle.bind_group();
                let oracle = &self.passes.oracle;
                oracle.record(&mut cp, bind_group, g as u32, t.width, t.height, b - a);
            }
            mark(stamps, encoder, Some(Pass::Collect));
        }
    }

    /// HOM or HZB: per group, the occluder raster, the pyramid and the box test, and
    /// the refinement when `refines`.
    fn record_occlusion(
        &self,
        encoder: &mut Encoder<'_>,
        t: &SlotTargets,
        refines: bool,
        stamps: &mut Option<Stamps>,
    ) {
        let inputs = &self.inputs;
        let pose_bg = inputs.pose_bind_group();
        for (g, &(a, b)) in inputs.groups.iter().enumerate() {
            self.passes.raster.record_group(
                encoder,
                RasterKind::OccluderDepth,
                t,
                pose_bg,
                a..b,
                &self.scene,
                |p| inputs.draw_list(p),
            );
            mark(stamps, encoder, Some(Pass::OccluderRaster));
            // One compute pass for the pyramid, the box test and the refinement's
            // filter (wgpu orders the dispatches); split where profiling stamps go.
            let passes = &self.passes;
            let test = |cp: &mut ComputePass<'_>| {
                let bind_group = inputs.test.bind_group();
                passes
                    .test
                    .record(cp, bind_group, g as u32, inputs.test.counts[g]);
            };
            let filter = |cp: &mut ComputePass<'_>| {
                inputs.refine.record_filter(&passes.refine, cp, g);
            };
            {
                let mut cp = encoder.compute_pass("pyramid, box test, refinement filter");
                passes
                    .pyramid
                    .record(&mut cp, &t.pyramid_bg, &t.layout, b - a);
                if stamps.is_none() {
                    test(&mut cp);
                    if refines {
                        filter(&mut cp);
                    }
                }
            }
            if stamps.is_some() {
                mark(stamps, encoder, Some(Pass::Pyramid));
                test(&mut encoder.compute_pass("box test"));
                mark(stamps, encoder, Some(Pass::BoxTest));
                if refines {
                    filter(&mut encoder.compute_pass("refinement filter"));
                }
            }
            if refines {
                let refine = &inputs.refine;
                refine.record_raster(&passes.refine, encoder, t, pose_bg, &self.scene, a..b);
                mark(stamps, encoder, Some(Pass::Refine));
            }
        }
    }

    /// Submits the batch, reads back its bitmask (the refined one when `refined`; one
    /// region per pose) and, when profiling, the timestamps.
    fn read_masks(
        &mut self,
        mut encoder: Encoder<'_>,
        refined: bool,
        stamps: Option<&Stamps>,
    ) -> Result<(Vec<Vec<u32>>, Option<PassTimes>), GpuError> {
        let poses = self.inputs.poses_count;
        let resolved = stamps.map(|st| st.resolve(&mut encoder));
        let ticket = self.submit(encoder, refined);
        let masks = self.in_flight.take(&self.ctx, ticket)?;
        let times = match (stamps, resolved) {
            (Some(st), Some((buffer, size))) => {
                let encoder = self.ctx.encoder();
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
fn mark(stamps: &mut Option<Stamps>, encoder: &mut Encoder<'_>, pass: Option<Pass>) {
    if let Some(st) = stamps {
        st.mark(encoder, pass);
    }
}

impl Culler for GpuBackend {
    fn name(&self) -> &'static str {
        "gpu"
    }

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
        prep: &PreparedScene,
        plans: &[PosePlan],
        s: &CullSettings,
    ) -> Result<Vec<Vec<u32>>, CullError> {
        let Some(work) = s.passes() else {
            return Ok(masks_from_plans(s.method, prep, plans));
        };
        if plans.is_empty() {
            return Ok(Vec::new());
        }
        let mut masks = self.record_and_read(plans, s, work)?;
        if let Some(moving) = self.moving_candidates(plans, s) {
            mark_visible(&mut masks, &moving);
        }
        Ok(masks)
    }

    /// Submits the batch and returns; profiling batches are read back at once (their
    /// timestamps need a second readback).
    fn start_visibility(
        &mut self,
        prep: &PreparedScene,
        plans: &[PosePlan],
        s: &CullSettings,
    ) -> Result<StartedVisibility, CullError> {
        let work = s
            .passes()
            .filter(|_| !plans.is_empty() && self.profile.is_none());
        let Some(work) = work else {
            return Ok(StartedVisibility::Answered(
                self.visibility(prep, plans, s)?,
            ));
        };
        let ticket = self.start(plans, s, work);
        if let Some(moving) = self.moving_candidates(plans, s) {
            self.unfiltered.push_back((ticket, moving));
        }
        Ok(StartedVisibility::InFlight(ticket))
    }

    fn finish_visibility(
        &mut self,
        started: StartedVisibility,
    ) -> Result<Vec<Vec<u32>>, CullError> {
        match started {
            StartedVisibility::Answered(masks) => Ok(masks),
            StartedVisibility::InFlight(ticket) => {
                let mut masks = self.in_flight.take(&self.ctx, ticket)?;
                while let Some((t, moving)) = self.unfiltered.pop_front() {
                    if t == ticket {
                        mark_visible(&mut masks, &moving);
                        break;
                    }
                    if t > ticket {
                        self.unfiltered.push_front((t, moving));
                        break;
                    }
                }
                Ok(masks)
            }
        }
    }

    fn scene_changed(&mut self, prep: &PreparedScene, changed: &[(u32, glam::Mat4)]) {
        let bytes = self.scene.update(&self.ctx, &prep.scene, changed);
        tracing::debug!(
            objects = changed.len(),
            bytes,
            "placements written to the GPU"
        );
        self.moving = prep.moving.clone();
    }
}

/// Sets each pose's `ids` in its mask.
fn mark_visible(masks: &mut [Vec<u32>], ids: &[Vec<u32>]) {
    for (mask, ids) in masks.iter_mut().zip(ids) {
        for &id in ids {
            set_bit(mask, id);
        }
    }
}
