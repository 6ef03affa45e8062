//! Binding-layout entries, uniform slots and the two dispatch shapes every compute pass
//! here records.

use wgpu::util::DeviceExt;

pub(crate) fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

pub(crate) fn uniform_entry(
    binding: u32,
    dynamic: bool,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: dynamic,
            min_binding_size: None,
        },
        count: None,
    }
}

pub(crate) fn texture_array_entry(
    binding: u32,
    sample_type: wgpu::TextureSampleType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type,
            view_dimension: wgpu::TextureViewDimension::D2Array,
            multisampled: false,
        },
        count: None,
    }
}

/// Records a 1-D compute pass of `invocations` threads in workgroups of `wg`, with
/// `bind_group` bound at uniform slot `slot`; nothing when `invocations` is 0. Wide
/// dispatches wrap into rows of at most 65535 workgroups (the per-dimension limit), so
/// kernels index `g.x + g.y · num_workgroups.x · wg`.
pub(crate) fn record_wide(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    bind_group: &wgpu::BindGroup,
    slot: u32,
    invocations: u32,
    wg: u32,
) {
    const MAX_DIM: u32 = 65_535;
    if invocations == 0 {
        return;
    }
    let groups = invocations.div_ceil(wg);
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes: None,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, bind_group, &[(slot as u64 * UNIFORM_SLOT) as u32]);
    let x = groups.min(MAX_DIM);
    pass.dispatch_workgroups(x, groups.div_ceil(x), 1);
}

/// Records a compute pass of 8×8 workgroups over a `width` × `height` grid for each of
/// `slots` pose slots (z = slot), with `bind_group` bound at uniform slot `slot`: the
/// shape of the per-pixel passes (pyramid, oracle collect).
#[allow(clippy::too_many_arguments)]
pub(crate) fn record_grid(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    pipeline: &wgpu::ComputePipeline,
    bind_group: &wgpu::BindGroup,
    slot: u32,
    width: u32,
    height: u32,
    slots: u32,
) {
    let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: Some(label),
        timestamp_writes: None,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, bind_group, &[(slot as u64 * UNIFORM_SLOT) as u32]);
    pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), slots);
}

/// Uniform slots are 256 bytes apart (the dynamic-offset alignment every adapter accepts).
pub const UNIFORM_SLOT: u64 = 256;

/// Packs `items` into 256-byte slots for dynamic-offset binding.
pub(crate) fn slotted<T: bytemuck::Pod>(items: &[T]) -> Vec<u8> {
    let mut out = vec![0u8; items.len().max(1) * UNIFORM_SLOT as usize];
    for (i, it) in items.iter().enumerate() {
        let b = bytemuck::bytes_of(it);
        out[i * UNIFORM_SLOT as usize..][..b.len()].copy_from_slice(b);
    }
    out
}

/// A storage buffer holding `bytes` (16 zero bytes when empty: bindings may not be empty).
pub(crate) fn storage_buffer(device: &wgpu::Device, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    let fallback = [0u8; 16];
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: if bytes.is_empty() { &fallback } else { bytes },
        usage: wgpu::BufferUsages::STORAGE,
    })
}

/// A 16-byte uniform slot of `buffer` for dynamic-offset binding.
pub(crate) fn uniform_slot(buffer: &wgpu::Buffer) -> wgpu::BindingResource<'_> {
    wgpu::BindingResource::Buffer(wgpu::BufferBinding {
        buffer,
        offset: 0,
        size: wgpu::BufferSize::new(16),
    })
}
