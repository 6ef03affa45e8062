//! A scene's geometry on the GPU: uploaded once as loaded, shared by every pass and
//! pose. Objects move by their placement matrices, which the vertex stage applies
//! (`raster.wgsl`): a move writes one matrix per object (64 bytes, whatever its
//! size) and its test boxes, never its vertices.
//!
//! The CPU backends place the vertices with the same f32 matrix (`dynamic::snapshot`);
//! the GPU may round the product otherwise (a fused multiply-add), by less than the
//! pad the snapshot widens every placed bound and test box with, so the boxes hold
//! the GPU's vertices too. The GPU's HOM, its refinement and its oracle share the one
//! vertex stage, so they agree on where every moved triangle is, as on static ones
//! (an identity matrix leaves a vertex bit for bit as it was).

use glam::Mat4;

use super::device::GpuDevice;
use crate::scene::{Scene, TestBox};

/// One test box as the test kernel reads it (`TestBox` in `test.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuTestBox {
    /// xyz: min corner; w: object ID as bits.
    pub min_obj: [f32; 4],
    pub max: [f32; 4],
}
const _: () = assert!(std::mem::size_of::<GpuTestBox>() == 32);

/// Vertex, index, object, placement and test-box buffers of one scene.
pub struct SceneBuffers {
    /// The vertices as loaded.
    pub vertices: wgpu::Buffer,
    /// Each object's placement, column-major (`Placement::matrix`; identity as loaded).
    pub placements: wgpu::Buffer,
    pub indices: wgpu::Buffer,
    pub boxes: wgpu::Buffer,
    /// `[first_index, index_count]` of every object, from which the refinement's
    /// draws are expanded on the GPU.
    pub objects: wgpu::Buffer,
}

impl SceneBuffers {
    /// The buffers of `scene` as loaded (every placement the identity).
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
        let placements = vec![Mat4::IDENTITY.to_cols_array(); scene.objects.len().max(1)];
        SceneBuffers {
            vertices: init(
                "scene vertices",
                bytemuck::cast_slice(&verts),
                wgpu::BufferUsages::VERTEX,
            ),
            placements: init(
                "scene placements",
                bytemuck::cast_slice(&placements),
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
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
    /// Writes the placement and test boxes of each object `changed` (its matrix, and
    /// its boxes from `scene`, the same scene moved: same objects and box counts). The
    /// writes reach the GPU before the next submission and after every earlier one
    /// (the queue orders them), so a batch in flight keeps the version it was
    /// recorded with. Answers the bytes written.
    pub fn update(&self, gpu: &GpuDevice, scene: &Scene, changed: &[(u32, Mat4)]) -> u64 {
        const MATRIX: u64 = 64;
        const BOX: u64 = std::mem::size_of::<GpuTestBox>() as u64;
        let mut bytes = 0;
        for &(id, m) in changed {
            let cols = m.to_cols_array();
            gpu.queue.write_buffer(
                &self.placements,
                id as u64 * MATRIX,
                bytemuck::cast_slice(&cols),
            );
            bytes += MATRIX;
            let (lo, hi) = scene.box_ranges[id as usize];
            if hi > lo {
                let boxes: Vec<GpuTestBox> = scene.boxes[lo as usize..hi as usize]
                    .iter()
                    .map(GpuTestBox::from)
                    .collect();
                gpu.queue
                    .write_buffer(&self.boxes, lo as u64 * BOX, bytemuck::cast_slice(&boxes));
                bytes += boxes.len() as u64 * BOX;
            }
        }
        bytes
    }
}
