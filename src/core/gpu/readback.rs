//! Reading results back from the device (blocking): buffers, and the occlusion map's
//! layers for tests and debug images.

use super::device::{GpuDevice, GpuError};
use super::targets::SlotTargets;

/// Reads back a buffer region (blocking); used for the bitmask and by tests.
pub fn read_buffer(
    gpu: &GpuDevice,
    encoder: wgpu::CommandEncoder,
    src: &wgpu::Buffer,
    size: u64,
) -> Result<Vec<u8>, GpuError> {
    let device = &gpu.device;
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = encoder;
    encoder.copy_buffer_to_buffer(src, 0, &staging, 0, size);
    let t = std::time::Instant::now();
    gpu.queue.submit([encoder.finish()]);
    let submit_ms = t.elapsed().as_secs_f64() * 1e3;
    let (tx, rx) = std::sync::mpsc::channel();
    staging.slice(..).map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    device
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
    let data = staging
        .slice(..)
        .get_mapped_range()
        .map_err(|e| GpuError::Readback(e.to_string()))?
        .to_vec();
    staging.unmap();
    Ok(data)
}

/// The first `layers` occlusion-map layers (view depth, 0 where uncovered), one
/// `width × height` image after another.
pub(crate) fn read_occlusion(
    gpu: &GpuDevice,
    t: &SlotTargets,
    layers: u32,
) -> Result<Vec<f32>, GpuError> {
    let (w, h) = (t.width, t.height);
    let row = (w * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let size = row as u64 * h as u64 * layers as u64;
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("occlusion map readback"),
        size,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    enc.copy_texture_to_buffer(
        t.occlusion.texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: Some(h),
            },
        },
        wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: layers,
        },
    );
    let bytes = read_buffer(gpu, enc, &buffer, size)?;
    let padded: Vec<f32> = bytemuck::pod_collect_to_vec(&bytes);
    Ok(padded
        .chunks_exact(row as usize / 4)
        .flat_map(|r| &r[..w as usize])
        .copied()
        .collect())
}
