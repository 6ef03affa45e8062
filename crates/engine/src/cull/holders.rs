//! The triangles that may hold each open edge of the occluders (`scene::edges`), found
//! with a BVH over the occluder triangles: here rather than in `scene`, which comes
//! before the BVH.

use glam::Vec3;
use rayon::prelude::*;

use crate::bvh::BoxBvh;
use crate::geom::Aabb;
use crate::scene::Scene;
use crate::scene::edges::{EdgeNeighbours, HOLD_TOLERANCE_M, MAX_HOLDERS, held};

/// The holder candidates of every edge of `objects`' triangles that `edges` gives no
/// neighbour, by slot (`tri * 3 + e`) ascending: triangles of `objects` whose box meets
/// the edge's and that hold part of it as the scene is now.
pub fn find(scene: &Scene, objects: &[u32], edges: &EdgeNeighbours) -> Vec<(u32, Vec<u32>)> {
    let corners = |tri: u32| scene.triangle(tri);
    let grow = Vec3::splat(HOLD_TOLERANCE_M);
    let tris: Vec<u32> = objects
        .iter()
        .flat_map(|&id| {
            let o = &scene.objects[id as usize];
            let first = o.first_index / 3;
            first..first + o.index_count / 3
        })
        .collect();
    let boxes: Vec<Aabb> = tris
        .iter()
        .map(|&t| {
            let b = Aabb::from_points(&corners(t));
            Aabb::new(b.min - grow, b.max + grow)
        })
        .collect();
    let bvh = BoxBvh::new(&boxes);
    let mut found: Vec<(u32, Vec<u32>)> = tris
        .par_iter()
        .flat_map_iter(|&tri| (0..3).map(move |e| (tri, e)))
        .filter(|&(tri, e)| edges.is_open(tri, e))
        .map(|(tri, e)| {
            let c = corners(tri);
            let (a, b) = (c[e], c[(e + 1) % 3]);
            let mut hits = Vec::new();
            bvh.box_query(&Aabb::from_points(&[a, b]), |k| {
                let s = tris[k as usize];
                if s != tri && hits.len() < MAX_HOLDERS && held(a, b, corners(s)).is_some() {
                    hits.push(s);
                }
            });
            hits.sort_unstable();
            (tri * 3 + e as u32, hits)
        })
        .filter(|(_, hits)| !hits.is_empty())
        .collect();
    found.sort_unstable_by_key(|&(slot, _)| slot);
    found
}
