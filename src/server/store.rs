//! The data directory: uploaded scenes on disk, written so that a crash or a second
//! replica writing the same directory never leaves half a scene.
//!
//! Layout under `--data-dir`:
//! ```text
//! scenes/<id>/scene.glb        the upload, byte for byte (also what /glb serves)
//! scenes/<id>/meta.json        {"id", "name", "created_unix"}
//! scenes/<id>/occluders.json   preprocessed occluder database (a cache; rebuilt if absent or stale)
//! tmp/                         uploads and deletes in progress
//! ```
//! A scene appears by renaming a complete, fsynced directory from `tmp/` into
//! `scenes/` (one atomic rename), and disappears by renaming it back out before
//! removing it. Readers therefore see a scene whole or not at all, and replicas that
//! share the directory (a ReadWriteMany volume) pick it up on their next rescan.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

use serde::{Deserialize, Serialize};

use crate::core::occluders::OccluderParams;

/// Metadata written beside each scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SceneMeta {
    pub id: String,
    pub name: String,
    pub created_unix: u64,
}

/// The cached output of occluder preprocessing, valid for the params it was built with.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OccluderCache {
    pub min_diagonal: f32,
    pub max_triangles: u32,
    pub objects: u32,
    pub ids: Vec<u32>,
}

impl OccluderCache {
    /// Whether this cache was built for `params` over a scene of `objects` objects.
    pub fn matches(&self, params: &OccluderParams, objects: usize) -> bool {
        self.min_diagonal == params.min_diagonal
            && self.max_triangles == params.max_triangles
            && self.objects as usize == objects
    }
}

/// Files of the data directory.
#[derive(Debug, Clone)]
pub struct Store {
    root: PathBuf,
}

/// Temp entries older than this are leftovers of a crash (another replica's upload in
/// progress is younger) and are removed at startup.
const STALE_TMP: Duration = Duration::from_secs(3600);

/// Scene ids are 16 lowercase hex digits (or `demo`); anything else is not ours.
pub fn valid_id(id: &str) -> bool {
    id.len() == 16
        && id
            .bytes()
            .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
}

impl Store {
    /// Opens (creating if needed) a data directory and clears stale temp entries.
    pub fn open(root: &Path) -> std::io::Result<Store> {
        let store = Store {
            root: root.to_path_buf(),
        };
        std::fs::create_dir_all(store.scenes_dir())?;
        std::fs::create_dir_all(store.tmp_dir())?;
        for e in std::fs::read_dir(store.tmp_dir())?.flatten() {
            let old = e
                .metadata()
                .and_then(|m| m.modified())
                .ok()
                .and_then(|t| SystemTime::now().duration_since(t).ok())
                .is_some_and(|age| age > STALE_TMP);
            if old {
                tracing::info!(path = %e.path().display(), "removing a stale temp entry");
                let _ =
                    std::fs::remove_dir_all(e.path()).or_else(|_| std::fs::remove_file(e.path()));
            }
        }
        Ok(store)
    }

    pub fn root(&self) -> &Path {
        &self.root
    }

    fn scenes_dir(&self) -> PathBuf {
        self.root.join("scenes")
    }

    fn tmp_dir(&self) -> PathBuf {
        self.root.join("tmp")
    }

    pub fn scene_dir(&self, id: &str) -> PathBuf {
        self.scenes_dir().join(id)
    }

    pub fn glb_path(&self, id: &str) -> PathBuf {
        self.scene_dir(id).join("scene.glb")
    }

    /// Ids of the complete scenes on disk, sorted.
    pub fn list(&self) -> std::io::Result<Vec<String>> {
        let mut ids: Vec<String> = std::fs::read_dir(self.scenes_dir())?
            .flatten()
            .filter_map(|e| e.file_name().into_string().ok())
            .filter(|id| valid_id(id))
            .collect();
        ids.sort();
        Ok(ids)
    }

    /// Reads a stored scene's metadata and GLB bytes.
    pub fn read(&self, id: &str) -> std::io::Result<(SceneMeta, Vec<u8>)> {
        let dir = self.scene_dir(id);
        let meta: SceneMeta = serde_json::from_slice(&std::fs::read(dir.join("meta.json"))?)
            .map_err(std::io::Error::other)?;
        let glb = std::fs::read(dir.join("scene.glb"))?;
        Ok((meta, glb))
    }

    /// Writes a new scene atomically and returns its metadata.
    pub fn create(&self, name: &str, glb: &[u8]) -> std::io::Result<SceneMeta> {
        let id = format!("{:016x}", rand::random::<u64>());
        let meta = SceneMeta {
            id: id.clone(),
            name: name.to_string(),
            created_unix: SystemTime::now()
                .duration_since(SystemTime::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs()),
        };
        let tmp = self.tmp_dir().join(format!("{id}.upload"));
        std::fs::create_dir_all(&tmp)?;
        let written = (|| {
            write_synced(&tmp.join("scene.glb"), glb)?;
            write_synced(
                &tmp.join("meta.json"),
                &serde_json::to_vec_pretty(&meta).map_err(std::io::Error::other)?,
            )?;
            sync_dir(&tmp)?;
            std::fs::rename(&tmp, self.scene_dir(&id))?;
            sync_dir(&self.scenes_dir())
        })();
        if written.is_err() {
            let _ = std::fs::remove_dir_all(&tmp);
        }
        written.map(|()| meta)
    }

    /// Removes a scene: first out of `scenes/` (atomic), then from disk.
    pub fn delete(&self, id: &str) -> std::io::Result<()> {
        let gone = self
            .tmp_dir()
            .join(format!("{id}.{:08x}.deleted", rand::random::<u32>()));
        std::fs::rename(self.scene_dir(id), &gone)?;
        sync_dir(&self.scenes_dir())?;
        std::fs::remove_dir_all(gone)
    }

    /// The cached occluder database of a scene, if present and readable.
    pub fn read_occluders(&self, id: &str) -> Option<OccluderCache> {
        let bytes = std::fs::read(self.scene_dir(id).join("occluders.json")).ok()?;
        serde_json::from_slice(&bytes).ok()
    }

    /// Caches a scene's occluder database (temp file + rename inside the scene's dir).
    pub fn write_occluders(&self, id: &str, cache: &OccluderCache) -> std::io::Result<()> {
        let dir = self.scene_dir(id);
        let tmp = dir.join(format!(".occluders.{:08x}.tmp", rand::random::<u32>()));
        let res = write_synced(
            &tmp,
            &serde_json::to_vec(cache).map_err(std::io::Error::other)?,
        )
        .and_then(|()| std::fs::rename(&tmp, dir.join("occluders.json")));
        if res.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        res
    }
}

fn write_synced(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut f = std::fs::File::create(path)?;
    f.write_all(bytes)?;
    f.sync_all()
}

fn sync_dir(path: &Path) -> std::io::Result<()> {
    std::fs::File::open(path)?.sync_all()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn create_list_read_delete() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path()).unwrap();
        let meta = store.create("a scene", b"glTF-bytes").unwrap();
        assert!(valid_id(&meta.id));
        assert_eq!(store.list().unwrap(), vec![meta.id.clone()]);
        let (m, glb) = store.read(&meta.id).unwrap();
        assert_eq!((m, glb.as_slice()), (meta.clone(), &b"glTF-bytes"[..]));
        let cache = OccluderCache {
            min_diagonal: 1.0,
            max_triangles: 5,
            objects: 3,
            ids: vec![0, 2],
        };
        store.write_occluders(&meta.id, &cache).unwrap();
        assert_eq!(store.read_occluders(&meta.id), Some(cache));
        // A half-written upload in tmp/ is not a scene.
        std::fs::create_dir_all(dir.path().join("tmp/0123456789abcdef.upload")).unwrap();
        assert_eq!(store.list().unwrap().len(), 1);
        store.delete(&meta.id).unwrap();
        assert!(store.list().unwrap().is_empty());
        assert!(std::fs::read_dir(dir.path().join("tmp")).unwrap().count() == 1);
    }

    #[test]
    fn ids_are_checked() {
        assert!(valid_id("0123456789abcdef"));
        assert!(!valid_id("../etc/passwd0000"));
        assert!(!valid_id("0123456789ABCDEF"));
        assert!(!valid_id("demo"));
    }
}
