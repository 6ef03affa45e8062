//! Geometry of the demo city: axis-aligned rectangles on the ground, box meshes, and
//! the [`City`] being built (a scene builder plus helpers that add one object each).

use glam::Vec3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::super::SceneBuilder;
use super::{Span, between};

/// An axis-aligned rectangle on the ground (x, z).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Rect {
    pub(super) x0: f32,
    pub(super) z0: f32,
    pub(super) x1: f32,
    pub(super) z1: f32,
}

impl Rect {
    pub(super) fn from_spans(x: Span, z: Span) -> Self {
        Rect {
            x0: x.lo,
            z0: z.lo,
            x1: x.hi,
            z1: z.hi,
        }
    }

    pub(super) fn shrunk(self, d: f32) -> Self {
        Rect {
            x0: self.x0 + d,
            z0: self.z0 + d,
            x1: self.x1 - d,
            z1: self.z1 - d,
        }
    }

    pub(super) fn width(self) -> f32 {
        self.x1 - self.x0
    }

    pub(super) fn depth(self) -> f32 {
        self.z1 - self.z0
    }

    pub(super) fn overlaps(self, o: Rect) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.z0 < o.z1 && o.z0 < self.z1
    }

    /// The solid box standing on this rectangle from `y0` to `y1`.
    pub(super) fn extruded(self, y0: f32, y1: f32) -> (Vec3, Vec3) {
        (
            Vec3::new(self.x0, y0, self.z0),
            Vec3::new(self.x1, y1, self.z1),
        )
    }

    /// A square of half side `r` around a point.
    pub(super) fn around(x: f32, z: f32, r: f32) -> Self {
        Rect {
            x0: x - r,
            z0: z - r,
            x1: x + r,
            z1: z + r,
        }
    }
}

/// Vertices and a triangle list for one object, before it joins the scene.
#[derive(Debug, Default)]
pub(super) struct Mesh {
    pub(super) vertices: Vec<Vec3>,
    pub(super) indices: Vec<u32>,
}

/// The faces of a box as corner quads (corner `i` takes max on axis `k` iff bit `k`
/// of `i` is set), each counter-clockwise seen from outside so normals point out.
pub(super) const BOX_QUADS: [[u32; 4]; 6] = [
    [0, 4, 6, 2], // −x
    [1, 3, 7, 5], // +x
    [0, 1, 5, 4], // −y
    [2, 6, 7, 3], // +y
    [0, 2, 3, 1], // −z
    [4, 5, 7, 6], // +z
];

impl Mesh {
    /// A closed box: 8 corners, 12 outward-facing triangles.
    pub(super) fn add_box(&mut self, min: Vec3, max: Vec3) {
        let base = self.vertices.len() as u32;
        self.vertices.extend((0..8).map(|i| {
            Vec3::new(
                if i & 1 == 0 { min.x } else { max.x },
                if i & 2 == 0 { min.y } else { max.y },
                if i & 4 == 0 { min.z } else { max.z },
            )
        }));
        for [a, b, c, d] in BOX_QUADS {
            self.indices
                .extend([a, b, c, a, c, d].map(|corner| base + corner));
        }
    }

    /// A closed octahedron (a cheap tree crown): 6 vertices, 8 outward triangles.
    pub(super) fn add_octahedron(&mut self, centre: Vec3, radius: Vec3) {
        let base = self.vertices.len() as u32;
        // Vertex 2k is the −axis tip and 2k+1 the +axis tip of axis k.
        for axis in 0..3 {
            for sign in [-1.0, 1.0] {
                let mut offset = Vec3::ZERO;
                offset[axis] = sign * radius[axis];
                self.vertices.push(centre + offset);
            }
        }
        for octant in 0..8u32 {
            let tip = |axis: u32| base + 2 * axis + ((octant >> axis) & 1);
            let (x, y, z) = (tip(0), tip(1), tip(2));
            // (x, y, z) winds counter-clockwise seen from outside iff the octant has an
            // even number of negative axes; otherwise swap two corners.
            let negatives = 3 - octant.count_ones();
            if negatives % 2 == 0 {
                self.indices.extend([x, y, z]);
            } else {
                self.indices.extend([x, z, y]);
            }
        }
    }

    /// A flat ground tile at y = 0 facing up: 2 triangles.
    pub(super) fn add_ground_quad(&mut self, r: Rect) {
        let base = self.vertices.len() as u32;
        self.vertices.extend([
            Vec3::new(r.x0, 0.0, r.z0),
            Vec3::new(r.x0, 0.0, r.z1),
            Vec3::new(r.x1, 0.0, r.z1),
            Vec3::new(r.x1, 0.0, r.z0),
        ]);
        self.indices.extend([0, 1, 2, 0, 2, 3].map(|i| base + i));
    }
}

/// The scene under construction plus running counters for prop names.
#[derive(Default)]
pub(super) struct City {
    pub(super) builder: SceneBuilder,
    pub(super) cars: usize,
    pub(super) trees: usize,
    pub(super) benches: usize,
}

impl City {
    pub(super) fn push(&mut self, name: String, mesh: &Mesh) {
        self.builder.push(name, &mesh.vertices, &mesh.indices, None);
    }

    /// A car of about 4.5 × 1.5 × 1.8 m: body plus cabin, long side along x or z.
    pub(super) fn add_car(&mut self, x: f32, z: f32, along_x: bool) {
        let (half_long, half_wide) = if along_x { (2.25, 0.9) } else { (0.9, 2.25) };
        let (cabin_long, cabin_wide) = if along_x { (1.2, 0.8) } else { (0.8, 1.2) };
        let mut mesh = Mesh::default();
        mesh.add_box(
            Vec3::new(x - half_long, 0.0, z - half_wide),
            Vec3::new(x + half_long, 0.9, z + half_wide),
        );
        mesh.add_box(
            Vec3::new(x - cabin_long, 0.9, z - cabin_wide),
            Vec3::new(x + cabin_long, 1.5, z + cabin_wide),
        );
        // Cars drive (`homcull animate`): marked dynamic, as a file would mark them.
        let extras = serde_json::json!({"homcull": {"dynamic": true}});
        let name = format!("car_{}", self.cars);
        self.builder
            .push(name, &mesh.vertices, &mesh.indices, Some(extras));
        self.cars += 1;
    }

    /// A tree: a trunk box and a crown (an octahedron or a box) in one object.
    /// Returns the radius of its crown.
    pub(super) fn add_tree(&mut self, rng: &mut ChaCha8Rng, x: f32, z: f32, max_crown: f32) -> f32 {
        let trunk = between(rng, (2.2, 3.5));
        let crown = between(rng, (1.2, max_crown.max(1.3)));
        let mut mesh = Mesh::default();
        mesh.add_box(
            Vec3::new(x - 0.2, 0.0, z - 0.2),
            Vec3::new(x + 0.2, trunk, z + 0.2),
        );
        if rng.random_bool(0.5) {
            let centre = Vec3::new(x, trunk + crown * 0.9, z);
            mesh.add_octahedron(centre, Vec3::new(crown, crown * 1.2, crown));
        } else {
            let half = crown * 0.8;
            mesh.add_box(
                Vec3::new(x - half, trunk - 0.3, z - half),
                Vec3::new(x + half, trunk + crown * 1.6, z + half),
            );
        }
        self.push(format!("tree_{}", self.trees), &mesh);
        self.trees += 1;
        crown
    }

    /// A bench: seat and backrest boxes, 1.8 m long, along x or z.
    pub(super) fn add_bench(&mut self, x: f32, z: f32, along_x: bool) {
        let (half_long, half_deep) = (0.9, 0.25);
        let mut mesh = Mesh::default();
        let (seat_min, seat_max, back_min, back_max) = if along_x {
            (
                Vec3::new(x - half_long, 0.0, z - half_deep),
                Vec3::new(x + half_long, 0.45, z + half_deep),
                Vec3::new(x - half_long, 0.45, z + half_deep - 0.08),
                Vec3::new(x + half_long, 0.9, z + half_deep),
            )
        } else {
            (
                Vec3::new(x - half_deep, 0.0, z - half_long),
                Vec3::new(x + half_deep, 0.45, z + half_long),
                Vec3::new(x + half_deep - 0.08, 0.45, z - half_long),
                Vec3::new(x + half_deep, 0.9, z + half_long),
            )
        };
        mesh.add_box(seat_min, seat_max);
        mesh.add_box(back_min, back_max);
        self.push(format!("bench_{}", self.benches), &mesh);
        self.benches += 1;
    }
}
