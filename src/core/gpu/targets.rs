//! Per-slot render targets and pyramid buffers for one viewport size.
//!
//! Poses are processed in groups of up to [`MAX_SLOTS`] that share these targets (a
//! texture array layer and a pyramid region per pose), so memory stays bounded however
//! large the batch.

use super::pyramid::{PyramidPass, buffer_levels};
use super::raster::{DEPTH_FORMAT, ID_FORMAT, OCCLUSION_FORMAT};
use crate::core::hom::pyramid::LevelLayout;

/// Most poses sharing the per-slot targets at once.
pub const MAX_SLOTS: u32 = 16;
/// Memory the per-slot targets may take, bytes; fewer slots at large viewports. The
/// oracle's ID buffers, made only once an exact batch runs, come on top (half as much
/// again at most: 4 of the 8 bytes a pixel the occlusion map and depth take).
const SLOT_MEMORY_BUDGET: u64 = 256 << 20;

/// Per-slot render targets and pyramid buffers for one viewport size.
pub(crate) struct SlotTargets {
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) slots: u32,
    pub(crate) layout: LevelLayout,
    /// The occlusion map of every slot (view depth of the nearest occluder, 0 uncovered).
    pub(crate) occlusion: Layers,
    /// Per slot: the occluders' depth, kept for the refinement (the oracle reuses it).
    pub(crate) depth: Layers,
    /// The oracle's ID buffers, made on the first exact batch (HOM never needs them).
    pub(crate) ids: std::sync::OnceLock<Layers>,
    /// Opacity and depth pyramids, levels 1.. ([`buffer_levels`]).
    pub(crate) opacity: wgpu::Buffer,
    pub(crate) pyramid_depth: wgpu::Buffer,
    /// The pyramid pass bound to these targets; nothing in it changes between batches.
    pub(crate) pyramid_bg: wgpu::BindGroup,
}

/// A texture array with a layer per slot, its per-layer views and one array view.
pub(crate) struct Layers {
    pub(crate) texture: wgpu::Texture,
    pub(crate) layers: Vec<wgpu::TextureView>,
    pub(crate) array: wgpu::TextureView,
}

impl Layers {
    fn new(
        device: &wgpu::Device,
        label: &str,
        format: wgpu::TextureFormat,
        size: wgpu::Extent3d,
    ) -> Self {
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let layers = (0..size.depth_or_array_layers)
            .map(|l| {
                texture.create_view(&wgpu::TextureViewDescriptor {
                    dimension: Some(wgpu::TextureViewDimension::D2),
                    base_array_layer: l,
                    array_layer_count: Some(1),
                    ..Default::default()
                })
            })
            .collect();
        let array = texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        Layers {
            texture,
            layers,
            array,
        }
    }
}

impl SlotTargets {
    pub(crate) fn new(
        device: &wgpu::Device,
        pyramid: &PyramidPass,
        width: u32,
        height: u32,
    ) -> Self {
        let layout = LevelLayout::new(width, height);
        let (_, pyramid_stride) = buffer_levels(&layout);
        // Occlusion and depth layers (4 bytes a pixel each), opacity and depth pyramids
        // (levels 1.., 4 bytes a texel each); the oracle's ID layers come on top when
        // an exact batch first needs them.
        let per_slot = (width as u64 * height as u64) * 8 + pyramid_stride as u64 * 8;
        let slots = (SLOT_MEMORY_BUDGET / per_slot).clamp(1, MAX_SLOTS as u64) as u32;
        let size = Self::extent(width, height, slots);
        let occlusion = Layers::new(device, "occlusion raster", OCCLUSION_FORMAT, size);
        let depth = Layers::new(device, "depth", DEPTH_FORMAT, size);
        let buf = |label| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: pyramid_stride as u64 * slots as u64 * 4,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        let opacity = buf("pyramid opacity");
        let pyramid_depth = buf("pyramid depth");
        let pyramid_bg =
            pyramid.bind_group(device, &layout, &opacity, &pyramid_depth, &occlusion.array);
        SlotTargets {
            width,
            height,
            slots,
            layout,
            occlusion,
            depth,
            ids: std::sync::OnceLock::new(),
            opacity,
            pyramid_depth,
            pyramid_bg,
        }
    }

    fn extent(width: u32, height: u32, slots: u32) -> wgpu::Extent3d {
        wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: slots,
        }
    }

    /// The oracle's ID layers, made on first use.
    pub(crate) fn ids(&self, device: &wgpu::Device) -> &Layers {
        self.ids.get_or_init(|| {
            let size = Self::extent(self.width, self.height, self.slots);
            Layers::new(device, "oracle ids", ID_FORMAT, size)
        })
    }
}
