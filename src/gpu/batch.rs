//! [`GpuBackend`]: all passes of a batch of poses in one submission, one readback.
//!
//! Poses are processed in groups of up to [`MAX_SLOTS`] that share per-slot targets
//! (a texture array layer and a pyramid region per pose), so memory stays bounded
//! however large the batch: group g's raster, pyramid and test passes are recorded
//! before group g+1's, and wgpu orders them. Every pose writes its own region of one
//! visibility bitmask, copied back once at the end.

use std::sync::Arc;

use homcull_proto::Method;
use wgpu::util::DeviceExt;

use super::oracle::OraclePass;
use super::profile::{Pass, PassTimes, Stamps};
use super::pyramid::{PyramidPass, buffer_levels};
use super::raster::{
    DEPTH_FORMAT, DrawList, ID_FORMAT, OCCLUSION_FORMAT, RasterKind, RasterPass, indirect_draws,
};
use super::refine::{RefineParams, RefinePass};
use super::scene_buffers::SceneBuffers;
use super::test_pass::{GroupParams, TestConfig, TestPass};
use super::{GpuContext, GpuError, UNIFORM_SLOT, slotted};
use crate::camera::PoseUniform;
use crate::cull::{CullError, CullSettings, Culler, PosePlan, PreparedScene, words_per_pose};
use crate::hom::level_thresholds;
use crate::hom::pyramid::LevelLayout;

/// Most poses sharing the per-slot targets at once.
pub const MAX_SLOTS: u32 = 16;
/// Memory the per-slot targets may take, bytes; fewer slots at large viewports. The
/// oracle's ID buffers, made only once an exact batch runs, come on top (half as much
/// again at most: 4 of the 8 bytes a pixel the occlusion map and depth take).
const SLOT_MEMORY_BUDGET: u64 = 256 << 20;

/// Per-slot render targets and pyramid buffers for one viewport size.
struct SlotTargets {
    width: u32,
    height: u32,
    slots: u32,
    layout: LevelLayout,
    /// The occlusion map of every slot (view depth of the nearest occluder, 0 uncovered).
    occlusion: Layers,
    /// Per slot: the occluders' depth, kept for the refinement (the oracle reuses it).
    depth: Layers,
    /// The oracle's ID buffers, made on the first exact batch (HOM never needs them).
    ids: std::sync::OnceLock<Layers>,
    /// Opacity and depth pyramids, levels 1.. ([`buffer_levels`]).
    opacity: wgpu::Buffer,
    pyramid_depth: wgpu::Buffer,
    /// The pyramid pass bound to these targets; nothing in it changes between batches.
    pyramid_bg: wgpu::BindGroup,
}

/// A texture array with a layer per slot, its per-layer views and one array view.
struct Layers {
    texture: wgpu::Texture,
    layers: Vec<wgpu::TextureView>,
    array: wgpu::TextureView,
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
    fn new(device: &wgpu::Device, pyramid: &PyramidPass, width: u32, height: u32) -> Self {
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
    fn ids(&self, device: &wgpu::Device) -> &Layers {
        self.ids.get_or_init(|| {
            let size = Self::extent(self.width, self.height, self.slots);
            Layers::new(device, "oracle ids", ID_FORMAT, size)
        })
    }
}

/// Pipelines and render targets shared by every scene on one device. Pipelines are
/// compiled once; the slot targets are written and consumed within one submission, so
/// one set serves every scene, and a server with many scenes holds it once.
pub struct SharedPasses {
    raster: RasterPass,
    refine: RefinePass,
    pyramid: PyramidPass,
    test: TestPass,
    oracle: OraclePass,
    /// Slot targets of the last viewport size, and the lock that serialises batches.
    targets: std::sync::Mutex<Option<SlotTargets>>,
}

impl SharedPasses {
    fn new(ctx: &GpuContext) -> Self {
        let raster = RasterPass::new(ctx);
        SharedPasses {
            refine: RefinePass::new(ctx, &raster),
            raster,
            pyramid: PyramidPass::new(ctx),
            test: TestPass::new(ctx),
            oracle: OraclePass::new(ctx),
            targets: Default::default(),
        }
    }
}

/// The GPU culler of one scene: its buffers, and the device's shared passes.
pub struct GpuBackend {
    ctx: Arc<GpuContext>,
    scene: SceneBuffers,
    passes: Arc<SharedPasses>,
    /// `(first_index, index_count)` of every object, for draw calls.
    draws: Vec<(u32, u32)>,
    /// GPU time per pass since profiling started (`Some` while profiling).
    profile: Option<PassTimes>,
}

fn storage(device: &wgpu::Device, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    let fallback = [0u8; 16];
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: if bytes.is_empty() { &fallback } else { bytes },
        usage: wgpu::BufferUsages::STORAGE,
    })
}

/// A 16-byte uniform slot of `buffer` for dynamic-offset binding.
fn uniform_slot(buffer: &wgpu::Buffer) -> wgpu::BindingResource<'_> {
    wgpu::BindingResource::Buffer(wgpu::BufferBinding {
        buffer,
        offset: 0,
        size: wgpu::BufferSize::new(16),
    })
}

/// The refinement's draws: indirect (filtered on the GPU) or one call per candidate.
enum RefineDraws {
    Indirect {
        buffer: wgpu::Buffer,
        ranges: Vec<(u32, u32)>,
        filter_bg: wgpu::BindGroup,
    },
    Direct(Vec<Vec<(u32, u32, u32)>>),
}

/// What the refinement of one batch records with.
struct RefineInputs {
    draws: RefineDraws,
    /// Indirect draws per group (for the filter dispatch).
    group_draws: Vec<u32>,
    refined: wgpu::Buffer,
    raster_bg: wgpu::BindGroup,
}

/// Draw calls `(first_index, index_count, object_id)` for the given objects.
fn object_draws(ranges: &[(u32, u32)], ids: &[u32]) -> Vec<(u32, u32, u32)> {
    ids.iter()
        .map(|&id| {
            let (first, count) = ranges[id as usize];
            (first, count, id)
        })
        .collect()
}

impl GpuBackend {
    pub fn new(ctx: Arc<GpuContext>, prep: &PreparedScene) -> Self {
        GpuBackend {
            scene: SceneBuffers::new(&ctx.device, &prep.scene),
            passes: ctx
                .shared_passes
                .get_or_init(|| Arc::new(SharedPasses::new(&ctx)))
                .clone(),
            draws: prep
                .scene
                .objects
                .iter()
                .map(|o| (o.first_index, o.index_count))
                .collect(),
            profile: None,
            ctx,
        }
    }

    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }

    /// Locks the shared slot targets (serialising batches on this device), sized for
    /// `width` × `height`.
    fn targets(&self, width: u32, height: u32) -> std::sync::MutexGuard<'_, Option<SlotTargets>> {
        let mut t = self
            .passes
            .targets
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        if t.as_ref()
            .is_none_or(|t| (t.width, t.height) != (width, height))
        {
            *t = None; // free the old targets before allocating new ones
            *t = Some(SlotTargets::new(
                &self.ctx.device,
                &self.passes.pyramid,
                width,
                height,
            ));
        }
        t
    }

    /// Buffers and bind groups of the refinement pass for a batch (`crate::gpu::refine`):
    /// every pose's candidates as draws (filtered on the GPU to the box test's survivors
    /// when draws are indirect), the second bitmask, and per-pose and per-group params.
    fn refine_inputs(
        &self,
        plans: &[PosePlan],
        groups: &[(u32, u32)],
        box_mask: &wgpu::Buffer,
        occlusion: &wgpu::TextureView,
        words: u32,
    ) -> RefineInputs {
        let device = &self.ctx.device;
        let pass = &self.passes.refine;
        let draws = plans
            .iter()
            .map(|p| object_draws(&self.draws, &p.candidates));
        let mut group_draws = Vec::new();
        let draws = if self.ctx.indirect_draws {
            let (buffer, ranges) = indirect_draws(device, draws, wgpu::BufferUsages::STORAGE);
            let draw_pose: Vec<u32> = ranges
                .iter()
                .enumerate()
                .flat_map(|(p, &(_, n))| std::iter::repeat_n(p as u32, n as usize))
                .collect();
            let params: Vec<RefineParams> = groups
                .iter()
                .map(|&(a, b)| {
                    let first = ranges[a as usize].0;
                    let (last, n) = ranges[b as usize - 1];
                    RefineParams {
                        a: first,
                        b: last + n - first,
                        words_per_pose: words,
                        _pad: 0,
                    }
                })
                .collect();
            group_draws = params.iter().map(|p| p.b).collect();
            let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("refine filter params"),
                contents: &slotted(&params),
                usage: wgpu::BufferUsages::UNIFORM,
            });
            let draw_pose = storage(device, "draw pose", bytemuck::cast_slice(&draw_pose));
            let filter_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("refine filter"),
                layout: &pass.filter_layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: uniform_slot(&params),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: box_mask.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: draw_pose.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: buffer.as_entire_binding(),
                    },
                ],
            });
            RefineDraws::Indirect {
                buffer,
                ranges,
                filter_bg,
            }
        } else {
            RefineDraws::Direct(draws.collect())
        };
        let refined = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("refined visibility mask"),
            size: (plans.len() as u32 * words) as u64 * 4,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let pose_params: Vec<RefineParams> = groups
            .iter()
            .flat_map(|&(a, b)| {
                (a..b).map(move |p| RefineParams {
                    a: p - a,
                    b: p,
                    words_per_pose: words,
                    _pad: 0,
                })
            })
            .collect();
        let pose_params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("refine params"),
            contents: &slotted(&pose_params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let raster_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("refine raster"),
            layout: &pass.raster_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(occlusion),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: box_mask.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: refined.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: uniform_slot(&pose_params),
                },
            ],
        });
        RefineInputs {
            draws,
            group_draws,
            refined,
            raster_bg,
        }
    }

    /// Records the refinement of poses `range` (group `g`), after its test pass.
    fn record_refine(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        t: &SlotTargets,
        pose_bg: &wgpu::BindGroup,
        r: &RefineInputs,
        g: usize,
        range: std::ops::Range<u32>,
    ) {
        let pass = &self.passes.refine;
        if let RefineDraws::Indirect { filter_bg, .. } = &r.draws {
            pass.record_filter(encoder, filter_bg, g as u32, r.group_draws[g]);
        }
        let first = range.start;
        for p in range {
            let draws = match &r.draws {
                RefineDraws::Indirect { buffer, ranges, .. } => {
                    let (first, count) = ranges[p as usize];
                    DrawList::Indirect(buffer, first, count)
                }
                RefineDraws::Direct(lists) => DrawList::Direct(lists[p as usize].clone()),
            };
            pass.record_raster(
                encoder,
                &t.depth.layers[(p - first) as usize],
                pose_bg,
                &r.raster_bg,
                p,
                &self.scene,
                draws,
            );
        }
    }

    /// Reads back a buffer region (blocking); used for the bitmask and by tests.
    pub fn read_buffer(
        &self,
        encoder: wgpu::CommandEncoder,
        src: &wgpu::Buffer,
        size: u64,
    ) -> Result<Vec<u8>, GpuError> {
        let device = &self.ctx.device;
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = encoder;
        encoder.copy_buffer_to_buffer(src, 0, &staging, 0, size);
        let t = std::time::Instant::now();
        self.ctx.queue.submit([encoder.finish()]);
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

    /// Runs the occluder raster and pyramid of one group of plans (at most one group
    /// of slots) and returns the opacity and depth pyramids in the CPU twin's layout
    /// (`LevelLayout`, one after another per pose; level 0 read back from the occlusion
    /// map). For GPU-vs-CPU tests and debug images.
    pub fn pyramids(
        &mut self,
        plans: &[PosePlan],
        s: &CullSettings,
    ) -> Result<(Vec<f32>, Vec<f32>), GpuError> {
        let guard = self.targets(plans[0].cam.width, plans[0].cam.height);
        let slots = guard.as_ref().expect("targets exist").slots;
        if plans.len() > slots as usize {
            return Err(GpuError::Readback(format!(
                "{} poses do not fit the {slots} pyramid slots",
                plans.len()
            )));
        }
        self.record_with(guard.as_ref().expect("targets exist"), plans, s, false)?;
        let t = guard.as_ref().expect("targets exist after a batch");
        let n = plans.len();
        let (_, stride) = buffer_levels(&t.layout);
        let read = |buffer| -> Result<Vec<f32>, GpuError> {
            let enc = self.ctx.device.create_command_encoder(&Default::default());
            let bytes = self.read_buffer(enc, buffer, stride as u64 * n as u64 * 4)?;
            Ok(bytemuck::pod_collect_to_vec(&bytes))
        };
        let (upper_opacity, upper_depth) = (read(&t.opacity)?, read(&t.pyramid_depth)?);
        let level0 = self.read_occlusion(t, n as u32)?;
        let (w, h) = t.layout.dims[0];
        let pixels = (w * h) as usize;
        let upper = t.layout.total as usize - pixels;
        let (mut opacity, mut depth) = (Vec::new(), Vec::new());
        for k in 0..n {
            let d0 = &level0[k * pixels..][..pixels];
            opacity.extend(d0.iter().map(|&d| if d > 0.0 { 1.0 } else { 0.0 }));
            depth.extend_from_slice(d0);
            let at = k * stride as usize;
            opacity.extend_from_slice(&upper_opacity[at..at + upper]);
            depth.extend_from_slice(&upper_depth[at..at + upper]);
        }
        Ok((opacity, depth))
    }

    /// The first `layers` occlusion-map layers (view depth, 0 where uncovered), one
    /// `width × height` image after another.
    fn read_occlusion(&self, t: &SlotTargets, layers: u32) -> Result<Vec<f32>, GpuError> {
        let (w, h) = (t.width, t.height);
        let row = (w * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let size = row as u64 * h as u64 * layers as u64;
        let buffer = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("occlusion map readback"),
            size,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
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
        let bytes = self.read_buffer(enc, &buffer, size)?;
        let padded: Vec<f32> = bytemuck::pod_collect_to_vec(&bytes);
        Ok(padded
            .chunks_exact(row as usize / 4)
            .flat_map(|r| &r[..w as usize])
            .copied()
            .collect())
    }

    fn record_and_read(
        &mut self,
        plans: &[PosePlan],
        s: &CullSettings,
    ) -> Result<Vec<Vec<u32>>, GpuError> {
        let profile = self.profile.is_some();
        let (masks, times) = {
            let guard = self.targets(plans[0].cam.width, plans[0].cam.height);
            self.record_with(guard.as_ref().expect("targets exist"), plans, s, profile)?
        };
        if let (Some(total), Some(t)) = (&mut self.profile, times) {
            for (sum, ms) in total.ms.iter_mut().zip(t.ms) {
                *sum += ms;
            }
            total.poses += t.poses;
        }
        Ok(masks)
    }

    /// Records, submits and reads back one batch on the (locked) slot targets `t`;
    /// with `profile` (and timestamp support), also its GPU time per pass.
    fn record_with(
        &self,
        t: &SlotTargets,
        plans: &[PosePlan],
        s: &CullSettings,
        profile: bool,
    ) -> Result<(Vec<Vec<u32>>, Option<PassTimes>), GpuError> {
        let started = std::time::Instant::now();
        let (w, h) = (plans[0].cam.width, plans[0].cam.height);
        let device = &self.ctx.device;
        let p_count = plans.len() as u32;
        let slots = t.slots;
        let words = words_per_pose(self.draws.len()) as u32;
        let exact = s.options.method == Method::Exact;

        let pose_uniforms: Vec<PoseUniform> = plans
            .iter()
            .map(|p| PoseUniform::new(&p.cam, p.deb.depth[0]))
            .collect();
        let poses = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("poses"),
            contents: &slotted(&pose_uniforms),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::STORAGE,
        });
        let pose_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("pose"),
            layout: &self.passes.raster.pose_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &poses,
                    offset: 0,
                    size: wgpu::BufferSize::new(UNIFORM_SLOT),
                }),
            }],
        });
        let mask = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("visibility mask"),
            size: (p_count * words) as u64 * 4,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });

        // Groups of poses sharing the slots, and their candidate ranges.
        let groups: Vec<(u32, u32)> = (0..p_count)
            .step_by(slots as usize)
            .map(|a| (a, (a + slots).min(p_count)))
            .collect();
        let mut candidates: Vec<[u32; 2]> = Vec::new();
        let mut group_params = Vec::new();
        for &(a, b) in &groups {
            let start = candidates.len() as u32;
            for p in a..b {
                candidates.extend(plans[p as usize].test_boxes.iter().map(|&bx| [p, bx]));
            }
            let count = candidates.len() as u32 - start;
            group_params.push(if exact {
                GroupParams {
                    a: w,
                    b: h,
                    c: words,
                    d: a,
                }
            } else {
                GroupParams {
                    a: start,
                    b: count,
                    c: a,
                    d: 0,
                }
            });
        }
        let group_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("group params"),
            contents: &slotted(&group_params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        // Objects each pose rasterizes: all candidates for the oracle, occluders otherwise.
        let drawn = |p: &PosePlan| -> Vec<(u32, u32, u32)> {
            object_draws(
                &self.draws,
                if exact {
                    &p.candidates
                } else {
                    &p.occluders.ids
                },
            )
        };
        let indirect = self
            .ctx
            .indirect_draws
            .then(|| indirect_draws(device, plans.iter().map(drawn), wgpu::BufferUsages::empty()));
        let draw_list = |p: u32| match &indirect {
            Some((buffer, ranges)) => {
                let (first, count) = ranges[p as usize];
                DrawList::Indirect(buffer, first, count)
            }
            None => DrawList::Direct(drawn(&plans[p as usize])),
        };
        let mut encoder = device.create_command_encoder(&Default::default());
        let mut refined_mask = None;
        let stamps_per_group = if exact { 2 } else { 3 + s.refines() as u32 };
        let mut stamps = if profile && self.ctx.timestamps {
            Stamps::new(device, 1 + groups.len() as u32 * stamps_per_group)
        } else {
            None
        };
        let mut mark = |encoder: &mut wgpu::CommandEncoder, pass: Option<Pass>| {
            if let Some(st) = &mut stamps {
                st.mark(encoder, pass);
            }
        };
        mark(&mut encoder, None);

        if exact {
            let ids = t.ids(device);
            let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("oracle"),
                layout: &self.passes.oracle.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: uniform_slot(&group_buf),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(&ids.array),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: mask.as_entire_binding(),
                    },
                ],
            });
            for (g, &(a, b)) in groups.iter().enumerate() {
                for p in a..b {
                    self.passes.raster.record(
                        &mut encoder,
                        RasterKind::ObjectIds,
                        &ids.layers[(p - a) as usize],
                        &t.depth.layers[(p - a) as usize],
                        &pose_bg,
                        p,
                        &self.scene,
                        draw_list(p),
                    );
                }
                mark(&mut encoder, Some(Pass::IdRaster));
                self.passes
                    .oracle
                    .record(&mut encoder, &bg, g as u32, w, h, b - a);
                mark(&mut encoder, Some(Pass::Collect));
            }
        } else {
            let deb0 = &plans[0].deb;
            let cfg = TestConfig::new(
                s.options.method,
                s.options.deb,
                &t.layout,
                &level_thresholds(s.options.threshold, t.layout.levels()),
                deb0.tile,
                deb0.cols,
                deb0.rows,
                words,
            );
            let cfg_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("test config"),
                contents: bytemuck::bytes_of(&cfg),
                usage: wgpu::BufferUsages::UNIFORM,
            });
            let deb_tiles: Vec<f32> = plans
                .iter()
                .flat_map(|p| p.deb.depth.iter().copied())
                .collect();
            let cand_buf = storage(device, "candidates", bytemuck::cast_slice(&candidates));
            let deb_buf = storage(device, "deb tiles", bytemuck::cast_slice(&deb_tiles));
            let test_bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("test"),
                layout: &self.passes.test.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: cfg_buf.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: uniform_slot(&group_buf),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: poses.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 3,
                        resource: self.scene.boxes.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 4,
                        resource: cand_buf.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 5,
                        resource: deb_buf.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 6,
                        resource: t.opacity.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 7,
                        resource: t.pyramid_depth.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 8,
                        resource: mask.as_entire_binding(),
                    },
                    wgpu::BindGroupEntry {
                        binding: 9,
                        resource: wgpu::BindingResource::TextureView(&t.occlusion.array),
                    },
                ],
            });
            let refine = s
                .refines()
                .then(|| self.refine_inputs(plans, &groups, &mask, &t.occlusion.array, words));
            for (g, &(a, b)) in groups.iter().enumerate() {
                for p in a..b {
                    self.passes.raster.record(
                        &mut encoder,
                        RasterKind::OccluderDepth,
                        &t.occlusion.layers[(p - a) as usize],
                        &t.depth.layers[(p - a) as usize],
                        &pose_bg,
                        p,
                        &self.scene,
                        draw_list(p),
                    );
                }
                mark(&mut encoder, Some(Pass::OccluderRaster));
                self.passes
                    .pyramid
                    .record(&mut encoder, &t.pyramid_bg, &t.layout, b - a);
                mark(&mut encoder, Some(Pass::Pyramid));
                self.passes
                    .test
                    .record(&mut encoder, &test_bg, g as u32, group_params[g].b);
                mark(&mut encoder, Some(Pass::BoxTest));
                if let Some(r) = &refine {
                    self.record_refine(&mut encoder, t, &pose_bg, r, g, a..b);
                    mark(&mut encoder, Some(Pass::Refine));
                }
            }
            if let Some(r) = refine {
                refined_mask = Some(r.refined);
            }
        }
        tracing::debug!(
            target: "homcull::timing",
            poses = p_count,
            record_ms = started.elapsed().as_secs_f64() * 1e3,
            "recorded a batch"
        );
        let resolved = stamps.as_ref().map(|st| st.resolve(&mut encoder));
        let result = refined_mask.as_ref().unwrap_or(&mask);
        let bytes = self.read_buffer(encoder, result, (p_count * words) as u64 * 4)?;
        let all: &[u32] = bytemuck::cast_slice(&bytes);
        let masks = all
            .chunks_exact(words as usize)
            .map(|c| c.to_vec())
            .collect();
        let times = match (&stamps, resolved) {
            (Some(st), Some((buffer, size))) => {
                let encoder = device.create_command_encoder(&Default::default());
                let ticks = self.read_buffer(encoder, buffer, size)?;
                let mut times = PassTimes {
                    poses: p_count as u64,
                    ..Default::default()
                };
                let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&ticks);
                st.accumulate(&ticks, self.ctx.queue.get_timestamp_period(), &mut times);
                Some(times)
            }
            _ => None,
        };
        Ok((masks, times))
    }
}

impl Culler for GpuBackend {
    fn describe(&self) -> String {
        self.ctx.describe()
    }

    fn set_profiling(&mut self, on: bool) -> bool {
        self.profile = (on && self.ctx.timestamps).then(PassTimes::default);
        self.profile.is_some()
    }

    fn take_pass_times(&mut self) -> Option<PassTimes> {
        self.profile.as_mut().map(std::mem::take)
    }

    fn visibility(
        &mut self,
        _prep: &PreparedScene,
        plans: &[PosePlan],
        s: &CullSettings,
    ) -> Result<Vec<Vec<u32>>, CullError> {
        if plans.is_empty() {
            return Ok(Vec::new());
        }
        Ok(self.record_and_read(plans, s)?)
    }
}
