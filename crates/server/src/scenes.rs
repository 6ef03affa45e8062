//! How scenes enter and leave the registry: the demo city and `--scene` files at start,
//! uploads, the stored scenes of the data dir, and rescans that follow what other
//! replicas wrote or deleted. All of it blocks (parsing, building, uploading to the
//! device): call from a blocking thread.

use std::sync::Arc;

use super::alloc::release_free_heap;
use super::scene_files::{Glb, SceneFile};
use super::state::{AppState, GlbSource, Origin, SceneEntry, assemble};
use super::store::SceneMeta;
use homcull_engine::dynamic::marks;
use homcull_engine::resident::ResidentScene;
use homcull_engine::scene::{Scene, demo_city, load_glb_bytes_within, write_glb};

impl AppState {
    /// Builds the demo city (blocking: call from a blocking thread).
    pub fn load_demo(&self) {
        let t = std::time::Instant::now();
        let scene = demo_city();
        let glb = axum::body::Bytes::from(write_glb(&scene));
        let len = glb.len() as u64;
        let origin = Origin {
            id: "demo".into(),
            name: "demo city".into(),
            glb: GlbSource::Memory(glb),
            glb_bytes: len,
            read_only: true,
        };
        let resident = assemble(scene, self.occluder_params(), None, &self.backend);
        let entry = SceneEntry::new(origin, resident, self.journals.as_ref());
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
                (GlbSource::Memory(b.into()), len)
            }
        };
        let origin = Origin {
            id: file.id,
            name: file.scene.name.clone(),
            glb,
            glb_bytes,
            read_only: true,
        };
        let resident = assemble(file.scene, self.occluder_params(), None, &self.backend);
        let entry = SceneEntry::new(origin, resident, self.journals.as_ref());
        release_free_heap();
        tracing::info!(
            id = %entry.info.id, objects = entry.info.objects,
            ms = t.elapsed().as_millis() as u64, "scene file ready"
        );
        self.insert(entry);
    }

    /// Loads a stored scene by id (blocking), caching its occluders if needed. A scene
    /// whose files are readable but unusable (its GLB refused, its `meta.json` broken or
    /// naming another id) is moved to the data dir's quarantine, so that no later start
    /// or replica tries it again.
    pub fn load_stored(&self, id: &str) -> Result<Arc<SceneEntry>, String> {
        let (meta, glb) = match self.store.read(id) {
            Ok(read) => read,
            Err(e) if e.kind() == std::io::ErrorKind::InvalidData => {
                return Err(self.quarantine(id, &format!("meta.json: {e}")));
            }
            Err(e) => return Err(format!("reading scene {id}: {e}")),
        };
        if meta.id != id {
            let why = format!("meta.json names id `{}`, not its folder's", meta.id);
            return Err(self.quarantine(id, &why));
        }
        let loaded = load_glb_bytes_within(&glb, &meta.name, &self.config.load_limits())
            .map_err(|e| e.to_string())
            .and_then(|mut scene| {
                marks::mark(&mut scene, &meta.dynamic).map_err(|e| e.to_string())?;
                Ok(scene)
            });
        match loaded {
            Ok(scene) => Ok(self.prepare(&meta, scene, glb.len() as u64)),
            Err(e) => Err(self.quarantine(id, &e)),
        }
    }

    /// Moves a stored scene out of the way (see [`AppState::load_stored`]) and says why.
    fn quarantine(&self, id: &str, why: &str) -> String {
        match self.store.quarantine(id) {
            Ok(to) => format!("scene {id}: {why}; moved to {}", to.display()),
            Err(e) => format!("scene {id}: {why}; could not quarantine it: {e}"),
        }
    }

    /// Makes a new upload (already parsed as `scene`) resident and stores it, if
    /// `may_store()` still says so once the scene is assembled (blocking). `None`: it
    /// was not stored (its client has been answered already).
    /// `dynamic` are the patterns that marked objects of `scene` dynamic, kept with it.
    pub fn create(
        &self,
        name: &str,
        glb: &[u8],
        dynamic: &[String],
        scene: Scene,
        may_store: impl FnOnce() -> bool,
    ) -> std::io::Result<Option<Arc<SceneEntry>>> {
        let t = std::time::Instant::now();
        let resident = assemble(scene, self.occluder_params(), None, &self.backend);
        if !may_store() {
            return Ok(None);
        }
        let _changing = self.changes.lock().unwrap_or_else(|p| p.into_inner());
        let meta = self.store.create(name, glb, dynamic)?;
        Ok(Some(self.commit(
            &meta,
            resident,
            glb.len() as u64,
            false,
            t,
        )))
    }

    fn prepare(&self, meta: &SceneMeta, scene: Scene, glb_bytes: u64) -> Arc<SceneEntry> {
        let t = std::time::Instant::now();
        let cache = self.store.read_occluders(&meta.id);
        let cached = cache.is_some();
        let resident = assemble(scene, self.occluder_params(), cache, &self.backend);
        self.commit(meta, resident, glb_bytes, cached, t)
    }

    /// Makes an assembled stored scene an entry, caches its occluders unless they came
    /// from the cache, and inserts it.
    fn commit(
        &self,
        meta: &SceneMeta,
        resident: ResidentScene,
        glb_bytes: u64,
        cached: bool,
        t: std::time::Instant,
    ) -> Arc<SceneEntry> {
        let origin = Origin {
            id: meta.id.clone(),
            name: meta.name.clone(),
            glb: GlbSource::File(self.store.glb_path(&meta.id)),
            glb_bytes,
            read_only: false,
        };
        let entry = SceneEntry::new(origin, resident, self.journals.as_ref());
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
