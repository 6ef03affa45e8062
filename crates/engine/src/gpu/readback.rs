//! Reading results back from the device (blocking): buffers, and the occlusion atlas's
//! slots for tests and debug images.

use super::arena::GrowBuffer;
use super::counted::Encoder;
use super::device::{GpuDevice, GpuError};
use super::targets::SlotTargets;

/// Submits `encoder` with a copy of `src`'s first `size` bytes into `staging` (a
/// mappable buffer kept between batches), waits, and returns the bytes.
pub(crate) fn read_into(
    gpu: &GpuDevice,
    encoder: Encoder<'_>,
    src: &wgpu::Buffer,
    size: u64,
    staging: &mut GrowBuffer,
) -> Result<Vec<u8>, GpuError> {
    submit_read(gpu, encoder, src, size, staging).wait(gpu)
}

/// A submitted copy into a mappable buffer whose mapping has been requested; the
/// device runs it while the host goes on, and [`PendingRead::wait`] takes the bytes.
pub(crate) struct PendingRead {
    staging: wgpu::Buffer,
    size: u64,
    submission: wgpu::SubmissionIndex,
    submitted: std::time::Instant,
    mapped: std::sync::mpsc::Receiver<Result<(), wgpu::BufferAsyncError>>,
}

/// Records a copy of `src`'s first `size` bytes into `staging` (grown if needed) at
/// the end of `encoder`, submits it and requests the mapping, without waiting.
/// `staging` must not be read again before the returned [`PendingRead`] is waited for.
pub(crate) fn submit_read(
    gpu: &GpuDevice,
    mut encoder: Encoder<'_>,
    src: &wgpu::Buffer,
    size: u64,
    staging: &mut GrowBuffer,
) -> PendingRead {
    staging.reserve(gpu, size);
    let staging = staging.get().clone();
    encoder.raw.copy_buffer_to_buffer(src, 0, &staging, 0, size);
    let submitted = std::time::Instant::now();
    let submission = gpu.submit(encoder);
    let (tx, mapped) = std::sync::mpsc::channel();
    staging
        .slice(..size)
        .map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
    PendingRead {
        staging,
        size,
        submission,
        submitted,
        mapped,
    }
}

impl PendingRead {
    /// Waits for the submission and the mapping, and returns the bytes (the staging
    /// buffer is unmapped again, ready for the next batch).
    pub(crate) fn wait(self, gpu: &GpuDevice) -> Result<Vec<u8>, GpuError> {
        let err = |e: &dyn std::fmt::Display| GpuError::Readback(e.to_string());
        let waited = std::time::Instant::now();
        gpu.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(self.submission),
                timeout: None,
            })
            .map_err(|e| err(&e))?;
        self.mapped
            .recv()
            .map_err(|e| err(&e))?
            .map_err(|e| err(&e))?;
        tracing::debug!(
            target: "homcull::timing",
            in_flight_ms = self.submitted.elapsed().as_secs_f64() * 1e3,
            wait_ms = waited.elapsed().as_secs_f64() * 1e3,
            "GPU readback"
        );
        let slice = self.staging.slice(..self.size);
        let data = slice.get_mapped_range().map_err(|e| err(&e))?.to_vec();
        self.staging.unmap();
        Ok(data)
    }
}

/// [`read_into`] a staging buffer of its own (tests, debug images, profiling).
pub(crate) fn read_buffer(
    gpu: &GpuDevice,
    encoder: Encoder<'_>,
    src: &wgpu::Buffer,
    size: u64,
) -> Result<Vec<u8>, GpuError> {
    let mut staging = readback_buffer();
    read_into(gpu, encoder, src, size, &mut staging)
}

/// An empty mappable staging buffer.
pub(crate) fn readback_buffer() -> GrowBuffer {
    GrowBuffer::new("readback", wgpu::BufferUsages::MAP_READ)
}

/// The occlusion map of the first `slots` slots (view depth, 0 where uncovered), one
/// `width × height` image after another.
pub(crate) fn read_occlusion(
    gpu: &GpuDevice,
    t: &SlotTargets,
    slots: u32,
) -> Result<Vec<f32>, GpuError> {
    let (w, h) = (t.width, t.height);
    let row = (w * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let per_slot = row as u64 * h as u64;
    let size = per_slot * slots as u64;
    let buffer = gpu.buffer(&wgpu::BufferDescriptor {
        label: Some("occlusion atlas readback"),
        size,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let mut enc = gpu.encoder();
    for s in 0..slots {
        let (x, y) = t.origin(s);
        enc.raw.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &t.occlusion.texture,
                mip_level: 0,
                origin: wgpu::Origin3d { x, y, z: 0 },
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: s as u64 * per_slot,
                    bytes_per_row: Some(row),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
        );
    }
    let bytes = read_buffer(gpu, enc, &buffer, size)?;
    let padded: Vec<f32> = bytemuck::pod_collect_to_vec(&bytes);
    Ok(padded
        .chunks_exact(row as usize / 4)
        .flat_map(|r| &r[..w as usize])
        .copied()
        .collect())
}
