//! A scene's geometry on the GPU: uploaded once, shared by every pass and pose; when
//! objects move, their vertices and test boxes are written again in place.

use super::device::GpuDevice;
use crate::core::dynamic::snapshot::vertex_span;
use crate::core::scene::{Scene, TestBox};

/// One test box as the test kernel reads it (`TestBox` in `test.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuTestBox {
    /// xyz: min corner; w: object ID as bits.
    pub min_obj: [f32; 4],
    pub max: [f32; 4],
}
const _: () = assert!(std::mem::size_of::<GpuTestBox>() == 32);

/// Vertex, index, object and test-box buffers of one scene.
pub struct SceneBuffers {
    pub vertices: wgpu::Buffer,
    pub indices: wgpu::Buffer,
    pub boxes: wgpu::Buffer,
    /// `[first_index, index_count]` of every object, from which the refinement's
    /// draws are expanded on the GPU.
    pub objects: wgpu::Buffer,
}

impl SceneBuffers {
    pub fn new(gpu: &GpuDevice, scene: &Scene) -> Self {
        let init = |label, contents: &[u8], usage| gpu.buffer_init(label, contents, usage);
        let verts: Vec<[f32; 3]> = scene.positions.iter().map(|p| p.to_array()).collect();
        let mut indices = scene.indices.clone();
        if indices.is_empty() {
            indices.extend([0, 0, 0]); // wgpu rejects empty buffers; never drawn
        }
        let mut boxes: Vec<GpuTestBox> = scene.boxes.iter().map(GpuTestBox::from).collect();
        if boxes.is_empty() {
            boxes.push(bytemuck::Zeroable::zeroed());
        }
        let mut objects: Vec<[u32; 2]> = scene
            .objects
            .iter()
            .map(|o| [o.first_index, o.index_count])
            .collect();
        if objects.is_empty() {
            objects.push([0, 0]);
        }
        SceneBuffers {
            vertices: init(
                "scene vertices",
                bytemuck::cast_slice(&verts),
                wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            ),
            indices: init(
                "scene indices",
                bytemuck::cast_slice(&indices),
                wgpu::BufferUsages::INDEX,
            ),
            boxes: init(
                "scene test boxes",
                bytemuck::cast_slice(&boxes),
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            ),
            objects: init(
                "scene objects",
                bytemuck::cast_slice(&objects),
                wgpu::BufferUsages::STORAGE,
            ),
        }
    }
}

impl From<&TestBox> for GpuTestBox {
    fn from(b: &TestBox) -> Self {
        GpuTestBox {
            min_obj: [
                b.aabb.min.x,
                b.aabb.min.y,
                b.aabb.min.z,
                f32::from_bits(b.object),
            ],
            max: [b.aabb.max.x, b.aabb.max.y, b.aabb.max.z, 0.0],
        }
    }
}

impl SceneBuffers {
    /// Writes the vertices and test boxes of the objects `changed` from `scene` (the
    /// same scene moved: same objects, index ranges and box counts). The writes reach
    /// the GPU before the next submission and after every earlier one (the queue
    /// orders them), so a batch in flight keeps the version it was recorded with.
    pub fn update(&self, gpu: &GpuDevice, scene: &Scene, changed: &[u32]) {
        const VERTEX: u64 = 12;
        const BOX: u64 = std::mem::size_of::<GpuTestBox>() as u64;
        for &id in changed {
            let o = &scene.objects[id as usize];
            if let Some((a, b)) = vertex_span(scene, o) {
                let verts: Vec<[f32; 3]> = scene.positions[a..=b]
                    .iter()
                    .map(|p| p.to_array())
                    .collect();
                gpu.queue.write_buffer(
                    &self.vertices,
                    a as u64 * VERTEX,
                    bytemuck::cast_slice(&verts),
                );
            }
            let (lo, hi) = scene.box_ranges[id as usize];
            if hi > lo {
                let boxes: Vec<GpuTestBox> = scene.boxes[lo as usize..hi as usize]
                    .iter()
                    .map(GpuTestBox::from)
                    .collect();
                gpu.queue
                    .write_buffer(&self.boxes, lo as u64 * BOX, bytemuck::cast_slice(&boxes));
            }
        }
    }
}
