//! Which triangle shares each edge of an occluder's triangles: where a region map's
//! first drawn surface continues across an edge and where it may end.
//!
//! Two triangles of one object share an edge when they have its two corners at the
//! same positions, bit for bit (meshes repeat a vertex per normal or texture seam, so
//! indices alone would split surfaces that are whole). An edge with one triangle, or
//! with three or more, has no neighbour: the map treats it as a place where the
//! surface may end, which only ever makes it cull less. Neighbours are found once per
//! scene, for the objects that may occlude, and hold for every later version of it: a
//! moved object moves its corners by one matrix, so corners that were equal stay equal.

use std::collections::HashMap;

use glam::Vec3;

use super::Scene;

/// No neighbour across an edge.
const NONE: u32 = u32::MAX;

/// An edge by its two corner positions (their bits), sorted.
type EdgeKey = ([u32; 3], [u32; 3]);

/// The neighbour across each edge of each triangle of the scene's occluder objects,
/// by global triangle index (`Scene::indices` / 3); edge `e` runs from corner `e` to
/// corner `e + 1`.
#[derive(Debug, Default)]
pub struct EdgeNeighbours {
    /// Three entries per triangle of the scene (`NONE` where there is none, and for
    /// every triangle of an object that was not indexed).
    across: Vec<u32>,
}

impl EdgeNeighbours {
    /// Indexes the triangles of `objects` (the occluder objects) of `scene`.
    pub fn build(scene: &Scene, objects: &[u32]) -> Self {
        let mut across = vec![NONE; scene.indices.len()];
        let key = |p: Vec3| p.to_array().map(f32::to_bits);
        for &id in objects {
            let o = &scene.objects[id as usize];
            let first = o.first_index / 3;
            // Edge (its corner positions, sorted) → the first two (triangle, edge)
            // slots that have it, packed as `tri * 3 + e`, and how many have it.
            let mut seen: HashMap<EdgeKey, ([u32; 2], u32)> = HashMap::new();
            for (k, corners) in scene.corners_of(o).enumerate() {
                let slot = (first + k as u32) * 3;
                for e in 0..3 {
                    let (a, b) = (key(corners[e]), key(corners[(e + 1) % 3]));
                    if a == b {
                        continue; // a degenerate edge bounds nothing
                    }
                    let edge = if a < b { (a, b) } else { (b, a) };
                    let entry = seen.entry(edge).or_insert(([NONE; 2], 0));
                    if entry.1 < 2 {
                        entry.0[entry.1 as usize] = slot + e as u32;
                    }
                    entry.1 += 1;
                }
            }
            for ([s, t], n) in seen.into_values() {
                if n == 2 {
                    across[s as usize] = t / 3;
                    across[t as usize] = s / 3;
                }
            }
        }
        EdgeNeighbours { across }
    }

    /// The triangle across edge `e` of triangle `tri`, if exactly one shares it.
    pub fn of(&self, tri: u32, e: usize) -> Option<u32> {
        let n = *self.across.get(tri as usize * 3 + e)?;
        (n != NONE).then_some(n)
    }
}
