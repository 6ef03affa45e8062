//! The one place homcull creates GPU buffers and bind groups, begins passes and submits
//! work, each counted, so that tests can see what a batch records.
//!
//! A batch's cost on a GPU is mostly fixed costs per object created and per pass begun
//! (barriers, descriptor writes, pass breaks), which a timing on a software adapter
//! hides. [`GpuDevice::counts`] makes them visible anywhere: `tests/gpu_batch.rs`
//! asserts that a batch of 1 or 256 poses records the same passes and submissions, and
//! that a second batch creates nothing. `tests/architecture.rs` keeps the raw wgpu
//! calls out of every other file of `gpu/`, so nothing slips past the count.

use std::sync::atomic::{AtomicU64, Ordering};

use wgpu::util::DeviceExt;

use super::device::GpuDevice;

/// Running totals of what the device has been asked to create and record.
#[derive(Debug, Default)]
pub struct Counters {
    buffers: AtomicU64,
    bind_groups: AtomicU64,
    render_passes: AtomicU64,
    compute_passes: AtomicU64,
    submissions: AtomicU64,
}

/// A snapshot of [`Counters`]; subtract two to get what happened between them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RecordCounts {
    pub buffers: u64,
    pub bind_groups: u64,
    pub render_passes: u64,
    pub compute_passes: u64,
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
            submissions: self.submissions - o.submissions,
        }
    }
}

fn bump(counter: &AtomicU64) {
    counter.fetch_add(1, Ordering::Relaxed);
}

impl GpuDevice {
    /// What this device has created and recorded so far.
    pub fn counts(&self) -> RecordCounts {
        let c = &self.counters;
        let get = |a: &AtomicU64| a.load(Ordering::Relaxed);
        RecordCounts {
            buffers: get(&c.buffers),
            bind_groups: get(&c.bind_groups),
            render_passes: get(&c.render_passes),
            compute_passes: get(&c.compute_passes),
            submissions: get(&c.submissions),
        }
    }

    pub(crate) fn buffer(&self, desc: &wgpu::BufferDescriptor<'_>) -> wgpu::Buffer {
        bump(&self.counters.buffers);
        self.device.create_buffer(desc)
    }

    pub(crate) fn buffer_init(
        &self,
        label: &str,
        contents: &[u8],
        usage: wgpu::BufferUsages,
    ) -> wgpu::Buffer {
        bump(&self.counters.buffers);
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage,
            })
    }

    /// A bind group of `layout` with `resources` at bindings 0, 1, 2, …
    pub(crate) fn bind_group(
        &self,
        label: &str,
        layout: &wgpu::BindGroupLayout,
        resources: Vec<wgpu::BindingResource<'_>>,
    ) -> wgpu::BindGroup {
        bump(&self.counters.bind_groups);
        let entries: Vec<wgpu::BindGroupEntry> = resources
            .into_iter()
            .enumerate()
            .map(|(binding, resource)| wgpu::BindGroupEntry {
                binding: binding as u32,
                resource,
            })
            .collect();
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(label),
            layout,
            entries: &entries,
        })
    }

    /// A command encoder whose passes are counted.
    pub(crate) fn encoder(&self) -> Encoder<'_> {
        Encoder {
            raw: self.device.create_command_encoder(&Default::default()),
            counters: &self.counters,
        }
    }

    /// Submits what `encoder` recorded.
    pub(crate) fn submit(&self, encoder: Encoder<'_>) {
        bump(&self.counters.submissions);
        self.queue.submit([encoder.raw.finish()]);
    }
}

/// A command encoder that counts the passes begun on it.
pub(crate) struct Encoder<'a> {
    /// For copies, clears and timestamps (not passes: use the methods).
    pub(crate) raw: wgpu::CommandEncoder,
    counters: &'a Counters,
}

impl Encoder<'_> {
    pub(crate) fn render_pass<'p>(
        &'p mut self,
        desc: &wgpu::RenderPassDescriptor<'_>,
    ) -> wgpu::RenderPass<'p> {
        bump(&self.counters.render_passes);
        self.raw.begin_render_pass(desc)
    }

    pub(crate) fn compute_pass(&mut self, label: &str) -> wgpu::ComputePass<'_> {
        bump(&self.counters.compute_passes);
        self.raw.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: None,
        })
    }
}
