//! Occluder raster and oracle ID raster.
//!
//! Both draw scene triangles with the same vertex stage (`raster.wgsl`, `@invariant`
//! position) and the same reversed-Z depth test, so a pixel an occluder covers in the
//! occlusion map is a pixel it covers in the oracle's ID buffer: HOM's coverage and the
//! ground truth never disagree by rasterization. The occluder raster writes the view
//! depth of the nearest occluder per pixel (0 = uncovered) to an `r32float` target and
//! keeps its depth buffer for the refinement (`crate::gpu::refine`); the oracle writes
//! the nearest object's ID to an `r32uint` target.

use super::counted::Encoder;
use super::device::GpuDevice;
use super::encode::{UNIFORM_SLOT, storage_entry, uniform_entry};
use super::scene_buffers::SceneBuffers;
use super::targets::{DepthUse, SlotTargets};

pub use super::prelude::NO_OBJECT;
pub use super::targets::{DEPTH_FORMAT, ID_FORMAT, OCCLUSION_FORMAT};

/// What a raster pass writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RasterKind {
    OccluderDepth,
    ObjectIds,
}

/// The two raster pipelines and their pose binding.
pub struct RasterPass {
    pub pose_layout: wgpu::BindGroupLayout,
    /// `raster.wgsl`: the refinement pass draws with the same vertex stage.
    pub module: wgpu::ShaderModule,
    depth_pipeline: wgpu::RenderPipeline,
    id_pipeline: wgpu::RenderPipeline,
}

const VERTEX_BUFFERS: [Option<wgpu::VertexBufferLayout<'static>>; 1] =
    [Some(wgpu::VertexBufferLayout {
        array_stride: 12,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &wgpu::vertex_attr_array![0 => Float32x3],
    })];

impl RasterPass {
    pub fn new(ctx: &GpuDevice) -> Self {
        let device = &ctx.device;
        // The early-depth entry point validates only where the feature is enabled.
        let source = if ctx.early_depth_test {
            concat!(
                include_str!("shaders/raster.wgsl"),
                include_str!("shaders/refine_early.wgsl")
            )
        } else {
            include_str!("shaders/raster.wgsl")
        };
        let module = ctx.shader("raster", source);
        let pose_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("pose"),
            entries: &[
                uniform_entry(0, true, wgpu::ShaderStages::VERTEX),
                wgpu::BindGroupLayoutEntry {
                    visibility: wgpu::ShaderStages::VERTEX,
                    ..storage_entry(1, true)
                },
            ],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("raster"),
            bind_group_layouts: &[Some(&pose_layout)],
            immediate_size: 0,
        });
        // Nearest wins (reversed Z).
        let pipeline = |fs: &str, format: wgpu::TextureFormat| {
            triangle_pipeline(
                device,
                &layout,
                &module,
                fs,
                &[Some(format.into())],
                DepthTest::KeepNearest,
            )
        };
        RasterPass {
            depth_pipeline: pipeline("fs_depth", OCCLUSION_FORMAT),
            id_pipeline: pipeline("fs_id", ID_FORMAT),
            pose_layout,
            module,
        }
    }

    /// Binds the scene's geometry in an open render pass.
    pub fn bind_geometry(pass: &mut wgpu::RenderPass<'_>, scene: &SceneBuffers) {
        pass.set_vertex_buffer(0, scene.vertices.slice(..));
        pass.set_index_buffer(scene.indices.slice(..), wgpu::IndexFormat::Uint32);
    }

    /// Records `draws` in an open render pass with the scene's geometry bound.
    pub fn draw(pass: &mut wgpu::RenderPass<'_>, draws: DrawList<'_>) {
        match draws {
            DrawList::Direct(list) => {
                for &(first, count, id) in list {
                    if count > 0 {
                        pass.draw_indexed(first..first + count, 0, id..id + 1);
                    }
                }
            }
            DrawList::Indirect(buffer, first, count) => {
                pass.multi_draw_indexed_indirect(buffer, first as u64 * DRAW_ARGS_BYTES, count);
            }
            DrawList::IndirectCount {
                buffer,
                first,
                counts,
                at,
                max,
            } => {
                let offset = first as u64 * DRAW_ARGS_BYTES;
                pass.multi_draw_indexed_indirect_count(buffer, offset, counts, at as u64 * 4, max);
            }
        }
    }

    /// Records the raster of the poses `group` (slot = pose − first pose) into one
    /// render pass over the atlas: the occlusion map and its depth (kept for the
    /// refinement), or the oracle's IDs (depth discarded). `draws(p)` gives pose `p`'s.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn record_group<'d>(
        &self,
        encoder: &mut Encoder<'_>,
        kind: RasterKind,
        t: &SlotTargets,
        poses: &wgpu::BindGroup,
        group: std::ops::Range<u32>,
        scene: &SceneBuffers,
        draws: impl Fn(u32) -> DrawList<'d>,
    ) {
        let (target, clear, depth, pipeline) = match kind {
            RasterKind::OccluderDepth => (
                &t.occlusion.view,
                wgpu::Color::TRANSPARENT,
                DepthUse::ClearKeep,
                &self.depth_pipeline,
            ),
            RasterKind::ObjectIds => (
                &t.ids
                    .get()
                    .expect("ID atlas made before the oracle raster")
                    .view,
                wgpu::Color {
                    r: NO_OBJECT as f64,
                    g: 0.0,
                    b: 0.0,
                    a: 0.0,
                },
                DepthUse::ClearDiscard,
                &self.id_pipeline,
            ),
        };
        let mut pass = t.begin_pass(encoder, "raster", Some((target, clear)), depth);
        pass.set_pipeline(pipeline);
        Self::bind_geometry(&mut pass, scene);
        let first = group.start;
        for p in group {
            t.bind_slot(&mut pass, p - first);
            pass.set_bind_group(0, poses, &[(p as u64 * UNIFORM_SLOT) as u32]);
            Self::draw(&mut pass, draws(p));
        }
    }
}

/// How a raster pipeline uses the depth buffer (reversed Z: larger is nearer).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DepthTest {
    /// Keep the nearest fragment per pixel (occluder and oracle rasters).
    KeepNearest,
    /// Pass fragments at or in front of what the buffer holds; write nothing.
    NotBehind,
    /// Every fragment runs; nothing is written.
    Off,
}

/// A pipeline drawing scene triangles with `raster.wgsl`'s vertex stage (`@invariant`
/// position, shared by every raster pass so their coverage and depth are identical)
/// and the fragment entry `fs`.
pub fn triangle_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    fs: &str,
    targets: &[Option<wgpu::ColorTargetState>],
    depth_test: DepthTest,
) -> wgpu::RenderPipeline {
    let (compare, write) = match depth_test {
        DepthTest::KeepNearest => (wgpu::CompareFunction::Greater, true),
        DepthTest::NotBehind => (wgpu::CompareFunction::GreaterEqual, false),
        DepthTest::Off => (wgpu::CompareFunction::Always, false),
    };
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(fs),
        layout: Some(layout),
        vertex: vertex_state(module),
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(write),
            depth_compare: Some(compare),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(fs),
            compilation_options: Default::default(),
            targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

fn vertex_state(module: &wgpu::ShaderModule) -> wgpu::VertexState<'_> {
    wgpu::VertexState {
        module,
        entry_point: Some("vs"),
        compilation_options: Default::default(),
        buffers: &VERTEX_BUFFERS,
    }
}

/// Bytes of one indexed indirect draw's arguments.
pub const DRAW_ARGS_BYTES: u64 = std::mem::size_of::<wgpu::util::DrawIndexedIndirectArgs>() as u64;

/// One pose's object draws: `(first_index, index_count, object_id)` each, either
/// recorded one call per object or read from an indirect buffer (`first` and `count`
/// in draws) in one call, or the first `counts[at]` (at most `max`) of them.
pub enum DrawList<'a> {
    Direct(&'a [(u32, u32, u32)]),
    Indirect(&'a wgpu::Buffer, u32, u32),
    IndirectCount {
        buffer: &'a wgpu::Buffer,
        first: u32,
        counts: &'a wgpu::Buffer,
        at: u32,
        max: u32,
    },
}

/// The indirect arguments of every pose's draws, one after another, and each pose's
/// `(first, count)` among them (draws of empty objects left out).
pub(crate) fn indirect_args(
    per_pose: impl Iterator<Item = Vec<(u32, u32, u32)>>,
) -> (Vec<u8>, Vec<(u32, u32)>) {
    let mut args: Vec<u8> = Vec::new();
    let mut ranges = Vec::new();
    let mut n = 0u32;
    for draws in per_pose {
        let first = n;
        for (first_index, index_count, id) in draws.into_iter().filter(|d| d.1 > 0) {
            let a = wgpu::util::DrawIndexedIndirectArgs {
                index_count,
                instance_count: 1,
                first_index,
                base_vertex: 0,
                first_instance: id,
            };
            args.extend_from_slice(a.as_bytes());
            n += 1;
        }
        ranges.push((first, n - first));
    }
    (args, ranges)
}

/// Draw calls `(first_index, index_count, object_id)` for the given objects.
pub(crate) fn object_draws(ranges: &[(u32, u32)], ids: &[u32]) -> Vec<(u32, u32, u32)> {
    ids.iter()
        .map(|&id| {
            let (first, count) = ranges[id as usize];
            (first, count, id)
        })
        .collect()
}
