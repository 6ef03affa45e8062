//! What the server holds: resident scenes (each with its engine), the GPU worker
//! handle, limits, and the shutdown signal. Handlers get an [`AppState`] (cheap clone).

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, RwLock};

use homcull_proto::{ObjectInfo, SceneInfo, WalkStart};
use tokio::sync::watch;

use super::error::ApiError;
use super::scene_files::{Glb, SceneFile};
use super::store::{OccluderCache, SceneMeta, Store};
use super::worker::WorkerHandle;
use crate::config::ServeArgs;
use crate::cull::PreparedScene;
use crate::engine::Engine;
use crate::gpu::GpuContext;
use crate::occluders::{OccluderDb, OccluderParams};
use crate::pvs::Pvs;
use crate::sampler::PoseSampler;
use crate::scene::{Scene, demo_city, load_glb_bytes, write_glb};

/// Where a scene's GLB is served from.
pub enum GlbSource {
    /// Built in memory (the demo city).
    Memory(Arc<Vec<u8>>),
    /// The stored upload.
    File(std::path::PathBuf),
}

/// Where a scene came from: its id, name and GLB.
struct Origin {
    id: String,
    name: String,
    glb: GlbSource,
    glb_bytes: u64,
    /// Not from the data dir (the demo, `--scene` files): cannot be deleted, and
    /// rescans leave it be.
    read_only: bool,
}

/// One resident scene.
pub struct SceneEntry {
    pub info: SceneInfo,
    pub objects: Vec<ObjectInfo>,
    pub glb: GlbSource,
    /// Built in or given at start (`Origin::read_only`).
    pub read_only: bool,
    /// Only the GPU worker locks this, so it is never contended.
    pub engine: Mutex<Engine>,
}

impl SceneEntry {
    /// Prepares a scene (occluders from `cache` when it fits) and uploads it to the GPU.
    fn build(
        origin: Origin,
        mut scene: Scene,
        params: OccluderParams,
        cache: Option<OccluderCache>,
        gpu: Option<Arc<GpuContext>>,
    ) -> SceneEntry {
        let pvs = Pvs::from_scene(&scene).and_then(Result::ok);
        // glTF extras (e.g. the OpenArena maps' PVS) are for offline evaluation only;
        // as JSON values they can outweigh the geometry.
        scene.extras = None;
        for o in &mut scene.objects {
            o.extras = None;
        }
        let occluders = match cache {
            Some(c) if c.matches(&params, scene.objects.len()) => {
                OccluderDb::from_ids(&scene, params, c.ids)
            }
            _ => OccluderDb::build(&scene, params),
        };
        let occluder_set: std::collections::HashSet<u32> = occluders.ids.iter().copied().collect();
        let objects = scene
            .objects
            .iter()
            .map(|o| ObjectInfo {
                id: o.id,
                name: o.name.clone(),
                aabb: [o.aabb.min.to_array(), o.aabb.max.to_array()],
                triangles: o.triangles(),
                occluder: occluder_set.contains(&o.id),
            })
            .collect();
        let Origin {
            id,
            name,
            glb,
            glb_bytes,
            read_only,
        } = origin;
        let mut info = SceneInfo {
            id,
            name,
            objects: scene.objects.len() as u32,
            triangles: scene.triangle_count().min(u32::MAX as u64) as u32,
            occluders: occluders.ids.len() as u32,
            bounds: [scene.bounds.min.to_array(), scene.bounds.max.to_array()],
            glb_bytes,
            warnings: scene.warnings.clone(),
            start: None,
        };
        let engine = Engine::from_prepared(PreparedScene::with_occluders(scene, occluders), gpu);
        // Last, after everything the scene keeps is allocated: the sampler's short-lived
        // structures then sit on top and, with the fixed mmap threshold
        // (`tune_allocator`), go back to the OS whole instead of staying as fragments.
        info.start = walk_start(&engine.prepared.scene, pvs.as_ref());
        SceneEntry {
            info,
            objects,
            glb,
            read_only,
            engine: Mutex::new(engine),
        }
    }

    /// The occluder list to cache on disk.
    fn occluder_cache(&self) -> OccluderCache {
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

/// Scenes above this many triangles get no walk start: the sampler's triangle BVH
/// would cost more memory and time at load than the hint is worth.
const MAX_WALK_START_TRIANGLES: u64 = 4_000_000;

/// A street-level place for the viewer to start walking (`SceneInfo::start`). Inside a
/// map that carries a PVS, only eyes in a vis-cluster count (not on the sealed hull).
fn walk_start(scene: &Scene, pvs: Option<&Pvs>) -> Option<WalkStart> {
    if scene.triangle_count() > MAX_WALK_START_TRIANGLES {
        return None;
    }
    let accept = |p: glam::Vec3| pvs.is_none_or(|v| v.cluster_at(p) >= 0);
    let (eye, target) = PoseSampler::new(scene).walk_start(&accept)?;
    Some(WalkStart {
        position: eye.to_array(),
        look_at: target.to_array(),
    })
}

pub struct Inner {
    pub config: ServeArgs,
    pub store: Store,
    pub scenes: RwLock<BTreeMap<String, Arc<SceneEntry>>>,
    pub worker: WorkerHandle,
    pub gpu: Option<Arc<GpuContext>>,
    /// Adapter and backend in words, or the CPU fallback.
    pub adapter: String,
    pub ready: AtomicBool,
    pub ws_clients: AtomicUsize,
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

    fn insert(&self, entry: SceneEntry) -> Arc<SceneEntry> {
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

    /// Builds the demo city (blocking: call from a blocking thread).
    pub fn load_demo(&self) {
        let t = std::time::Instant::now();
        let scene = demo_city();
        let glb = Arc::new(write_glb(&scene));
        let len = glb.len() as u64;
        let origin = Origin {
            id: "demo".into(),
            name: "demo city".into(),
            glb: GlbSource::Memory(glb),
            glb_bytes: len,
            read_only: true,
        };
        let entry = SceneEntry::build(
            origin,
            scene,
            self.occluder_params(),
            None,
            self.gpu.clone(),
        );
        tracing::info!(
            objects = entry.info.objects,
            ms = t.elapsed().as_millis() as u64,
            "demo city ready"
        );
        self.insert(entry);
    }

    /// Makes a `--scene` file resident (blocking): read-only, never in the data dir.
    pub fn load_file(&self, file: SceneFile) {
        let t = std::time::Instant::now();
        let (glb, glb_bytes) = match file.glb {
            Glb::File { bytes } => (GlbSource::File(file.path), bytes),
            Glb::Written(b) => {
                let len = b.len() as u64;
                (GlbSource::Memory(Arc::new(b)), len)
            }
        };
        let origin = Origin {
            id: file.id,
            name: file.scene.name.clone(),
            glb,
            glb_bytes,
            read_only: true,
        };
        let entry = SceneEntry::build(
            origin,
            file.scene,
            self.occluder_params(),
            None,
            self.gpu.clone(),
        );
        release_free_heap();
        tracing::info!(
            id = %entry.info.id, objects = entry.info.objects,
            ms = t.elapsed().as_millis() as u64, "scene file ready"
        );
        self.insert(entry);
    }

    /// Loads a stored scene by id (blocking), caching its occluders if needed.
    pub fn load_stored(&self, id: &str) -> Result<Arc<SceneEntry>, String> {
        let (meta, glb) = self
            .store
            .read(id)
            .map_err(|e| format!("reading scene {id}: {e}"))?;
        let scene = load_glb_bytes(&glb, &meta.name).map_err(|e| format!("scene {id}: {e}"))?;
        Ok(self.prepare(&meta, scene, glb.len() as u64))
    }

    /// Stores a new upload (already parsed as `scene`) and makes it resident (blocking).
    pub fn create(&self, name: &str, glb: &[u8], scene: Scene) -> std::io::Result<Arc<SceneEntry>> {
        let _changing = self.changes.lock().unwrap_or_else(|p| p.into_inner());
        let meta = self.store.create(name, glb)?;
        Ok(self.prepare(&meta, scene, glb.len() as u64))
    }

    fn prepare(&self, meta: &SceneMeta, scene: Scene, glb_bytes: u64) -> Arc<SceneEntry> {
        let t = std::time::Instant::now();
        let cache = self.store.read_occluders(&meta.id);
        let cached = cache.is_some();
        let origin = Origin {
            id: meta.id.clone(),
            name: meta.name.clone(),
            glb: GlbSource::File(self.store.glb_path(&meta.id)),
            glb_bytes,
            read_only: false,
        };
        let entry = SceneEntry::build(
            origin,
            scene,
            self.occluder_params(),
            cache,
            self.gpu.clone(),
        );
        if !cached {
            if let Err(e) = self
                .store
                .write_occluders(&meta.id, &entry.occluder_cache())
            {
                tracing::warn!(id = %meta.id, "could not cache the occluder database: {e}");
            }
        }
        release_free_heap();
        tracing::info!(
            id = %meta.id, name = %meta.name, objects = entry.info.objects,
            occluder_cache = if cached { "hit" } else { "built" },
            ms = t.elapsed().as_millis() as u64, "scene ready"
        );
        self.insert(entry)
    }

    /// Brings the resident set in line with the data dir: loads scenes other replicas
    /// wrote, drops scenes they deleted (blocking).
    pub fn rescan(&self) {
        let _changing = self.changes.lock().unwrap_or_else(|p| p.into_inner());
        let on_disk = match self.store.list() {
            Ok(ids) => ids,
            Err(e) => {
                tracing::warn!("listing the data dir: {e}");
                return;
            }
        };
        let resident: Vec<(String, bool)> = self
            .scenes
            .read()
            .unwrap_or_else(|p| p.into_inner())
            .iter()
            .map(|(id, s)| (id.clone(), s.read_only))
            .collect();
        for id in &on_disk {
            let failed = self
                .failed
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .contains(id);
            if !resident.iter().any(|(r, _)| r == id) && !failed {
                if let Err(e) = self.load_stored(id) {
                    tracing::warn!("skipping a stored scene: {e}");
                    self.failed
                        .lock()
                        .unwrap_or_else(|p| p.into_inner())
                        .insert(id.clone());
                }
            }
        }
        for (id, read_only) in resident {
            if !read_only && !on_disk.contains(&id) {
                tracing::info!(%id, "scene left the data dir; unloading");
                self.remove(&id);
            }
        }
    }
}

/// Hands the heap's free pages back to the OS. Parsing a GLB peaks well above what the
/// resident scene keeps (JSON, per-primitive buffers, the glTF extras), and glibc keeps
/// those pages mapped; without this a resident scene costs several times its size.
pub fn release_free_heap() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only returns free pages of glibc's own heap to the kernel.
    unsafe {
        libc::malloc_trim(0);
    }
}

/// Keeps large allocations (≥ 256 KiB) out of the heap: glibc otherwise raises its mmap
/// threshold to the size of each large block freed, after which blocks of that size
/// come from the heap, and a scene load's short-lived buffers (the GLB parse, the
/// walk-start sampler) leave resident fragments behind (seen: +7–9 MiB per scene).
pub fn tune_allocator() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only changes glibc's allocation policy for later allocations.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 256 * 1024);
    }
}
