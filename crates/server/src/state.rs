//! What the server holds: the registry of resident scenes, the worker handle, limits,
//! and the shutdown signal. Handlers get an [`AppState`] (cheap clone). How scenes
//! enter and leave the registry is in `scenes.rs`.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, RwLock};

use homcull_proto::{ObjectInfo, ObjectList, ObjectPlacement, SceneInfo};
use tokio::sync::watch;

use super::config::Config;
use super::error::ApiError;
use super::journal::StateDir;
use super::store::{OccluderCache, Store};
use super::worker::{SharedEngine, WorkerHandle};
use super::writes::{self, Writes};
use homcull_engine::dynamic::Dynamics;
use homcull_engine::engine::Backend;
use homcull_engine::occluders::OccluderParams;
use homcull_engine::resident::{Residency, ResidentScene};
use homcull_engine::scene::Scene;

/// Where a scene's GLB is served from.
pub enum GlbSource {
    /// Built in memory (the demo city); clones share the bytes.
    Memory(axum::body::Bytes),
    /// The stored upload.
    File(std::path::PathBuf),
}

/// Where a scene came from: its id, name and GLB.
pub(super) struct Origin {
    pub(super) id: String,
    pub(super) name: String,
    pub(super) glb: GlbSource,
    pub(super) glb_bytes: u64,
    /// Not from the data dir (the demo, `--scene` files): cannot be deleted, and
    /// rescans leave it be.
    pub(super) read_only: bool,
}

/// Assembles a scene for serving on `backend`, occluders from `cache` when it fits: the
/// slow part of making a scene resident (BVHs, occluder database, walk start).
pub(super) fn assemble(
    scene: Scene,
    params: OccluderParams,
    cache: Option<OccluderCache>,
    backend: &Backend,
) -> ResidentScene {
    let cached = cache
        .filter(|c| c.matches(&params, scene.objects.len()))
        .map(|c| c.ids);
    ResidentScene::assemble(scene, Residency::serving(params, cached), backend.clone())
}

/// One resident scene.
pub struct SceneEntry {
    pub info: SceneInfo,
    pub objects: Vec<ObjectInfo>,
    pub glb: GlbSource,
    /// Built in or given at start (`Origin::read_only`).
    pub read_only: bool,
    /// Culled on by the worker's jobs, which hold it, not this entry.
    pub engine: SharedEngine,
    /// Where writers move the scene's objects (the engine follows when it culls), and
    /// how their updates are kept.
    pub writes: Arc<Writes>,
}

impl SceneEntry {
    /// The scene's placements now, locked once for a whole answer:
    /// [`Dynamics::bounds`] gives an object's world bounds where it is placed (the
    /// object table gives them as loaded). Not to be held across an await.
    pub fn placements(&self) -> std::sync::MutexGuard<'_, Dynamics> {
        self.writes
            .dynamics
            .lock()
            .unwrap_or_else(|p| p.into_inner())
    }

    /// The entry of a scene already assembled (the slow part, see [`assemble`]), its
    /// placements restored from its journal in `journals` (`None`: kept in memory).
    pub(super) fn new(
        origin: Origin,
        resident: ResidentScene,
        journals: Option<&StateDir>,
    ) -> SceneEntry {
        let scene = resident.scene();
        let Origin {
            id,
            name,
            glb,
            glb_bytes,
            read_only,
        } = origin;
        let info = SceneInfo {
            id,
            name,
            objects: scene.objects.len() as u32,
            triangles: scene.triangle_count().min(u32::MAX as u64) as u32,
            occluders: resident.engine.prepared.occluders.ids.len() as u32,
            dynamic_objects: scene.objects.iter().filter(|o| o.dynamic).count() as u32,
            bounds: [scene.bounds.min.to_array(), scene.bounds.max.to_array()],
            glb_bytes,
            warnings: scene.warnings.clone(),
            start: resident.start,
        };
        let dynamics = resident.engine.dynamics();
        let durability = writes::recover(journals, &info.id, scene, &dynamics);
        SceneEntry {
            info,
            objects: resident.objects,
            glb,
            read_only,
            writes: Arc::new(Writes {
                dynamics,
                durability,
            }),
            engine: Arc::new(Mutex::new(resident.engine)),
        }
    }

    /// The object table (`GET /v1/scenes/{id}/objects`): each object's bounds where it
    /// is now and where its file puts it, and its placement, all at the version the
    /// table names (read under one lock of the placements).
    pub fn object_list(&self) -> ObjectList {
        let mut objects = self.objects.clone();
        let placed = self.placements();
        let moved = placed.placed();
        for (id, p) in &moved.objects {
            let Some(o) = objects.get_mut(*id as usize) else {
                continue;
            };
            let now = placed.bounds(*id);
            o.aabb = [now.min.to_array(), now.max.to_array()];
            o.placement = Some(ObjectPlacement {
                matrix: p.matrix.to_cols_array(),
                velocity: p.velocity.to_array(),
                angular_velocity: p.angular_velocity.to_array(),
                valid_ms: p.motion_s.is_finite().then(|| f64::from(p.motion_s) * 1e3),
            });
        }
        ObjectList {
            version: moved.version,
            objects,
        }
    }

    /// The occluder list to cache on disk.
    pub(super) fn occluder_cache(&self) -> OccluderCache {
        let engine = self.engine.lock().unwrap_or_else(|p| p.into_inner());
        let db = &engine.prepared.occluders;
        OccluderCache {
            min_diagonal: db.params.min_diagonal,
            max_triangles: db.params.max_triangles,
            objects: self.info.objects,
            ids: db.ids.clone(),
        }
    }
}

pub struct Inner {
    pub config: Config,
    pub store: Store,
    /// The placement journals (`--state journal`), `None` in memory.
    pub journals: Option<super::journal::StateDir>,
    pub scenes: RwLock<BTreeMap<String, Arc<SceneEntry>>>,
    pub worker: WorkerHandle,
    pub backend: Backend,
    /// Adapter and backend in words, or the CPU fallback.
    pub adapter: String,
    pub ready: AtomicBool,
    pub ws_clients: AtomicUsize,
    /// Connections and streams per peer address, against their cap.
    pub addresses: Arc<super::listen::AddressBook>,
    pub shutdown: watch::Receiver<bool>,
    pub metrics: metrics_exporter_prometheus::PrometheusHandle,
    /// Serialises changes of the resident set (upload, delete, rescan).
    pub changes: Mutex<()>,
    /// Stored scenes that failed to load; not retried by rescans.
    pub failed: Mutex<std::collections::HashSet<String>>,
}

/// Shared server state.
#[derive(Clone)]
pub struct AppState(pub Arc<Inner>);

impl std::ops::Deref for AppState {
    type Target = Inner;
    fn deref(&self) -> &Inner {
        &self.0
    }
}

/// A WebSocket client slot; frees itself when dropped.
pub struct WsClientSlot(AppState);

impl Drop for WsClientSlot {
    fn drop(&mut self) {
        self.0.ws_clients.fetch_sub(1, Ordering::SeqCst);
        metrics::gauge!("homcull_ws_clients").decrement(1.0);
    }
}

impl AppState {
    pub fn occluder_params(&self) -> OccluderParams {
        OccluderParams {
            budget_triangles: self.config.budget,
            ..Default::default()
        }
    }

    pub fn scene(&self, id: &str) -> Result<Arc<SceneEntry>, ApiError> {
        let found = self
            .scenes
            .read()
            .unwrap_or_else(|p| p.into_inner())
            .get(id)
            .cloned();
        match found {
            Some(s) => Ok(s),
            None if !self.ready.load(Ordering::SeqCst) => Err(ApiError::new(
                axum::http::StatusCode::SERVICE_UNAVAILABLE,
                "starting",
                format!("scene `{id}` is not loaded yet: the server is still starting"),
            )),
            None => Err(ApiError::unknown_scene(id)),
        }
    }

    pub fn scene_list(&self) -> Vec<SceneInfo> {
        let scenes = self.scenes.read().unwrap_or_else(|p| p.into_inner());
        scenes.values().map(|s| s.info.clone()).collect()
    }

    pub(super) fn insert(&self, entry: SceneEntry) -> Arc<SceneEntry> {
        let entry = Arc::new(entry);
        self.scenes
            .write()
            .unwrap_or_else(|p| p.into_inner())
            .insert(entry.info.id.clone(), entry.clone());
        metrics::gauge!("homcull_scenes").set(self.scenes.read().map_or(0, |s| s.len()) as f64);
        entry
    }

    pub fn remove(&self, id: &str) -> bool {
        let removed = self
            .scenes
            .write()
            .unwrap_or_else(|p| p.into_inner())
            .remove(id)
            .is_some();
        metrics::gauge!("homcull_scenes").set(self.scenes.read().map_or(0, |s| s.len()) as f64);
        removed
    }

    /// Takes a WebSocket client slot if the cap allows.
    pub fn try_ws_slot(&self) -> Option<WsClientSlot> {
        let cap = self.config.max_ws_clients;
        let taken = self
            .ws_clients
            .fetch_update(Ordering::SeqCst, Ordering::SeqCst, |n| {
                (n < cap).then_some(n + 1)
            });
        taken.ok().map(|_| {
            metrics::gauge!("homcull_ws_clients").increment(1.0);
            WsClientSlot(self.clone())
        })
    }
}
