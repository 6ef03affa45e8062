//! The exact oracle audited against the map's PVS pixel by pixel.
//!
//! The object-level check (`Pvs::may_see`: may object o be seen from cluster c?) rests
//! on how the scene's converter assigned faces to objects, and on oa_dm1 that
//! assignment has a flaw: `cluster_0` also holds copies of every brush model's faces
//! (doors, lifts). No BSP leaf references those copies, so `cluster_0`'s
//! `ref_clusters` omit the clusters they stand in, and when the oracle sees a door it
//! credits the pixels to `cluster_0` (the copy and the model lie at the same depth,
//! and the lower ID wins ties). [`brush_model_copies`] finds such objects.
//!
//! The pixel audit does not depend on that mapping. It renders the CPU twin of the
//! exact oracle (the GPU oracle's sampling rules, in exact arithmetic), takes the
//! world point each pixel sees, steps it back towards the eye (a surface bounds an
//! empty leaf; the step puts the point in the leaf the ray arrived through) and asks
//! the BSP tree for that point's cluster, which the camera cluster's PVS row must list.
//! That is the PVS's own promise, checked on every pixel.

use std::collections::HashSet;

use glam::Vec3;

use homcull_engine::camera::Camera;
use homcull_engine::pvs::Pvs;
use homcull_engine::reference::raster::raster_ids;
use homcull_engine::scene::{Object, Scene};

/// How far a seen point is moved back along its ray before its cluster is looked up.
const STEP_BACK_M: f32 = 0.05;

/// What one pose's pixels say about the PVS.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PixelAudit {
    /// The camera's cluster.
    pub cluster: i32,
    /// Pixels some triangle covers.
    pub pixels: u64,
    /// Pixels whose seen point lies in a cluster the camera's PVS row does not list.
    /// The PVS promises none.
    pub outside: u64,
    /// Pixels whose stepped-back point is still in solid (a ray grazing a wall); they
    /// say nothing either way.
    pub solid: u64,
    /// Objects owning at least one pixel: the CPU oracle's visible set, ascending.
    pub visible: Vec<u32>,
}

/// Audits one pose; `None` if the eye is in solid (no PVS row applies).
pub fn audit_pixels(pvs: &Pvs, scene: &Scene, cam: &Camera) -> Option<PixelAudit> {
    let cluster = pvs.cluster_at(cam.position);
    if cluster < 0 {
        return None;
    }
    let (w, h) = (cam.width as usize, cam.height as usize);
    let mut ids = vec![u32::MAX; w * h];
    let mut depth = vec![0.0f32; w * h];
    let triangles = scene
        .objects
        .iter()
        .flat_map(|o| scene.corners_of(o).map(move |t| (o.id, t)));
    raster_ids(cam, triangles, &mut ids, &mut depth);

    let mut audit = PixelAudit {
        cluster,
        ..Default::default()
    };
    let mut visible = vec![false; scene.objects.len()];
    let unproject = cam.unprojector();
    for (i, (&object, &d)) in ids.iter().zip(&depth).enumerate() {
        let Some(seen) = visible.get_mut(object as usize) else {
            continue; // uncovered
        };
        *seen = true;
        audit.pixels += 1;
        let (x, y) = ((i % w) as u32, (i / w) as u32);
        let hit = unproject(x, y, d);
        let back = (cam.position - hit).normalize_or_zero() * STEP_BACK_M.min(d * 0.5);
        let seen_from = pvs.cluster_at(hit + back);
        if seen_from < 0 {
            audit.solid += 1;
        } else if !pvs.cluster_may_see(cluster, seen_from) {
            audit.outside += 1;
        }
    }
    audit.visible = (0..scene.objects.len() as u32)
        .filter(|&o| visible[o as usize])
        .collect();
    Some(audit)
}

/// Objects that are not brush models (node extras without `"model"`) but hold a
/// triangle identical to one of a brush model's, ascending: their PVS clusters cannot
/// cover those copies (module docs).
pub fn brush_model_copies(scene: &Scene) -> Vec<u32> {
    let is_model = |o: &Object| o.extras.as_ref().is_some_and(|e| e.get("model").is_some());
    // A triangle's corners as bit patterns, in a fixed order.
    let key = |t: [Vec3; 3]| {
        let mut k = t.map(|p| p.to_array().map(f32::to_bits));
        k.sort_unstable();
        k
    };
    let model_triangles: HashSet<_> = scene
        .objects
        .iter()
        .filter(|o| is_model(o))
        .flat_map(|o| scene.corners_of(o).map(key))
        .collect();
    if model_triangles.is_empty() {
        return Vec::new();
    }
    scene
        .objects
        .iter()
        .filter(|o| {
            !is_model(o)
                && scene
                    .corners_of(o)
                    .any(|t| model_triangles.contains(&key(t)))
        })
        .map(|o| o.id)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use homcull_engine::camera::look_at;
    use homcull_engine::scene::SceneBuilder;
    use serde_json::json;

    /// Space split by the plane x = 1: x ≥ 1 is cluster 0, which sees only itself;
    /// x < 1 is cluster 1, which sees both. One wall (a 20 m square facing +x) at
    /// `wall_x`, tagged as a cluster-1 object.
    fn two_rooms(wall_x: f32) -> (Scene, Pvs) {
        let mut b = SceneBuilder::default();
        let (x, s) = (wall_x, 10.0);
        let corners = [
            Vec3::new(x, -s, -s),
            Vec3::new(x, -s, s),
            Vec3::new(x, s, s),
            Vec3::new(x, s, -s),
        ];
        b.push(
            "wall".into(),
            &corners,
            &[0, 1, 2, 0, 2, 3],
            Some(json!({ "cluster": 1, "ref_clusters": [1] })),
        );
        let mut scene = b.build("two rooms");
        scene.extras = Some(json!({
            "pvs": { "num_clusters": 2, "bytes_per_cluster": 1, "visible": { "0": [0], "1": [0, 1] } },
            "bsp": { "planes": [[1.0, 0.0, 0.0, 1.0]], "nodes": [[0, -1, -2]], "leaf_cluster": [0, 1] }
        }));
        let pvs = Pvs::from_scene(&scene).unwrap().unwrap();
        (scene, pvs)
    }

    #[test]
    fn flags_pixels_seen_in_a_cluster_the_row_omits() {
        let (scene, pvs) = two_rooms(-5.0);
        let cam = look_at(Vec3::new(5.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.0), 64, 48);
        let audit = audit_pixels(&pvs, &scene, &cam).unwrap();
        assert_eq!(audit.cluster, 0);
        assert_eq!(audit.pixels, 64 * 48, "the wall fills the view");
        assert_eq!(
            audit.outside, audit.pixels,
            "cluster 0 may not see cluster 1"
        );
        assert_eq!(audit.visible, vec![0]);
    }

    #[test]
    fn passes_pixels_seen_in_listed_clusters() {
        // The same wall from inside cluster 1, and a wall inside cluster 0 from cluster 0.
        let (scene, pvs) = two_rooms(-5.0);
        let cam = look_at(Vec3::new(-1.0, 0.0, 0.0), Vec3::new(-5.0, 0.0, 0.0), 64, 48);
        let audit = audit_pixels(&pvs, &scene, &cam).unwrap();
        assert_eq!((audit.cluster, audit.outside, audit.solid), (1, 0, 0));
        assert_eq!(audit.pixels, 64 * 48);

        let (scene, pvs) = two_rooms(3.0);
        let cam = look_at(Vec3::new(5.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.0), 64, 48);
        let audit = audit_pixels(&pvs, &scene, &cam).unwrap();
        assert_eq!((audit.cluster, audit.outside), (0, 0));
        assert!(audit.pixels > 0);
    }

    #[test]
    fn eye_in_solid_is_not_audited() {
        let (mut scene, _) = two_rooms(-5.0);
        let extras = scene.extras.as_mut().unwrap();
        extras["bsp"]["leaf_cluster"] = json!([0, -1]);
        let pvs = Pvs::from_scene(&scene).unwrap().unwrap();
        let cam = look_at(Vec3::new(-1.0, 0.0, 0.0), Vec3::new(-5.0, 0.0, 0.0), 16, 16);
        assert!(audit_pixels(&pvs, &scene, &cam).is_none());
    }

    #[test]
    fn finds_objects_holding_copies_of_brush_model_faces() {
        let mut b = SceneBuilder::default();
        let a = [Vec3::ZERO, Vec3::X, Vec3::Z];
        let other = [Vec3::ZERO, Vec3::Y, Vec3::Z];
        // The copy lists the corners in another order: still the same triangle.
        b.push("cluster_0".into(), &[a[1], a[2], a[0]], &[0, 1, 2], None);
        b.push("cluster_1".into(), &other, &[0, 1, 2], None);
        b.push(
            "model_1".into(),
            &a,
            &[0, 1, 2],
            Some(json!({ "model": 1, "cluster": 0 })),
        );
        let scene = b.build("copies");
        assert_eq!(brush_model_copies(&scene), vec![0]);
    }
}
