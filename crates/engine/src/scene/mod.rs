//! Scenes: objects with IDs, names, world bounds and the triangles to rasterize them.
//!
//! A scene is immutable once built. All geometry lives in two shared arrays
//! (`positions`, `indices`) in world space, so the GPU holds one vertex and one index
//! buffer per scene and an object is a range of that index buffer.
//!
//! Object IDs are `u32` indices into `objects`, assigned at load (see ARCHITECTURE.md) and
//! stable for a given file.

mod demo;
pub mod edges;
mod glb_write;
mod gltf_load;
pub mod limits;
mod subbounds;

pub use demo::demo_city;
pub use demo::demo_city_sized;
pub use glb_write::{glb_container, write_glb};
pub use gltf_load::{
    LoadError, load_glb_bytes, load_glb_bytes_within, load_path, load_path_within,
};
pub use limits::LoadLimits;
pub use subbounds::{SubBoundsParams, split_into_groups};

use glam::Vec3;

use crate::geom::Aabb;

/// One drawable object of the scene.
#[derive(Debug, Clone)]
pub struct Object {
    pub id: u32,
    pub name: String,
    /// World AABB of the object's transformed vertices.
    pub aabb: Aabb,
    /// First index in [`Scene::indices`] and the number of indices (3 per triangle).
    pub first_index: u32,
    pub index_count: u32,
    /// Raw JSON of the node's `extras`, if any (the OpenArena PVS data lives there).
    pub extras: Option<serde_json::Value>,
    /// Marked as one that will move (`core::dynamic::marks`): by its extras
    /// (`"homcull": {"dynamic": true}`) or by the upload.
    pub dynamic: bool,
}

/// Whether a node's extras mark it dynamic: `"homcull": {"dynamic": true}` (a JSON
/// `true`, nothing else).
pub fn marked_by_extras(extras: Option<&serde_json::Value>) -> bool {
    extras.and_then(|e| e.get("homcull")?.get("dynamic")?.as_bool()) == Some(true)
}

impl Object {
    pub fn triangles(&self) -> u32 {
        self.index_count / 3
    }
}

/// A compact group of one object's triangles with its own bounds ("loose bounds":
/// a tighter test than the object's box). An object is culled only if every group is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TestBox {
    pub object: u32,
    pub aabb: Aabb,
}

/// A loaded scene: objects, shared world-space geometry and per-object test boxes.
#[derive(Debug, Clone)]
pub struct Scene {
    pub name: String,
    pub objects: Vec<Object>,
    pub positions: Vec<Vec3>,
    pub indices: Vec<u32>,
    pub bounds: Aabb,
    /// Test boxes, grouped by object: object `o` owns `boxes[box_ranges[o].0 .. box_ranges[o].1]`.
    pub boxes: Vec<TestBox>,
    pub box_ranges: Vec<(u32, u32)>,
    /// Raw JSON of `scenes[0].extras` of the source file, if any.
    pub extras: Option<serde_json::Value>,
    /// Warnings raised while loading (skipped primitives and the like), counted.
    pub warnings: Vec<String>,
}

impl Scene {
    /// Builds a scene from objects whose index ranges point into `positions`/`indices`.
    /// Computes bounds and test boxes.
    pub fn new(
        name: impl Into<String>,
        objects: Vec<Object>,
        positions: Vec<Vec3>,
        indices: Vec<u32>,
    ) -> Self {
        let bounds = objects.iter().fold(Aabb::EMPTY, |b, o| b.union(o.aabb));
        let mut scene = Scene {
            name: name.into(),
            objects,
            positions,
            indices,
            bounds,
            boxes: Vec::new(),
            box_ranges: Vec::new(),
            extras: None,
            warnings: Vec::new(),
        };
        scene.rebuild_test_boxes(&SubBoundsParams::default());
        scene
    }

    /// Recomputes the per-object test boxes with the given splitting parameters.
    pub fn rebuild_test_boxes(&mut self, params: &SubBoundsParams) {
        self.boxes.clear();
        self.box_ranges.clear();
        for o in &self.objects {
            let start = self.boxes.len() as u32;
            for aabb in split_into_groups(self.triangles_of(o), &self.positions, params) {
                self.boxes.push(TestBox { object: o.id, aabb });
            }
            self.box_ranges.push((start, self.boxes.len() as u32));
        }
    }

    /// The index triples of one object.
    pub fn triangles_of(&self, o: &Object) -> &[u32] {
        &self.indices[o.first_index as usize..(o.first_index + o.index_count) as usize]
    }

    /// The corners of each of one object's triangles.
    pub fn corners_of<'a>(&'a self, o: &Object) -> impl Iterator<Item = [Vec3; 3]> + 'a {
        self.triangles_of(o)
            .chunks_exact(3)
            // Spelled out: `[0, 1, 2].map(..)` stays a call per triangle.
            .map(|t| {
                let p = &self.positions;
                [p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]]
            })
    }

    /// The corners of triangle `tri` (a global index: `indices[3 · tri ..]`).
    pub fn triangle(&self, tri: u32) -> [Vec3; 3] {
        let i = tri as usize * 3;
        let t = &self.indices[i..i + 3];
        let p = &self.positions;
        [p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]]
    }

    pub fn triangle_count(&self) -> u64 {
        self.indices.len() as u64 / 3
    }

    /// The test boxes of one object.
    pub fn boxes_of(&self, id: u32) -> &[TestBox] {
        let (a, b) = self.box_ranges[id as usize];
        &self.boxes[a as usize..b as usize]
    }
}

/// Accumulates objects and geometry; used by the loaders and the demo generator.
#[derive(Default)]
pub struct SceneBuilder {
    pub objects: Vec<Object>,
    pub positions: Vec<Vec3>,
    pub indices: Vec<u32>,
}

impl SceneBuilder {
    /// Adds an object from world-space vertices and a triangle list indexing them.
    /// Degenerate index lists (fewer than one triangle) still create the object, with no
    /// geometry and an empty box, so IDs stay aligned with the source nodes.
    pub fn push(
        &mut self,
        name: String,
        vertices: &[Vec3],
        tri_indices: &[u32],
        extras: Option<serde_json::Value>,
    ) -> u32 {
        let id = self.objects.len() as u32;
        let base = self.positions.len() as u32;
        let first_index = self.indices.len() as u32;
        self.positions.extend_from_slice(vertices);
        let whole = tri_indices.len() / 3 * 3;
        self.indices
            .extend(tri_indices[..whole].iter().map(|i| base + i));
        let index_count = whole as u32;
        let aabb = Aabb::from_points(tri_indices[..whole].iter().map(|&i| &vertices[i as usize]));
        let dynamic = marked_by_extras(extras.as_ref());
        self.objects.push(Object {
            id,
            name,
            aabb,
            first_index,
            index_count,
            extras,
            dynamic,
        });
        id
    }

    pub fn build(self, name: impl Into<String>) -> Scene {
        Scene::new(name, self.objects, self.positions, self.indices)
    }
}
