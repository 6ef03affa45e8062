//! The scene at a version: the previous one with the changed objects placed again
//! from their loaded geometry (never from the previous placement, so rounding does
//! not accumulate), their bounds and test boxes recomputed, and the object BVH and the
//! occluder database's refitted to the new bounds (built again once many objects
//! moved).

use glam::{Mat4, Vec3};

use super::{Changes, Placement};
use crate::bvh::BoxBvh;
use crate::cull::{PreparedScene, clear_bit, empty_mask, has_bit, set_bit};
use crate::geom::Aabb;
use crate::occluders::OccluderDb;
use crate::scene::{Object, Scene};

/// The first and last vertex an object's triangles use, or `None` without triangles.
pub fn vertex_span(scene: &Scene, o: &Object) -> Option<(usize, usize)> {
    let tris = scene.triangles_of(o);
    let lo = *tris.iter().min()? as usize;
    let hi = *tris.iter().max()? as usize;
    Some((lo, hi))
}

/// Bitmask of the objects whose vertex spans overlap another object's: moving one
/// alone would move part of the other. (Scenes built by the loaders give every object
/// vertices of its own, so this is normally empty.)
pub fn shared_vertices(scene: &Scene) -> Vec<u32> {
    let mut spans: Vec<(usize, usize, u32)> = scene
        .objects
        .iter()
        .filter_map(|o| vertex_span(scene, o).map(|(a, b)| (a, b, o.id)))
        .collect();
    spans.sort_unstable();
    let mut shared = empty_mask(scene.objects.len());
    // The furthest end so far and whose it was.
    let mut reach: Option<(usize, u32)> = None;
    for &(a, b, id) in &spans {
        if let Some((end, owner)) = reach
            && a <= end
        {
            set_bit(&mut shared, id);
            set_bit(&mut shared, owner);
        }
        if reach.is_none_or(|(end, _)| b > end) {
            reach = Some((b, id));
        }
    }
    shared
}

/// The scene of `changes.version`: `previous` with each changed object placed anew
/// from `base` (the scene as loaded).
pub fn advance(base: &PreparedScene, previous: &PreparedScene, changes: &Changes) -> PreparedScene {
    let mut scene = previous.scene.clone();
    let n = scene.objects.len();
    let mut moving = if previous.moving.is_empty() {
        empty_mask(n)
    } else {
        previous.moving.clone()
    };
    for &(id, p) in &changes.objects {
        let swept = place(&base.scene, &mut scene, id, p.as_ref(), changes.horizon_s);
        if swept {
            set_bit(&mut moving, id);
        } else {
            clear_bit(&mut moving, id);
        }
    }
    scene.bounds = scene
        .objects
        .iter()
        .fold(Aabb::EMPTY, |b, o| b.union(o.aabb));
    // The trees are refitted (linear, cheap) until a quarter of the objects moved since
    // they were built: refitting keeps answers exact but lets the boxes of inner nodes
    // grow loose, which slows queries.
    let moved = previous.moved_since_build + changes.objects.len();
    let rebuild = moved * 4 > n;
    let boxes: Vec<Aabb> = scene.objects.iter().map(|o| o.aabb).collect();
    let refit = (!rebuild).then(|| previous.bvh.refitted(&boxes)).flatten();
    let refitted = refit.is_some();
    let bvh = refit.unwrap_or_else(|| BoxBvh::new(&boxes));
    // Moving objects do not occlude (see the module docs of `core::dynamic`).
    let ids: Vec<u32> = base
        .occluders
        .ids
        .iter()
        .copied()
        .filter(|&id| !has_bit(&moving, id))
        .collect();
    let occluders = if ids == previous.occluders.ids {
        previous.occluders.moved(&scene, !refitted)
    } else {
        OccluderDb::from_ids(&scene, base.occluders.params, ids)
    };
    PreparedScene {
        scene,
        bvh,
        occluders,
        // Empty when nothing moves (see `PreparedScene::moving`).
        moving: if moving.iter().any(|&w| w != 0) {
            moving
        } else {
            Vec::new()
        },
        moved_since_build: if refitted { moved } else { 0 },
        copies: previous
            .copies
            .without_moved(n, changes.objects.iter().map(|&(id, _)| id)),
        edges: std::sync::Arc::clone(&previous.edges),
    }
}

/// Places object `id` of `scene` by `p` from its loaded geometry in `base`; returns
/// whether its boxes now bound a motion.
fn place(base: &Scene, scene: &mut Scene, id: u32, p: Option<&Placement>, horizon_s: f32) -> bool {
    let i = id as usize;
    let loaded = &base.objects[i];
    let (lo, hi) = base.box_ranges[i];
    let boxes = lo as usize..hi as usize;
    let Some((a, b)) = vertex_span(base, loaded) else {
        return false; // nothing to place
    };
    let Some(p) = p else {
        // Back as loaded, bit for bit.
        scene.positions[a..=b].copy_from_slice(&base.positions[a..=b]);
        scene.boxes[boxes.clone()].copy_from_slice(&base.boxes[boxes]);
        scene.objects[i].aabb = loaded.aabb;
        return false;
    };
    let m = p.matrix;
    for (to, from) in scene.positions[a..=b]
        .iter_mut()
        .zip(&base.positions[a..=b])
    {
        *to = m.transform_point3(*from);
    }
    // The bounds of the placed vertices, widened by the rounding `m * v` may have: the
    // GPU applies `m` in its vertex stage, where it may round otherwise (a fused
    // multiply-add), and its vertices must lie in the same bounds and boxes.
    let placed = {
        let o = &scene.objects[i];
        let exact = Aabb::from_points(
            scene
                .triangles_of(o)
                .iter()
                .map(|&v| &scene.positions[v as usize]),
        );
        let pad = rounding_pad(&m, loaded.aabb);
        Aabb::new(exact.min - pad, exact.max + pad)
    };
    let t = p.sweep_s(horizon_s);
    for k in boxes {
        let moved = transformed_box(&m, base.boxes[k].aabb);
        let part = intersection(moved, placed);
        scene.boxes[k].aabb = p.swept(part, placed, t);
    }
    scene.objects[i].aabb = p.swept(placed, placed, t);
    t > 0.0
}

/// A box holding every point of `b` transformed by `m` in f32: the box of the
/// transformed corners, widened by [`rounding_pad`], so that each vertex as the
/// snapshot or the GPU's vertex stage computes it is inside.
pub fn transformed_box(m: &Mat4, b: Aabb) -> Aabb {
    if b.is_empty() {
        return b;
    }
    let corners = b.corners().map(|c| m.transform_point3(c));
    let boxed = Aabb::from_points(corners.iter());
    let pad = rounding_pad(m, b);
    Aabb::new(boxed.min - pad, boxed.max + pad)
}

/// A bound, per axis, on how far `m * v` for a point `v` of `b` computed in f32 lies
/// from the exact product, whatever the order of its sums and whether its products
/// fuse (glam's `transform_point3` on the CPU, a WGSL `mat4x4 * vec4` on the GPU):
/// each of its four terms and three sums rounds by at most half an ulp of the sum of
/// magnitudes; eight ulps of it covers them with room.
pub fn rounding_pad(m: &Mat4, b: Aabb) -> Vec3 {
    let reach = b.min.abs().max(b.max.abs());
    let rows = m.transpose();
    let size = |r: glam::Vec4| r.truncate().abs().dot(reach) + r.w.abs();
    Vec3::new(size(rows.x_axis), size(rows.y_axis), size(rows.z_axis)) * (8.0 * f32::EPSILON)
}

fn intersection(a: Aabb, b: Aabb) -> Aabb {
    Aabb::new(a.min.max(b.min), a.max.min(b.max))
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use glam::Quat;
    use homcull_proto::{ObjectTransform, TransformsRequest};

    use super::*;
    use crate::dynamic::Dynamics;
    use crate::occluders::OccluderParams;
    use crate::scene::demo_city_sized;

    fn prepared() -> Arc<PreparedScene> {
        Arc::new(PreparedScene::new(
            demo_city_sized(3),
            OccluderParams::default(),
        ))
    }

    fn turn(id: u32, angle: f32, velocity: Option<[f32; 3]>) -> ObjectTransform {
        ObjectTransform {
            id,
            rotation: Some(Quat::from_rotation_y(angle).to_array()),
            translation: Some([1.5, 0.25, -2.0]),
            velocity,
            ..Default::default()
        }
    }

    #[test]
    fn placing_a_copy_or_its_original_drops_the_copy() {
        use crate::scene::SceneBuilder;
        // Two identical quads (the second a copy of the first) and a third elsewhere.
        let quad = |x: f32| [0.0, 1.0].map(|dy| [0.0, 1.0].map(|dx| Vec3::new(x + dx, dy, 0.0)));
        let mut b = SceneBuilder::default();
        for (i, x) in [0.0, 0.0, 5.0].into_iter().enumerate() {
            let q = quad(x);
            b.push(
                format!("quad_{i}"),
                &[q[0][0], q[0][1], q[1][1], q[1][0]],
                &[0, 1, 2, 0, 2, 3],
                None,
            );
        }
        let base = Arc::new(PreparedScene::new(
            b.build("quads"),
            OccluderParams::default(),
        ));
        assert_eq!(base.copies.pairs(), &[(1, 0)]);
        for (moved, kept) in [(2, true), (0, false), (1, false)] {
            let mut d = Dynamics::new(base.clone());
            let req = TransformsRequest {
                objects: vec![turn(moved, 0.5, None)],
                horizon_ms: None,
            };
            d.apply(&req, usize::MAX).unwrap();
            let next = advance(&base, &base, &d.take_changes(0).unwrap());
            assert_eq!(next.copies.is_copy(1), kept, "object {moved} placed");
        }
    }

    #[test]
    fn placed_objects_lie_inside_their_bounds_and_boxes() {
        let base = prepared();
        let mut d = Dynamics::new(base.clone());
        let ids: Vec<u32> = (0..base.scene.objects.len() as u32).step_by(7).collect();
        let req = TransformsRequest {
            objects: ids
                .iter()
                .map(|&id| turn(id, 0.3 + id as f32, None))
                .collect(),
            horizon_ms: None,
        };
        d.apply(&req, usize::MAX).unwrap();
        let next = advance(&base, &base, &d.take_changes(0).unwrap());
        for &id in &ids {
            let o = &next.scene.objects[id as usize];
            let inside = |b: &Aabb, v: Vec3| b.min.cmple(v).all() && b.max.cmpge(v).all();
            for tri in next.scene.corners_of(o) {
                for v in tri {
                    assert!(
                        inside(&o.aabb, v),
                        "object {id}: vertex {v} outside its bounds"
                    );
                }
                // Every triangle lies in the union of the object's boxes; here: each
                // vertex in some box.
                for v in tri {
                    let boxes = next.scene.boxes_of(id);
                    assert!(boxes.iter().any(|b| inside(&b.aabb, v)), "object {id}: {v}");
                }
            }
            let loaded = &base.scene.objects[id as usize];
            assert_ne!(o.aabb, loaded.aabb, "object {id} moved");
        }
        // Objects not updated are untouched, and the occluders are the same objects.
        assert_eq!(next.scene.objects[1].aabb, base.scene.objects[1].aabb);
        assert_eq!(next.occluders.ids, base.occluders.ids);
        assert!(next.moving.is_empty() || !next.moving.iter().any(|&w| w != 0));
        // Back as loaded: bit for bit.
        let back = TransformsRequest {
            objects: ids
                .iter()
                .map(|&id| ObjectTransform {
                    id,
                    ..Default::default()
                })
                .collect(),
            horizon_ms: None,
        };
        d.apply(&back, usize::MAX).unwrap();
        let again = advance(&base, &next, &d.take_changes(1).unwrap());
        assert_eq!(again.scene.positions, base.scene.positions);
        assert_eq!(again.scene.boxes, base.scene.boxes);
    }

    #[test]
    fn moving_objects_are_swept_and_leave_the_occluders() {
        let base = prepared();
        let occluder = base.occluders.ids[0];
        let mut d = Dynamics::new(base.clone());
        let req = TransformsRequest {
            objects: vec![turn(occluder, 0.0, Some([10.0, 0.0, 0.0]))],
            horizon_ms: Some(500.0),
        };
        assert_eq!(d.apply(&req, usize::MAX), Ok(1));
        let next = advance(&base, &base, &d.take_changes(0).unwrap());
        assert!(next.is_moving(occluder));
        assert!(!next.occluders.ids.contains(&occluder));
        let o = &next.scene.objects[occluder as usize];
        let loaded = &base.scene.objects[occluder as usize];
        // 10 m/s for 0.5 s: 5 m further in x.
        let grown = o.aabb.extent().x - loaded.aabb.extent().x;
        assert!((grown - 5.0).abs() < 1e-3, "{grown}");
        // A horizon of 0: no sweep, an occluder again.
        let zero = TransformsRequest {
            objects: vec![],
            horizon_ms: Some(0.0),
        };
        d.apply(&zero, usize::MAX).unwrap();
        let still = advance(&base, &next, &d.take_changes(1).unwrap());
        assert!(!still.is_moving(occluder) && still.occluders.ids.contains(&occluder));
    }

    #[test]
    fn a_refused_update_changes_nothing() {
        let base = prepared();
        let mut d = Dynamics::new(base.clone());
        let n = base.scene.objects.len() as u32;
        let req = TransformsRequest {
            objects: vec![turn(0, 1.0, None), turn(n, 1.0, None)],
            horizon_ms: None,
        };
        let e = d.apply(&req, usize::MAX).unwrap_err();
        assert!(
            e.to_string()
                .contains(&format!("object {n} does not exist")),
            "{e}"
        );
        assert_eq!(d.version(), 0);
        assert_eq!(d.take_changes(0), None);
        let twice = TransformsRequest {
            objects: vec![turn(2, 1.0, None), turn(2, 0.5, None)],
            horizon_ms: None,
        };
        assert!(
            d.apply(&twice, usize::MAX)
                .unwrap_err()
                .to_string()
                .contains("twice")
        );
        let many = TransformsRequest {
            objects: vec![turn(0, 1.0, None), turn(1, 1.0, None)],
            horizon_ms: None,
        };
        assert!(matches!(
            d.apply(&many, 1),
            Err(super::super::TransformError::TooMany { .. })
        ));
        assert_eq!(d.version(), 0);
    }

    #[test]
    fn objects_sharing_vertices_are_found() {
        let mut scene = demo_city_sized(2);
        assert!(shared_vertices(&scene).iter().all(|&w| w == 0));
        // Point object 1's first triangle at object 0's first vertex.
        let first = scene.objects[1].first_index as usize;
        scene.indices[first] = scene.indices[scene.objects[0].first_index as usize];
        let shared = shared_vertices(&scene);
        assert!(has_bit(&shared, 0) && has_bit(&shared, 1));
    }
}
