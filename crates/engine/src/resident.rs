//! The one place a resident scene is assembled, for the server, the command line and
//! the report alike: the PVS parsed from the glTF extras (and its eye filter), the
//! occluder database (built, or taken from a cache), the engine on the chosen backend,
//! the object table clients see, and a street-level walk start.

use glam::Vec3;
use homcull_proto::{ObjectInfo, WalkStart};

use crate::cull::PreparedScene;
use crate::engine::{Backend, Engine};
use crate::occluders::{OccluderDb, OccluderParams};
use crate::pvs::Pvs;
use crate::sampler::{PoseSampler, SampleResult};
use crate::scene::Scene;

/// Scenes above this many triangles get no walk start: the sampler's triangle BVH
/// would cost more memory and time at load than the hint is worth.
pub const MAX_WALK_START_TRIANGLES: u64 = 4_000_000;

/// How a scene is made resident.
#[derive(Debug, Clone, Default)]
pub struct Residency {
    pub occluders: OccluderParams,
    /// Occluder IDs from an earlier build with the same parameters (a cache), used
    /// instead of building the database again.
    pub cached_occluders: Option<Vec<u32>>,
    /// Serving: drop the glTF extras and the PVS once they are used (as JSON values
    /// they can outweigh the geometry), and find a walk start. Otherwise (evaluation)
    /// both are kept: the PVS audit reads them.
    pub serving: bool,
}

impl Residency {
    /// For the server, with an optional occluder cache.
    pub fn serving(occluders: OccluderParams, cached_occluders: Option<Vec<u32>>) -> Self {
        Residency {
            occluders,
            cached_occluders,
            serving: true,
        }
    }

    /// For evaluation: extras and PVS kept, no walk start.
    pub fn evaluation(occluders: OccluderParams) -> Self {
        Residency {
            occluders,
            cached_occluders: None,
            serving: false,
        }
    }
}

/// A scene ready to cull and to describe to clients.
pub struct ResidentScene {
    pub engine: Engine,
    /// The map's own potentially-visible set (kept for evaluation only).
    pub pvs: Option<Pvs>,
    /// One row per object, in ID order.
    pub objects: Vec<ObjectInfo>,
    /// Where the viewer starts walking (serving only).
    pub start: Option<WalkStart>,
}

impl ResidentScene {
    /// Assembles a resident scene on `backend`.
    pub fn assemble(mut scene: Scene, how: Residency, backend: impl Into<Backend>) -> Self {
        let pvs = parse_pvs(&scene);
        if how.serving {
            scene.extras = None;
            for o in &mut scene.objects {
                o.extras = None;
            }
        }
        let occluders = match how.cached_occluders {
            Some(ids) => OccluderDb::from_ids(&scene, how.occluders, ids),
            None => OccluderDb::build(&scene, how.occluders),
        };
        let objects = object_table(&scene, &occluders);
        let engine =
            Engine::from_prepared(PreparedScene::with_occluders(scene, occluders), backend);
        let mut resident = ResidentScene {
            engine,
            pvs,
            objects,
            start: None,
        };
        if how.serving {
            // Last, after everything the scene keeps is allocated: the sampler's
            // short-lived structures then sit on top and go back to the OS whole
            // instead of staying as fragments.
            resident.start = walk_start(resident.scene(), resident.pvs.as_ref());
            resident.pvs = None;
        }
        resident
    }

    pub fn scene(&self) -> &Scene {
        &self.engine.prepared.scene
    }

    /// Whether an eye at `p` stands in the playable space: inside a vis-cluster of the
    /// map's PVS where there is one, anywhere otherwise.
    pub fn accepts_eye(&self, p: Vec3) -> bool {
        accepts_eye(self.pvs.as_ref(), p)
    }

    /// `n` random street-level poses whose eyes [`ResidentScene::accepts_eye`].
    pub fn sample_poses(&self, n: usize, seed: u64, viewport: [u32; 2]) -> SampleResult {
        sample_poses(self.scene(), self.pvs.as_ref(), n, seed, viewport)
    }
}

/// `n` random street-level poses of `scene` whose eyes [`accepts_eye`] of `pvs`.
pub fn sample_poses(
    scene: &Scene,
    pvs: Option<&Pvs>,
    n: usize,
    seed: u64,
    viewport: [u32; 2],
) -> SampleResult {
    let accept = |p: Vec3| accepts_eye(pvs, p);
    PoseSampler::new(scene).sample(n, seed, viewport, &accept)
}

/// The scene's PVS, if it carries one; a broken one is a warning, not an error.
pub fn parse_pvs(scene: &Scene) -> Option<Pvs> {
    match Pvs::from_scene(scene)? {
        Ok(p) => Some(p),
        Err(e) => {
            tracing::warn!(scene = %scene.name, "the scene's PVS data is unusable: {e}");
            None
        }
    }
}

/// See [`ResidentScene::accepts_eye`].
pub fn accepts_eye(pvs: Option<&Pvs>, p: Vec3) -> bool {
    pvs.is_none_or(|v| v.cluster_at(p) >= 0)
}

fn object_table(scene: &Scene, occluders: &OccluderDb) -> Vec<ObjectInfo> {
    let occluder_set: std::collections::HashSet<u32> = occluders.ids.iter().copied().collect();
    scene
        .objects
        .iter()
        .map(|o| ObjectInfo {
            id: o.id,
            name: o.name.clone(),
            aabb: [o.aabb.min.to_array(), o.aabb.max.to_array()],
            file_aabb: [o.aabb.min.to_array(), o.aabb.max.to_array()],
            placement: None,
            triangles: o.triangles(),
            occluder: occluder_set.contains(&o.id),
            dynamic: o.dynamic,
        })
        .collect()
}

/// A street-level place for the viewer to start walking. Inside a map that carries a
/// PVS, only eyes in a vis-cluster count (not on the sealed hull).
fn walk_start(scene: &Scene, pvs: Option<&Pvs>) -> Option<WalkStart> {
    if scene.triangle_count() > MAX_WALK_START_TRIANGLES {
        return None;
    }
    let accept = |p: Vec3| accepts_eye(pvs, p);
    let (eye, target) = PoseSampler::new(scene).walk_start(&accept)?;
    Some(WalkStart {
        position: eye.to_array(),
        look_at: target.to_array(),
    })
}
