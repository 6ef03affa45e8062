//! Occluder database: which objects may occlude, and which of them to render per pose.
//!
//! Preprocessing (once per scene) keeps objects that are large enough to hide
//! something and cheap enough to rasterize, in their own BVH (the occluder
//! database of the HOM paper). Per pose, the in-frustum occluders are sorted by the distance of their
//! box centre from the eye and taken nearest first until a triangle budget is spent.
//! Occluders are the objects' own triangles, never simplified, so an occluder can only
//! ever cover pixels the object itself covers.

use crate::bvh::BoxBvh;
use crate::camera::Camera;
use crate::scene::Scene;

/// Tunables of occluder selection. Costs are noted per field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OccluderParams {
    /// Objects whose box diagonal is shorter than this (metres) never occlude. Lower:
    /// more occluders, better culling of clutter behind clutter, more raster work.
    pub min_diagonal: f32,
    /// Objects with more triangles than this never occlude (too slow to rasterize).
    pub max_triangles: u32,
    /// Runtime budget: triangles rendered into the occlusion map per pose. Higher:
    /// fuller occlusion map (better culling), linearly more raster time.
    pub budget_triangles: u32,
}

impl Default for OccluderParams {
    fn default() -> Self {
        OccluderParams {
            min_diagonal: 1.0,
            max_triangles: 20_000,
            budget_triangles: 100_000,
        }
    }
}

/// The preprocessed occluder set of one scene.
pub struct OccluderDb {
    pub params: OccluderParams,
    /// Object IDs that qualify as occluders.
    pub ids: Vec<u32>,
    bvh: BoxBvh,
}

/// The occluders chosen for one pose.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct OccluderSelection {
    /// Object IDs, nearest first.
    pub ids: Vec<u32>,
    pub triangles: u32,
}

impl OccluderDb {
    /// Selects occluders by size and complexity and indexes them in a BVH.
    pub fn build(scene: &Scene, params: OccluderParams) -> Self {
        let ids: Vec<u32> = scene
            .objects
            .iter()
            .filter(|o| {
                o.triangles() > 0
                    && o.triangles() <= params.max_triangles
                    && o.aabb.diagonal() >= params.min_diagonal
            })
            .map(|o| o.id)
            .collect();
        tracing::debug!(scene = %scene.name, occluders = ids.len(), "occluder database built");
        Self::from_ids(scene, params, ids)
    }

    /// Rebuilds the database from a cached occluder list. IDs out of range are dropped.
    pub fn from_ids(scene: &Scene, params: OccluderParams, mut ids: Vec<u32>) -> Self {
        ids.retain(|&i| (i as usize) < scene.objects.len());
        let boxes: Vec<_> = ids
            .iter()
            .map(|&i| scene.objects[i as usize].aabb)
            .collect();
        let bvh = BoxBvh::new(&boxes);
        OccluderDb { params, ids, bvh }
    }

    /// The same occluders in `scene` moved: the BVH refitted to their new bounds, or
    /// built again when `rebuild` (or when an occluder's bounds became empty).
    pub fn moved(&self, scene: &Scene, rebuild: bool) -> Self {
        let boxes: Vec<_> = self
            .ids
            .iter()
            .map(|&i| scene.objects[i as usize].aabb)
            .collect();
        let refit = (!rebuild).then(|| self.bvh.refitted(&boxes)).flatten();
        OccluderDb {
            params: self.params,
            ids: self.ids.clone(),
            bvh: refit.unwrap_or_else(|| BoxBvh::new(&boxes)),
        }
    }

    /// In-frustum occluders, nearest box centre first, until the budget is spent.
    /// An occluder that alone would overrun the remaining budget is skipped, so smaller
    /// ones behind it can still fill the budget.
    pub fn select(&self, scene: &Scene, cam: &Camera, budget_triangles: u32) -> OccluderSelection {
        self.select_preferring(scene, cam, budget_triangles, &[])
    }

    /// [`OccluderDb::select`], but the occluders in `prefer` (ascending IDs: e.g. the
    /// objects visible from the previous pose of a walk) come first, nearest first,
    /// then the others (temporal coherence: hidden occluders waste the budget). Which objects are selected changes, never whether culling is
    /// conservative: any subset of the objects' own triangles is a valid occluder set.
    pub fn select_preferring(
        &self,
        scene: &Scene,
        cam: &Camera,
        budget_triangles: u32,
        prefer: &[u32],
    ) -> OccluderSelection {
        // (not preferred, squared distance, ID): whether an occluder is preferred is
        // looked up once, not in every comparison of the sort.
        let mut found: Vec<(bool, f32, u32)> = Vec::new();
        self.bvh.frustum_query(cam, |slot| {
            let id = self.ids[slot as usize];
            let d = scene.objects[id as usize]
                .aabb
                .center()
                .distance_squared(cam.position);
            found.push((prefer.binary_search(&id).is_err(), d, id));
        });
        found.sort_unstable_by(|a, b| {
            (a.0.cmp(&b.0))
                .then(a.1.total_cmp(&b.1))
                .then(a.2.cmp(&b.2))
        });
        let mut sel = OccluderSelection::default();
        for (_, _, id) in found {
            let t = scene.objects[id as usize].triangles();
            if sel.triangles + t <= budget_triangles {
                sel.triangles += t;
                sel.ids.push(id);
            }
        }
        sel
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::look_at;
    use crate::scene::SceneBuilder;
    use glam::Vec3;

    fn quad(b: &mut SceneBuilder, name: &str, z: f32, half: f32) {
        let v = [
            Vec3::new(-half, -half, z),
            Vec3::new(half, -half, z),
            Vec3::new(half, half, z),
            Vec3::new(-half, half, z),
        ];
        b.push(name.into(), &v, &[0, 1, 2, 0, 2, 3], None);
    }

    #[test]
    fn size_filter_and_nearest_first_budget() {
        let mut b = SceneBuilder::default();
        quad(&mut b, "far", -30.0, 5.0);
        quad(&mut b, "near", -10.0, 5.0);
        quad(&mut b, "tiny", -5.0, 0.1);
        quad(&mut b, "behind", 10.0, 5.0);
        let scene = b.build("t");
        let db = OccluderDb::build(&scene, OccluderParams::default());
        assert_eq!(db.ids, vec![0, 1, 3]);
        let cam = look_at(Vec3::ZERO, Vec3::NEG_Z, 100, 100);
        let all = db.select(&scene, &cam, 100);
        assert_eq!(all.ids, vec![1, 0]);
        assert_eq!(all.triangles, 4);
        let one = db.select(&scene, &cam, 3);
        assert_eq!(one.ids, vec![1]);
        // Preferring the far quad (seen last pose) spends the budget on it first.
        let preferred = db.select_preferring(&scene, &cam, 3, &[0]);
        assert_eq!(preferred.ids, vec![0]);
        let both = db.select_preferring(&scene, &cam, 100, &[0]);
        assert_eq!(both.ids, vec![0, 1]);
    }
}
