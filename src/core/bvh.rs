//! Bounding-volume hierarchy over object boxes (obvhs), with frustum traversal.
//!
//! obvhs builds a high-quality binary BVH (PLOC + reinsertion); homcull only adds the
//! query it needs: every item whose box intersects a camera frustum. The same type
//! indexes the scene's objects and the occluder database.

use obvhs::{BvhBuildParams, bvh2::Bvh2, bvh2::builder::build_bvh2};

use crate::core::camera::Camera;
use crate::core::geom::Aabb;

struct Item(obvhs::aabb::Aabb);

impl obvhs::Boundable for Item {
    fn aabb(&self) -> obvhs::aabb::Aabb {
        self.0
    }
}

/// A BVH over a list of boxes; queries return indices into that list.
pub struct BoxBvh {
    bvh: Bvh2,
    /// Maps BVH primitive slots to the caller's item index (empty boxes are left out).
    items: Vec<u32>,
    /// The box of each item, to test the primitives of a leaf one by one.
    boxes: Vec<Aabb>,
}

impl BoxBvh {
    /// Builds over `boxes`; empty boxes can never be returned by a query.
    pub fn new(boxes: &[Aabb]) -> Self {
        let items: Vec<u32> = (0..boxes.len() as u32)
            .filter(|&i| !boxes[i as usize].is_empty())
            .collect();
        let prims: Vec<Item> = items
            .iter()
            .map(|&i| Item(boxes[i as usize].to_obvhs()))
            .collect();
        let bvh = if prims.is_empty() {
            Bvh2::default()
        } else {
            build_bvh2(
                &prims,
                BvhBuildParams::fast_build(),
                &mut Default::default(),
            )
        };
        BoxBvh {
            bvh,
            items,
            boxes: boxes.to_vec(),
        }
    }

    /// Calls `f` with the index of every box that intersects the camera's frustum
    /// (conservatively: see [`Camera::intersects`]).
    pub fn frustum_query(&self, cam: &Camera, mut f: impl FnMut(u32)) {
        let nodes = &self.bvh.nodes;
        if nodes.is_empty() {
            return;
        }
        let visible = |i: u32| {
            let b = nodes[i as usize].aabb();
            cam.intersects(&Aabb::new(b.min.into(), b.max.into()))
        };
        let mut stack = vec![0u32];
        while let Some(i) = stack.pop() {
            if !visible(i) {
                continue;
            }
            let node = &nodes[i as usize];
            if node.is_leaf() {
                for slot in node.first_index..node.first_index + node.prim_count {
                    let item = self.items[self.bvh.primitive_indices[slot as usize] as usize];
                    // A leaf can hold several boxes: test each one, not just the leaf's.
                    if cam.intersects(&self.boxes[item as usize]) {
                        f(item);
                    }
                }
            } else {
                stack.push(node.first_index);
                stack.push(node.first_index + 1);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::camera::look_at;
    use glam::Vec3;

    #[test]
    fn frustum_query_matches_brute_force() {
        let mut boxes = Vec::new();
        for i in 0..40 {
            for j in 0..40 {
                let p = Vec3::new(
                    i as f32 * 3.0 - 60.0,
                    (i * j % 7) as f32,
                    j as f32 * 3.0 - 60.0,
                );
                boxes.push(Aabb::new(p, p + Vec3::splat(1.0 + (i % 3) as f32)));
            }
        }
        boxes.push(Aabb::EMPTY);
        let bvh = BoxBvh::new(&boxes);
        for (eye, target) in [
            (Vec3::new(0.0, 2.0, 0.0), Vec3::new(10.0, 2.0, 3.0)),
            (Vec3::new(-70.0, 30.0, -70.0), Vec3::ZERO),
            (Vec3::new(0.0, 100.0, 0.0), Vec3::new(0.1, 0.0, 0.0)),
        ] {
            let cam = look_at(eye, target, 320, 200);
            let mut got = Vec::new();
            bvh.frustum_query(&cam, |i| got.push(i));
            got.sort_unstable();
            let want: Vec<u32> = (0..boxes.len() as u32)
                .filter(|&i| !boxes[i as usize].is_empty() && cam.intersects(&boxes[i as usize]))
                .collect();
            assert_eq!(got, want);
            assert!(!got.is_empty());
        }
    }
}
