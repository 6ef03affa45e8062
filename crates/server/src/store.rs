//! The data directory: uploaded scenes on disk, written so that a crash or a second
//! replica writing the same directory never leaves half a scene.
//!
//! Layout under `--data-dir`:
//! ```text
//! scenes/<id>/scene.glb        the upload, byte for byte (also what /glb serves)
//! scenes/<id>/meta.json        {"id", "name", "created_unix"}
//! scenes/<id>/occluders.json   preprocessed occluder database (a cache; rebuilt if absent or stale)
//! tmp/<instance>.live/         this process's uploads and deletes in progress
//! quarantine/<id>.<unix time>/ stored scenes that failed to load, moved out of the way
//! ```
//! Each running server holds an exclusive lock on `tmp/<instance>.live/lock`; at start a
//! server removes every temp folder whose lock it can take (its owner is gone: a crash
//! leaves nothing behind past the next start), whatever its age, and leaves the folders
//! of live replicas alone.
//! A scene appears by renaming a complete, fsynced directory from `tmp/` into
//! `scenes/` (one atomic rename), and disappears by renaming it back out before
//! removing it. Readers therefore see a scene whole or not at all, and replicas that
//! share the directory (a ReadWriteMany volume) pick it up on their next rescan.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

use serde::{Deserialize, Serialize};

use homcull_engine::occluders::OccluderParams;

/// Metadata written beside each scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SceneMeta {
    pub id: String,
    pub name: String,
    pub created_unix: u64,
    /// The upload's `dynamic` patterns (`core::dynamic::marks`), applied at each load.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub dynamic: Vec<String>,
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
    /// `tmp/<instance>.live`: where this process writes before renaming.
    work: PathBuf,
    /// The lock on `work/lock`, held while the process lives.
    _lock: std::sync::Arc<std::fs::File>,
}

/// Temp entries of the layout before per-instance folders, older than this, are
/// leftovers of a crash and are removed at startup.
const STALE_TMP: Duration = Duration::from_secs(3600);

/// Scene ids are 16 lowercase hex digits (or `demo`); anything else is not ours.
pub fn valid_id(id: &str) -> bool {
    id.len() == 16
        && id
            .bytes()
            .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b))
}

impl Store {
    /// Opens (creating if needed) a data directory, takes this process's temp folder
    /// and removes the temp folders of processes that are gone.
    pub fn open(root: &Path) -> std::io::Result<Store> {
        let scenes = root.join("scenes");
        let tmp = root.join("tmp");
        std::fs::create_dir_all(&scenes)?;
        std::fs::create_dir_all(&tmp)?;
        let work = tmp.join(format!("{:016x}.live", rand::random::<u64>()));
        std::fs::create_dir_all(&work)?;
        let lock = std::fs::File::create(work.join("lock"))?;
        if !try_lock(&lock) {
            return Err(std::io::Error::other("cannot lock a fresh temp folder"));
        }
        for e in std::fs::read_dir(&tmp)?.flatten() {
            let path = e.path();
            if path == work {
                continue;
            }
            let abandoned = if path.extension().is_some_and(|x| x == "live") {
                // Its owner holds the lock while it lives; taking it proves it is gone.
                std::fs::File::open(path.join("lock")).map_or(true, |f| try_lock(&f))
            } else {
                e.metadata()
                    .and_then(|m| m.modified())
                    .ok()
                    .and_then(|t| SystemTime::now().duration_since(t).ok())
                    .is_some_and(|age| age > STALE_TMP)
            };
            if abandoned {
                tracing::info!(path = %path.display(), "removing a temp entry no live server owns");
                let _ = std::fs::remove_dir_all(&path).or_else(|_| std::fs::remove_file(&path));
            }
        }
        Ok(Store {
            root: root.to_path_buf(),
            work,
            _lock: std::sync::Arc::new(lock),
        })
    }

    /// Moves a stored scene to `quarantine/<id>.<unix time>` and returns where.
    pub fn quarantine(&self, id: &str) -> std::io::Result<PathBuf> {
        let dir = self.root.join("quarantine");
        std::fs::create_dir_all(&dir)?;
        let to = dir.join(format!("{id}.{}", unix_now()));
        std::fs::rename(self.scene_dir(id), &to)?;
        sync_dir(&self.scenes_dir())?;
        Ok(to)
    }

    pub fn root(&self) -> &Path {
        &self.root
    }

    fn scenes_dir(&self) -> PathBuf {
        self.root.join("scenes")
    }

    fn tmp_dir(&self) -> &Path {
        &self.work
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
            .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))?;
        let glb = std::fs::read(dir.join("scene.glb"))?;
        Ok((meta, glb))
    }

    /// Writes a new scene atomically and returns its metadata.
    pub fn create(&self, name: &str, glb: &[u8], dynamic: &[String]) -> std::io::Result<SceneMeta> {
        let id = format!("{:016x}", rand::random::<u64>());
        let meta = SceneMeta {
            id: id.clone(),
            name: name.to_string(),
            created_unix: unix_now(),
            dynamic: dynamic.to_vec(),
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

fn unix_now() -> u64 {
    SystemTime::now()
        .duration_since(SystemTime::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

/// Takes an exclusive advisory lock on `file` without waiting; false if another
/// process holds it. Released when the file is closed, or when the process dies.
pub(crate) fn try_lock(file: &std::fs::File) -> bool {
    use std::os::fd::AsRawFd;
    // SAFETY: flock only reads the descriptor, which `file` keeps open for the call.
    unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX | libc::LOCK_NB) == 0 }
}

pub(crate) fn write_synced(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut f = std::fs::File::create(path)?;
    f.write_all(bytes)?;
    f.sync_all()
}

pub(crate) fn sync_dir(path: &Path) -> std::io::Result<()> {
    std::fs::File::open(path)?.sync_all()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn create_list_read_delete() {
        let dir = tempfile::tempdir().unwrap();
        let store = Store::open(dir.path()).unwrap();
        let meta = store.create("a scene", b"glTF-bytes", &[]).unwrap();
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
        std::fs::create_dir_all(store.tmp_dir().join("0123456789abcdef.upload")).unwrap();
        assert_eq!(store.list().unwrap().len(), 1);
        store.delete(&meta.id).unwrap();
        assert!(store.list().unwrap().is_empty());
        assert_eq!(
            std::fs::read_dir(store.tmp_dir()).unwrap().count(),
            2,
            "lock + upload"
        );
        let to = store
            .quarantine(&store.create("b", b"x", &[]).unwrap().id)
            .unwrap();
        assert!(to.join("scene.glb").is_file() && store.list().unwrap().is_empty());
    }

    #[test]
    fn temp_folders_of_gone_servers_are_removed_at_start_and_live_ones_kept() {
        let dir = tempfile::tempdir().unwrap();
        let live = Store::open(dir.path()).unwrap();
        std::fs::write(live.tmp_dir().join("half.glb"), b"in progress").unwrap();
        // A crashed server's folder: its lock file exists but nobody holds it.
        let dead = dir.path().join("tmp/00000000000000aa.live");
        std::fs::create_dir_all(dead.join("x.upload")).unwrap();
        std::fs::write(dead.join("lock"), b"").unwrap();
        let second = Store::open(dir.path()).unwrap();
        assert!(
            !dead.exists(),
            "a dead server's temp folder goes, however young"
        );
        assert!(live.tmp_dir().join("half.glb").exists(), "a live one stays");
        drop(live);
        let third = Store::open(dir.path()).unwrap();
        let left: Vec<_> = std::fs::read_dir(dir.path().join("tmp")).unwrap().collect();
        assert_eq!(left.len(), 2, "the second's and the third's: {left:?}");
        drop((second, third));
    }

    #[test]
    fn ids_are_checked() {
        assert!(valid_id("0123456789abcdef"));
        assert!(!valid_id("../etc/passwd0000"));
        assert!(!valid_id("0123456789ABCDEF"));
        assert!(!valid_id("demo"));
    }
}
