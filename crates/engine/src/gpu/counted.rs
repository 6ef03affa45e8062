//! Counts of the GPU buffers and bind groups homcull creates, the passes it begins and
//! the work it submits, so that tests can see what a batch records. `GpuDevice`'s
//! `buffer`, `bind_group` and `submit` and [`Encoder`]'s passes are the only way the
//! rest of `gpu/` makes them.
//!
//! A batch's cost on a GPU is mostly fixed costs per object created and per pass begun
//! (barriers, descriptor writes, pass breaks), which a timing on a software adapter
//! hides. `GpuDevice::counts` makes them visible anywhere: `tests/engine/gpu_batch.rs`
//! asserts that a batch of 1 or 256 poses records the same passes and submissions, and
//! that a second batch creates nothing. `tests/repo/architecture.rs` keeps the raw wgpu
//! calls out of every file of `gpu/` but this one and `device.rs`, so nothing slips
//! past the count.

use std::sync::atomic::{AtomicU64, Ordering};

/// Running totals of what the device has been asked to create and record.
#[derive(Debug, Default)]
pub struct Counters {
    buffers: AtomicU64,
    bind_groups: AtomicU64,
    render_passes: AtomicU64,
    compute_passes: AtomicU64,
    dispatches: AtomicU64,
    submissions: AtomicU64,
}

/// A snapshot of [`Counters`]; subtract two to get what happened between them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RecordCounts {
    pub buffers: u64,
    pub bind_groups: u64,
    pub render_passes: u64,
    pub compute_passes: u64,
    pub dispatches: u64,
    pub submissions: u64,
}

impl std::ops::Sub for RecordCounts {
    type Output = RecordCounts;
    fn sub(self, o: RecordCounts) -> RecordCounts {
        RecordCounts {
            buffers: self.buffers - o.buffers,
            bind_groups: self.bind_groups - o.bind_groups,
            render_passes: self.render_passes - o.render_passes,
            compute_passes: self.compute_passes - o.compute_passes,
            dispatches: self.dispatches - o.dispatches,
            submissions: self.submissions - o.submissions,
        }
    }
}

impl Counters {
    pub(crate) fn buffer(&self) {
        self.buffers.fetch_add(1, Ordering::Relaxed);
    }

    pub(crate) fn bind_group(&self) {
        self.bind_groups.fetch_add(1, Ordering::Relaxed);
    }

    pub(crate) fn submission(&self) {
        self.submissions.fetch_add(1, Ordering::Relaxed);
    }

    /// A snapshot of the totals.
    pub(crate) fn snapshot(&self) -> RecordCounts {
        let get = |a: &AtomicU64| a.load(Ordering::Relaxed);
        RecordCounts {
            buffers: get(&self.buffers),
            bind_groups: get(&self.bind_groups),
            render_passes: get(&self.render_passes),
            compute_passes: get(&self.compute_passes),
            dispatches: get(&self.dispatches),
            submissions: get(&self.submissions),
        }
    }
}

/// A command encoder that counts the passes begun on it.
pub(crate) struct Encoder<'a> {
    /// For copies, clears and timestamps (not passes: use the methods).
    pub(crate) raw: wgpu::CommandEncoder,
    counters: &'a Counters,
}

impl<'a> Encoder<'a> {
    pub(crate) fn new(raw: wgpu::CommandEncoder, counters: &'a Counters) -> Self {
        Encoder { raw, counters }
    }

    /// The recorded commands, ready to submit.
    pub(crate) fn finish(self) -> wgpu::CommandBuffer {
        self.raw.finish()
    }

    pub(crate) fn render_pass<'p>(
        &'p mut self,
        desc: &wgpu::RenderPassDescriptor<'_>,
    ) -> wgpu::RenderPass<'p> {
        self.counters.render_passes.fetch_add(1, Ordering::Relaxed);
        self.raw.begin_render_pass(desc)
    }

    pub(crate) fn compute_pass(&mut self, label: &str) -> ComputePass<'_> {
        self.counters.compute_passes.fetch_add(1, Ordering::Relaxed);
        let counters = self.counters;
        ComputePass {
            raw: self.raw.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(label),
                timestamp_writes: None,
            }),
            counters,
        }
    }
}

/// A compute pass whose dispatches are counted. Several kernels share one pass (wgpu
/// orders their dispatches by what they read and write).
pub(crate) struct ComputePass<'e> {
    raw: wgpu::ComputePass<'e>,
    counters: &'e Counters,
}

impl ComputePass<'_> {
    /// Dispatches `pipeline` over `groups` workgroups with `bind_group` at group 0 and
    /// the given dynamic offsets.
    pub(crate) fn dispatch(
        &mut self,
        pipeline: &wgpu::ComputePipeline,
        bind_group: &wgpu::BindGroup,
        offsets: &[u32],
        groups: [u32; 3],
    ) {
        self.counters.dispatches.fetch_add(1, Ordering::Relaxed);
        self.raw.set_pipeline(pipeline);
        self.raw.set_bind_group(0, bind_group, offsets);
        self.raw
            .dispatch_workgroups(groups[0], groups[1], groups[2]);
    }
}
