//! A scene with the structures every backend's planning needs, built once and kept
//! resident: the object BVH and the occluder database.

use crate::core::bvh::BoxBvh;
use crate::core::occluders::{OccluderDb, OccluderParams};
use crate::core::scene::Scene;

/// A scene with the structures culling needs, built once and kept resident.
pub struct PreparedScene {
    pub scene: Scene,
    pub bvh: BoxBvh,
    pub occluders: OccluderDb,
}

impl PreparedScene {
    pub fn new(scene: Scene, occluder_params: OccluderParams) -> Self {
        let occluders = OccluderDb::build(&scene, occluder_params);
        Self::with_occluders(scene, occluders)
    }

    /// Prepares a scene whose occluder database was built before (e.g. read from a cache).
    pub fn with_occluders(scene: Scene, occluders: OccluderDb) -> Self {
        let boxes: Vec<_> = scene.objects.iter().map(|o| o.aabb).collect();
        let bvh = BoxBvh::new(&boxes);
        PreparedScene {
            scene,
            bvh,
            occluders,
        }
    }
}
