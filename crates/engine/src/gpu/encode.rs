//! Binding-layout entries, uniform slots and the two dispatch shapes every compute pass
//! here records.

use super::counted::ComputePass;
use super::prelude::{GRID_WORKGROUP, LINEAR_WORKGROUP};

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

/// A 2-D texture read by a compute kernel (the atlases: `super::targets`).
pub(crate) fn texture_entry(
    binding: u32,
    sample_type: wgpu::TextureSampleType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type,
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }
}

/// Dispatches a 1-D kernel of `invocations` threads in workgroups of
/// [`LINEAR_WORKGROUP`] into `pass`, with `bind_group` bound at uniform slot `slot`;
/// nothing when `invocations` is 0. Wide dispatches wrap into rows of at most 65535
/// workgroups (the per-dimension limit), so kernels index
/// `g.x + g.y · num_workgroups.x · LINEAR_WORKGROUP`.
pub(crate) fn record_wide(
    pass: &mut ComputePass<'_>,
    pipeline: &wgpu::ComputePipeline,
    bind_group: &wgpu::BindGroup,
    slot: u32,
    invocations: u32,
) {
    const MAX_DIM: u32 = 65_535;
    if invocations == 0 {
        return;
    }
    let groups = invocations.div_ceil(LINEAR_WORKGROUP);
    let x = groups.min(MAX_DIM);
    let offset = (slot as u64 * UNIFORM_SLOT) as u32;
    pass.dispatch(pipeline, bind_group, &[offset], [x, groups.div_ceil(x), 1]);
}

/// Dispatches 8×8 workgroups over a `width` × `height` grid for each of `slots` pose
/// slots (z = slot) into `pass`, with `bind_group` bound at uniform slot `slot`: the
/// shape of the per-pixel kernels (pyramid, oracle collect).
#[allow(clippy::too_many_arguments)]
pub(crate) fn record_grid(
    pass: &mut ComputePass<'_>,
    pipeline: &wgpu::ComputePipeline,
    bind_group: &wgpu::BindGroup,
    slot: u32,
    width: u32,
    height: u32,
    slots: u32,
) {
    let side = GRID_WORKGROUP;
    let offset = (slot as u64 * UNIFORM_SLOT) as u32;
    let groups = [width.div_ceil(side), height.div_ceil(side), slots];
    pass.dispatch(pipeline, bind_group, &[offset], groups);
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

/// One `T`-sized uniform slot of `buffer` for dynamic-offset binding.
pub(crate) fn uniform_slot<T>(buffer: &wgpu::Buffer) -> wgpu::BindingResource<'_> {
    const { assert!(std::mem::size_of::<T>() as u64 <= UNIFORM_SLOT) };
    wgpu::BindingResource::Buffer(wgpu::BufferBinding {
        buffer,
        offset: 0,
        size: wgpu::BufferSize::new(std::mem::size_of::<T>() as u64),
    })
}
