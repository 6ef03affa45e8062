//! The render targets of a batch: one atlas holding a viewport-sized slot per pose.
//!
//! Every pose of a group draws into its own rectangle of one 2-D texture (its slot:
//! viewport and scissor set per pose), so a group's occluder raster, refinement and
//! oracle raster are one render pass each however many poses it holds; a texture array
//! would need a pass per layer. Slots sit in rows of [`SlotTargets::cols`]; slot `s`
//! starts at `((s % cols) · width, (s / cols) · height)` ([`SlotTargets::origin`]), the
//! arithmetic the kernels repeat (`slot_origin` in `common.wgsl`). A pose draws at an
//! integer offset with the same vertex stage; the oracle's ID raster puts pose k of a
//! batch in the same slot as the occluder raster and the refinement do, so the three
//! see identical coverage (which slot a pose lands in can move an edge pixel only where
//! the rasterizer rounds the offset viewport differently, like any other rasterizer).
//!
//! Memory is bounded: a group holds at most [`MAX_SLOTS`] poses, fewer where the
//! viewport is large ([`slot_budget`] per adapter) or the atlas would pass the
//! adapter's largest texture; larger batches run as several groups. Below that bound
//! the atlas starts at [`FIRST_SLOTS`] and grows with larger batches (to the next power
//! of two of the largest batch seen).

use super::arena::next_resource_id;
use super::counted::Encoder;
use super::device::GpuDevice;
use super::pyramid::{PyramidPass, buffer_levels};
use crate::reference::pyramid::LevelLayout;

/// The atlases' formats: the occluders' depth buffer, the occlusion map (view depth of
/// the nearest occluder, 0 where uncovered) and the oracle's object IDs.
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
pub const OCCLUSION_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
pub const ID_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;

/// Slots the atlas starts with: a server's first culls allocate the memory its
/// everyday batches need, so that a few concurrent clients do not grow it later.
pub const FIRST_SLOTS: u32 = 16;

/// Most poses in one group (one atlas).
pub const MAX_SLOTS: u32 = 256;

/// Memory the atlas and pyramid buffers of one group may take, bytes: 256 MiB on a
/// software adapter (it is host memory, shared with everything else), 1 GiB on a GPU.
/// The oracle's ID atlas, made only once an exact batch runs, comes on top (half as
/// much again at most: 4 of the 8 bytes a pixel the occlusion map and depth take).
pub fn slot_budget(device_type: wgpu::DeviceType) -> u64 {
    match device_type {
        wgpu::DeviceType::Cpu => 256 << 20,
        wgpu::DeviceType::Other
        | wgpu::DeviceType::IntegratedGpu
        | wgpu::DeviceType::DiscreteGpu
        | wgpu::DeviceType::VirtualGpu => 1 << 30,
    }
}

/// How many poses one atlas holds on `gpu` at `width` × `height`: the memory budget,
/// the adapter's largest texture and [`MAX_SLOTS`] each bound it.
pub fn slots_for(gpu: &GpuDevice, width: u32, height: u32) -> u32 {
    let (_, pyramid_stride) = buffer_levels(&LevelLayout::new(width, height));
    // Occlusion and depth (4 bytes a pixel each), opacity and depth pyramids (levels
    // 1.., 4 bytes a texel each); the oracle's IDs come on top.
    let per_slot = (width as u64 * height as u64) * 8 + pyramid_stride as u64 * 8;
    let by_memory = (slot_budget(gpu.info.device_type) / per_slot).max(1);
    let max_dim = gpu.device.limits().max_texture_dimension_2d;
    let by_size = (max_dim / width).max(1) as u64 * (max_dim / height).max(1) as u64;
    by_memory.min(by_size).min(MAX_SLOTS as u64) as u32
}

/// The atlas of one viewport size, and the pyramid buffers of its slots.
pub(crate) struct SlotTargets {
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) slots: u32,
    /// Slots per atlas row.
    pub(crate) cols: u32,
    pub(crate) layout: LevelLayout,
    /// The occlusion map of every slot (view depth of the nearest occluder, 0 uncovered).
    pub(crate) occlusion: Atlas,
    /// The occluders' depth, kept for the refinement (the oracle reuses it).
    pub(crate) depth: Atlas,
    /// The oracle's ID atlas, made on the first exact batch (HOM never needs it).
    pub(crate) ids: std::sync::OnceLock<Atlas>,
    /// Opacity and depth pyramids, levels 1.. ([`buffer_levels`]), slot after slot.
    pub(crate) opacity: wgpu::Buffer,
    pub(crate) pyramid_depth: wgpu::Buffer,
    /// The pyramid pass bound to these targets; nothing in it changes between batches.
    pub(crate) pyramid_bg: wgpu::BindGroup,
    /// Distinguishes these targets from earlier ones, for bind groups made on them.
    pub(crate) generation: u64,
}

/// One atlas texture and its view.
pub(crate) struct Atlas {
    pub(crate) texture: wgpu::Texture,
    pub(crate) view: wgpu::TextureView,
}

impl Atlas {
    fn new(
        device: &wgpu::Device,
        label: &str,
        format: wgpu::TextureFormat,
        w: u32,
        h: u32,
    ) -> Self {
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let view = texture.create_view(&Default::default());
        Atlas { texture, view }
    }
}

impl SlotTargets {
    /// An atlas for at least `poses` poses (a power of two, at least [`FIRST_SLOTS`]),
    /// or as many as [`slots_for`] allows.
    pub(crate) fn new(
        gpu: &GpuDevice,
        pyramid: &PyramidPass,
        (width, height): (u32, u32),
        poses: u32,
    ) -> Self {
        let layout = LevelLayout::new(width, height);
        let (_, pyramid_stride) = buffer_levels(&layout);
        let wanted = poses.max(FIRST_SLOTS).next_power_of_two();
        let slots = slots_for(gpu, width, height).min(wanted);
        let cols = (gpu.device.limits().max_texture_dimension_2d / width).max(1);
        let cols = cols.min(slots);
        let (aw, ah) = (cols * width, slots.div_ceil(cols) * height);
        let device = &gpu.device;
        let occlusion = Atlas::new(device, "occlusion atlas", OCCLUSION_FORMAT, aw, ah);
        let depth = Atlas::new(device, "depth atlas", DEPTH_FORMAT, aw, ah);
        let buf = |label| {
            gpu.buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: pyramid_stride as u64 * slots as u64 * 4,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        let opacity = buf("pyramid opacity");
        let pyramid_depth = buf("pyramid depth");
        let pyramid_bg = pyramid.bind_group(
            gpu,
            &layout,
            cols,
            &opacity,
            &pyramid_depth,
            &occlusion.view,
        );
        SlotTargets {
            width,
            height,
            slots,
            cols,
            layout,
            occlusion,
            depth,
            ids: std::sync::OnceLock::new(),
            opacity,
            pyramid_depth,
            pyramid_bg,
            generation: next_resource_id(),
        }
    }

    /// The top-left pixel of slot `slot` in the atlas.
    pub(crate) fn origin(&self, slot: u32) -> (u32, u32) {
        (
            (slot % self.cols) * self.width,
            (slot / self.cols) * self.height,
        )
    }

    /// The oracle's ID atlas, made on first use.
    pub(crate) fn ids(&self, device: &wgpu::Device) -> &Atlas {
        self.ids.get_or_init(|| {
            let size = self.occlusion.texture.size();
            Atlas::new(device, "oracle ids", ID_FORMAT, size.width, size.height)
        })
    }

    /// Sets the viewport and scissor of slot `slot` in an open render pass.
    pub(crate) fn bind_slot(&self, pass: &mut wgpu::RenderPass<'_>, slot: u32) {
        let (x, y) = self.origin(slot);
        pass.set_viewport(
            x as f32,
            y as f32,
            self.width as f32,
            self.height as f32,
            0.0,
            1.0,
        );
        pass.set_scissor_rect(x, y, self.width, self.height);
    }

    /// Records a render pass over the whole atlas: `color` (cleared to `clear`, or
    /// none) and the depth atlas (cleared and kept, or loaded and discarded).
    pub(crate) fn begin_pass<'e>(
        &self,
        encoder: &'e mut Encoder<'_>,
        label: &str,
        color: Option<(&wgpu::TextureView, wgpu::Color)>,
        depth: DepthUse,
    ) -> wgpu::RenderPass<'e> {
        let attachment = color.map(|(view, clear)| wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(clear),
                store: wgpu::StoreOp::Store,
            },
        });
        let depth_ops = match depth {
            DepthUse::ClearKeep => wgpu::Operations {
                load: wgpu::LoadOp::Clear(0.0),
                store: wgpu::StoreOp::Store,
            },
            DepthUse::ClearDiscard => wgpu::Operations {
                load: wgpu::LoadOp::Clear(0.0),
                store: wgpu::StoreOp::Discard,
            },
            DepthUse::LoadDiscard => wgpu::Operations {
                load: wgpu::LoadOp::Load,
                store: wgpu::StoreOp::Discard,
            },
        };
        let colors = [attachment];
        encoder.render_pass(&wgpu::RenderPassDescriptor {
            label: Some(label),
            color_attachments: &colors[..usize::from(colors[0].is_some())],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.depth.view,
                depth_ops: Some(depth_ops),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        })
    }
}

/// What a render pass does with the depth atlas.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum DepthUse {
    /// Occluder raster: cleared, kept for the refinement.
    ClearKeep,
    /// Oracle raster: cleared, not needed afterwards.
    ClearDiscard,
    /// Refinement: tested against, not needed afterwards.
    LoadDiscard,
}
