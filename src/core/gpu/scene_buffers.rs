//! A scene's geometry on the GPU: uploaded once, shared by every pass and pose.

use super::device::GpuDevice;
use crate::core::scene::Scene;

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
        let mut boxes: Vec<GpuTestBox> = scene
            .boxes
            .iter()
            .map(|b| GpuTestBox {
                min_obj: [
                    b.aabb.min.x,
                    b.aabb.min.y,
                    b.aabb.min.z,
                    f32::from_bits(b.object),
                ],
                max: [b.aabb.max.x, b.aabb.max.y, b.aabb.max.z, 0.0],
            })
            .collect();
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
                wgpu::BufferUsages::VERTEX,
            ),
            indices: init(
                "scene indices",
                bytemuck::cast_slice(&indices),
                wgpu::BufferUsages::INDEX,
            ),
            boxes: init(
                "scene test boxes",
                bytemuck::cast_slice(&boxes),
                wgpu::BufferUsages::STORAGE,
            ),
            objects: init(
                "scene objects",
                bytemuck::cast_slice(&objects),
                wgpu::BufferUsages::STORAGE,
            ),
        }
    }
}
