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
    mut encoder: Encoder<'_>,
    src: &wgpu::Buffer,
    size: u64,
    staging: &mut GrowBuffer,
) -> Result<Vec<u8>, GpuError> {
    staging.reserve(gpu, size);
    let staging = staging.get();
    encoder.raw.copy_buffer_to_buffer(src, 0, staging, 0, size);
    let t = std::time::Instant::now();
    gpu.submit(encoder);
    let submit_ms = t.elapsed().as_secs_f64() * 1e3;
    let (tx, rx) = std::sync::mpsc::channel();
    let slice = staging.slice(..size);
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    gpu.device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    rx.recv()
        .map_err(|e| GpuError::Readback(e.to_string()))?
        .map_err(|e| GpuError::Readback(e.to_string()))?;
    tracing::debug!(
        target: "homcull::timing",
        submit_ms,
        wait_ms = t.elapsed().as_secs_f64() * 1e3 - submit_ms,
        "GPU submission and readback"
    );
    let data = slice
        .get_mapped_range()
        .map_err(|e| GpuError::Readback(e.to_string()))?
        .to_vec();
    staging.unmap();
    Ok(data)
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
