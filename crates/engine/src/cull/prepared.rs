//! A scene with the structures every backend's planning needs, built once and kept
//! resident: the object BVH and the occluder database. A moved scene is another
//! `PreparedScene` (`core::dynamic` builds it), with the objects that may be moving
//! marked: their test boxes bound their motion, so only the box test may judge them.

use super::copies::Copies;
use super::mask::has_bit;
use crate::bvh::BoxBvh;
use crate::occluders::{OccluderDb, OccluderParams};
use std::sync::{Arc, OnceLock};

use crate::scene::Scene;
use crate::scene::edges::EdgeNeighbours;

/// A scene with the structures culling needs, built once and kept resident.
pub struct PreparedScene {
    pub scene: Scene,
    pub bvh: BoxBvh,
    pub occluders: OccluderDb,
    /// Bitmask of the objects whose test boxes bound a motion (temporal bounding
    /// volumes): the refinement, which tests an object's own triangles where they are
    /// now, must leave them as the box test left them. Empty when nothing moves.
    pub moving: Vec<u32>,
    /// Objects moved since `bvh` and the occluders' BVH were built (they were refitted
    /// since): `core::dynamic` builds them again when this grows large.
    pub moved_since_build: usize,
    /// Objects that are exact copies of earlier ones, which the exact oracle never
    /// shows ([`Copies`]): the refinement culls them.
    pub copies: Copies,
    /// The neighbour across each edge of the occluders' triangles, found on first use
    /// by a region cull and shared by the later versions of the scene
    /// (`scene::edges`).
    pub edges: Arc<OnceLock<EdgeNeighbours>>,
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
        let copies = Copies::find(&scene);
        PreparedScene {
            scene,
            bvh,
            occluders,
            moving: Vec::new(),
            moved_since_build: 0,
            copies,
            edges: Arc::default(),
        }
    }

    /// See [`PreparedScene::edges`].
    pub fn edge_neighbours(&self) -> &EdgeNeighbours {
        self.edges.get_or_init(|| {
            let ids = &self.occluders.ids;
            let edges = EdgeNeighbours::build(&self.scene, ids);
            let found = super::holders::find(&self.scene, ids, &edges);
            edges.with_holders(found)
        })
    }

    /// Whether object `id`'s test boxes bound a motion: only the box test judges it.
    #[inline]
    pub fn is_moving(&self, id: u32) -> bool {
        !self.moving.is_empty() && has_bit(&self.moving, id)
    }
}
