//! Buffers and bind groups that outlive a batch: nothing is rebuilt per batch.
//!
//! A batch writes its inputs into [`GrowBuffer`]s through one [`Upload`] (one
//! `queue.write_buffer`, so one staging buffer, then a copy per destination on the GPU)
//! and binds them with bind groups kept in [`BindCache`]s.
//! A buffer is reallocated only when a batch needs more than it holds, at the next
//! power of two, so a server settles after its first few batches and then creates no
//! buffers and no bind groups at all. Every allocation gets a fresh [`ResourceId`]; a
//! bind group is keyed by the IDs of what it binds, so it is remade exactly when one of
//! them was reallocated (or the targets were remade for another viewport).
//!
//! Batches may be in flight together (`super::in_flight`): a batch's writes reach a
//! buffer only after every earlier submission has read it (`queue.write_buffer` and
//! the copies recorded in the batch's own encoder are ordered on the queue), and an
//! allocation dropped while a batch still uses it lives until that batch is done.

use std::sync::atomic::{AtomicU64, Ordering};

use super::counted::Encoder;
use super::device::GpuDevice;

/// Identifies one allocation (a buffer or a set of targets) for as long as it lives.
pub(crate) type ResourceId = u64;

/// A new, never repeated [`ResourceId`].
pub(crate) fn next_resource_id() -> ResourceId {
    static NEXT: AtomicU64 = AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

/// Smallest allocation, bytes (bindings may not be empty; 256 covers a uniform slot).
const MIN_SIZE: u64 = 256;

/// A buffer kept between batches that grows when a batch needs more.
pub(crate) struct GrowBuffer {
    label: &'static str,
    usage: wgpu::BufferUsages,
    buffer: Option<(wgpu::Buffer, ResourceId)>,
}

impl GrowBuffer {
    /// An empty buffer of `usage` (`COPY_DST` is added: batches write into it).
    pub(crate) fn new(label: &'static str, usage: wgpu::BufferUsages) -> Self {
        GrowBuffer {
            label,
            usage: usage | wgpu::BufferUsages::COPY_DST,
            buffer: None,
        }
    }

    /// Makes room for `size` bytes, reallocating (contents lost) only when too small.
    pub(crate) fn reserve(&mut self, gpu: &GpuDevice, size: u64) {
        let size = size.max(MIN_SIZE).next_power_of_two();
        if self.buffer.as_ref().is_some_and(|(b, _)| b.size() >= size) {
            return;
        }
        self.buffer = None; // free the old allocation first
        let buffer = gpu.buffer(&wgpu::BufferDescriptor {
            label: Some(self.label),
            size,
            usage: self.usage,
            mapped_at_creation: false,
        });
        self.buffer = Some((buffer, next_resource_id()));
    }

    /// Writes `bytes` at the start (growing first), through the batch's `upload`.
    pub(crate) fn write(&mut self, gpu: &GpuDevice, upload: &mut Upload, bytes: &[u8]) {
        self.reserve(gpu, bytes.len() as u64);
        upload.stage(self.get(), bytes);
    }

    /// The buffer; [`GrowBuffer::reserve`] or [`GrowBuffer::write`] must have run.
    pub(crate) fn get(&self) -> &wgpu::Buffer {
        &self
            .buffer
            .as_ref()
            .expect("a GrowBuffer is reserved before use")
            .0
    }

    /// The current allocation's ID (0 before the first).
    pub(crate) fn id(&self) -> ResourceId {
        self.buffer.as_ref().map_or(0, |b| b.1)
    }
}

/// One bind group kept between batches, remade when what it binds was reallocated.
#[derive(Default)]
pub(crate) struct BindCache {
    key: Vec<ResourceId>,
    group: Option<wgpu::BindGroup>,
}

impl BindCache {
    /// The bind group for the resources identified by `key`, made by `make` when the
    /// key differs from the last one.
    pub(crate) fn get(
        &mut self,
        key: &[ResourceId],
        make: impl FnOnce() -> wgpu::BindGroup,
    ) -> &wgpu::BindGroup {
        if self.group.is_none() || self.key != key {
            self.group = None;
            self.group = Some(make());
            self.key = key.to_vec();
        }
        self.group.as_ref().expect("just made")
    }

    /// The bind group made by the last [`BindCache::get`].
    pub(crate) fn current(&self) -> &wgpu::BindGroup {
        self.group
            .as_ref()
            .expect("a BindCache is filled before use")
    }
}

/// Everything a batch writes into its buffers, sent as one block: one
/// `queue.write_buffer` into a buffer kept between batches (wgpu makes one staging
/// buffer per call, so one per batch rather than one per destination), then a
/// buffer-to-buffer copy into each destination, recorded ahead of the batch's passes.
pub(crate) struct Upload {
    bytes: Vec<u8>,
    /// `(offset in bytes, destination, size)` of each staged write.
    copies: Vec<(u64, wgpu::Buffer, u64)>,
    block: GrowBuffer,
}

impl Upload {
    pub(crate) fn new() -> Self {
        Upload {
            bytes: Vec::new(),
            copies: Vec::new(),
            block: GrowBuffer::new("upload", wgpu::BufferUsages::COPY_SRC),
        }
    }

    /// Stages `data` for the start of `dst` (padded to the 4-byte copy alignment; the
    /// destination is a [`GrowBuffer`], at least that large).
    pub(crate) fn stage(&mut self, dst: &wgpu::Buffer, data: &[u8]) {
        if data.is_empty() {
            return;
        }
        let at = self.bytes.len() as u64;
        self.bytes.extend_from_slice(data);
        let size = (data.len() as u64).next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT);
        self.bytes.resize((at + size) as usize, 0);
        self.copies.push((at, dst.clone(), size));
    }

    /// Sends what was staged and records its copies at the start of `encoder`.
    pub(crate) fn flush(&mut self, gpu: &GpuDevice, encoder: &mut Encoder<'_>) {
        if self.copies.is_empty() {
            return;
        }
        self.block.reserve(gpu, self.bytes.len() as u64);
        gpu.queue.write_buffer(self.block.get(), 0, &self.bytes);
        for (at, dst, size) in self.copies.drain(..) {
            encoder
                .raw
                .copy_buffer_to_buffer(self.block.get(), at, &dst, 0, size);
        }
        self.bytes.clear();
    }
}
