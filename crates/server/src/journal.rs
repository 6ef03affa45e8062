//! Placements that survive a restart (`--state journal`, the default): every accepted
//! transform update is appended to its scene's journal and flushed to disk before it
//! is acknowledged, and a scene made resident again (a restart, also after `kill -9`)
//! replays its journal, so it serves the same placements at the same version.
//!
//! Layout under `--data-dir`:
//! ```text
//! state/lock                 held by the one server that owns the journals
//! state/<id>/snapshot.json   {"content", "placed": {"version", "horizon_s", "objects"}}
//! state/<id>/log.jsonl       one {"version", "update"} line per update since the snapshot
//! ```
//! `content` is the SHA-256 of the scene as loaded (geometry, object names and
//! dynamic marks, [`content_of`]): a journal is replayed only onto the scene it was
//! written for. A changed `--scene` file or demo city starts again from the file's
//! placements, at the version the old journal had reached, so versions never go back
//! for a scene id. Every [`COMPACT_EVERY`] updates the placements are written as a new
//! snapshot (to a temporary file, flushed, renamed over the old one) and the log is
//! emptied. A crash mid-append leaves a torn last line, never acknowledged: replay
//! stops there and cuts it off.
//!
//! One server per data dir: `state/lock` is taken at start, and a second server
//! pointed at the same directory with `--state journal` refuses to start (replicas
//! that share a volume run with `--state memory`).

use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Seek, Write};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use homcull_engine::dynamic::Placed;
use homcull_engine::scene::Scene;
use homcull_proto::TransformsRequest;

use super::store::{sync_dir, try_lock, write_synced};

/// Updates after which the placements are written as a snapshot and the log emptied.
pub const COMPACT_EVERY: usize = 1024;
/// How long a start waits for the lock of a server still shutting down.
const LOCK_WAIT: std::time::Duration = std::time::Duration::from_secs(5);

/// The journals of one data dir, locked by this server.
pub struct StateDir {
    root: PathBuf,
    _lock: File,
}

/// A journal's snapshot file.
#[derive(Debug, Serialize, Deserialize)]
struct Snapshot {
    content: String,
    placed: Placed,
}

/// One line of a journal's log (the update borrowed when written, owned when read).
#[derive(Debug, Serialize, Deserialize)]
struct Entry<U> {
    version: u64,
    update: U,
}

/// What a scene's journal held when it was opened: the placements to restore and
/// the updates to apply after them, in order.
#[derive(Debug)]
pub struct Recovered {
    pub placed: Placed,
    pub updates: Vec<(u64, TransformsRequest)>,
}

/// One scene's open journal.
pub struct Journal {
    dir: PathBuf,
    content: String,
    log: File,
    /// Updates in the log since the snapshot.
    entries: usize,
}

impl StateDir {
    /// Opens (creating) `DATA/state` and takes its lock; an error if another live
    /// server holds it for 5 s (`LOCK_WAIT`: a restart may start before the old process
    /// has exited).
    pub fn open(data_dir: &Path) -> std::io::Result<StateDir> {
        let root = data_dir.join("state");
        std::fs::create_dir_all(&root)?;
        let lock = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(root.join("lock"))?;
        let deadline = std::time::Instant::now() + LOCK_WAIT;
        while !try_lock(&lock) {
            if std::time::Instant::now() >= deadline {
                return Err(std::io::Error::other(format!(
                    "another homcull server keeps its placement journal in {}: run one server \
                 per data dir with --state journal, or --state memory for replicas that \
                 share it",
                    root.display()
                )));
            }
            std::thread::sleep(std::time::Duration::from_millis(100));
        }
        Ok(StateDir { root, _lock: lock })
    }

    /// Opens the journal of scene `id`, whose content is `content` ([`content_of`]):
    /// what it holds for that content, or a fresh start (at the version an older
    /// content's journal reached) when it was written for another.
    pub fn journal(&self, id: &str, content: &str) -> std::io::Result<(Journal, Recovered)> {
        let dir = self.root.join(id);
        std::fs::create_dir_all(&dir)?;
        let old: Option<Snapshot> = match std::fs::read(dir.join("snapshot.json")) {
            Ok(bytes) => Some(serde_json::from_slice(&bytes).map_err(invalid)?),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => return Err(e),
        };
        let log_path = dir.join("log.jsonl");
        // The updates after the snapshot, one by one, and the length of the log that
        // holds just them (and older ones the snapshot has).
        let after = old.as_ref().map_or(0, |s| s.placed.version);
        let (updates, replayable) = consecutive(after, read_log(&log_path)?);
        let reached = updates.last().map_or(after, |u| u.0);
        let (recovered, rewrite) = match old {
            Some(s) if s.content == content => (
                Recovered {
                    placed: s.placed,
                    updates,
                },
                false,
            ),
            // Written for another content (or never): start from the file, and never
            // at a lower version than the old journal reached.
            _ => (
                Recovered {
                    placed: Placed {
                        version: reached,
                        horizon_s: Placed::default_horizon_s(),
                        objects: Vec::new(),
                    },
                    updates: Vec::new(),
                },
                true,
            ),
        };
        let log = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&log_path)?;
        let mut journal = Journal {
            dir,
            content: content.to_string(),
            log,
            entries: recovered.updates.len(),
        };
        if rewrite {
            journal.compact(&recovered.placed)?;
        } else {
            // What replay did not take (a torn last line from a crash mid-append, or
            // whatever follows a gap) is cut off, so that appends follow the last
            // update replayed and the next replay reaches them.
            journal.log.set_len(replayable)?;
            journal.log.seek(std::io::SeekFrom::Start(replayable))?;
        }
        Ok((journal, recovered))
    }

    /// Forgets scene `id`'s journal (the scene was deleted).
    pub fn remove(&self, id: &str) -> std::io::Result<()> {
        match std::fs::remove_dir_all(self.root.join(id)) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(e),
            _ => Ok(()),
        }
    }
}

impl Journal {
    /// Appends update `update`, to be applied as `version`, and flushes it to disk.
    pub fn append(&mut self, version: u64, update: &TransformsRequest) -> std::io::Result<()> {
        let mut line =
            serde_json::to_vec(&Entry { version, update }).map_err(std::io::Error::other)?;
        line.push(b'\n');
        self.log.write_all(&line)?;
        self.log.sync_data()?;
        self.entries += 1;
        Ok(())
    }

    /// Whether the log has grown enough to be compacted.
    pub fn due(&self) -> bool {
        self.entries >= COMPACT_EVERY
    }

    /// Writes `placed` (the placements after every logged update) as the snapshot and
    /// empties the log.
    pub fn compact(&mut self, placed: &Placed) -> std::io::Result<()> {
        let snapshot = Snapshot {
            content: self.content.clone(),
            placed: placed.clone(),
        };
        let tmp = self.dir.join("snapshot.json.tmp");
        write_synced(
            &tmp,
            &serde_json::to_vec(&snapshot).map_err(std::io::Error::other)?,
        )?;
        std::fs::rename(&tmp, self.dir.join("snapshot.json"))?;
        sync_dir(&self.dir)?;
        self.log.set_len(0)?;
        self.log.seek(std::io::SeekFrom::Start(0))?;
        self.log.sync_all()?;
        self.entries = 0;
        Ok(())
    }
}

/// The SHA-256 (hex) of a scene as loaded: its geometry, and each object's id, name,
/// index range and dynamic mark.
pub fn content_of(scene: &Scene) -> String {
    let mut h = Sha256::new();
    for p in &scene.positions {
        for c in p.to_array() {
            h.update(c.to_le_bytes());
        }
    }
    for i in &scene.indices {
        h.update(i.to_le_bytes());
    }
    for o in &scene.objects {
        h.update(o.id.to_le_bytes());
        h.update((o.name.len() as u64).to_le_bytes());
        h.update(o.name.as_bytes());
        h.update(o.first_index.to_le_bytes());
        h.update(o.index_count.to_le_bytes());
        h.update([u8::from(o.dynamic)]);
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// The log's whole entries in order, each with the offset just past its line.
fn read_log(path: &Path) -> std::io::Result<Vec<(u64, TransformsRequest, u64)>> {
    let file = match File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(e),
    };
    let (mut entries, mut end) = (Vec::new(), 0u64);
    let mut reader = BufReader::new(file);
    let mut line = Vec::new();
    loop {
        line.clear();
        let n = reader.read_until(b'\n', &mut line)?;
        if n == 0 || line.last() != Some(&b'\n') {
            break; // the end, or a torn last line
        }
        end += n as u64;
        match serde_json::from_slice::<Entry<TransformsRequest>>(&line) {
            Ok(e) => entries.push((e.version, e.update, end)),
            Err(e) => {
                tracing::warn!(path = %path.display(), "a journal line does not parse ({e}); replay stops there");
                break;
            }
        }
    }
    Ok(entries)
}

/// The updates that follow version `after` one by one (older ones are in the
/// snapshot already; a gap ends the run), and the length of the log up to the last
/// entry taken or passed over.
fn consecutive(
    after: u64,
    entries: Vec<(u64, TransformsRequest, u64)>,
) -> (Vec<(u64, TransformsRequest)>, u64) {
    let (mut next, mut end) = (after + 1, 0);
    let mut out = Vec::new();
    for (v, u, line_end) in entries {
        if v > next {
            tracing::warn!(
                expected = next,
                found = v,
                "a gap in a journal; replay stops there"
            );
            break;
        }
        if v == next {
            out.push((v, u));
            next += 1;
        }
        end = line_end;
    }
    (out, end)
}

fn invalid(e: serde_json::Error) -> std::io::Error {
    std::io::Error::new(std::io::ErrorKind::InvalidData, e)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Mat4, Vec3};
    use homcull_engine::dynamic::Placement;

    fn update(id: u32, x: f32) -> TransformsRequest {
        serde_json::from_value(
            serde_json::json!({"objects": [{"id": id, "translation": [x, 0.0, 0.0]}]}),
        )
        .unwrap()
    }

    /// The versions of the updates a journal gave back.
    fn versions(rec: &Recovered) -> Vec<u64> {
        rec.updates.iter().map(|u| u.0).collect()
    }

    fn placed(version: u64) -> Placed {
        Placed {
            version,
            horizon_s: 0.25,
            objects: vec![(
                3,
                Placement {
                    matrix: Mat4::from_translation(Vec3::new(0.1, 0.2, 0.3)),
                    velocity: Vec3::new(1.0 / 3.0, 0.0, 0.0),
                    angular_velocity: Vec3::ZERO,
                    motion_s: f32::INFINITY,
                },
            )],
        }
    }

    #[test]
    fn updates_come_back_in_order_and_a_torn_tail_is_cut() {
        let dir = tempfile::tempdir().unwrap();
        let state = StateDir::open(dir.path()).unwrap();
        let (mut j, rec) = state.journal("s", "c1").unwrap();
        assert_eq!((rec.placed.version, rec.updates.len()), (0, 0));
        j.append(1, &update(1, 1.0)).unwrap();
        j.append(2, &update(2, 2.0)).unwrap();
        drop(j);
        // A crash mid-append: half a line, never acknowledged.
        let log = dir.path().join("state/s/log.jsonl");
        let mut f = OpenOptions::new().append(true).open(&log).unwrap();
        f.write_all(br#"{"version":3,"upd"#).unwrap();
        drop(f);
        let (mut j, rec) = state.journal("s", "c1").unwrap();
        assert_eq!(versions(&rec), [1, 2]);
        assert_eq!(rec.updates[1].1, update(2, 2.0));
        // The torn line is gone: the next append follows the last whole one.
        j.append(3, &update(1, 3.0)).unwrap();
        drop(j);
        let (_, rec) = state.journal("s", "c1").unwrap();
        assert_eq!(versions(&rec), [1, 2, 3]);
    }

    #[test]
    fn what_follows_a_gap_is_cut_so_that_new_updates_replay() {
        let dir = tempfile::tempdir().unwrap();
        let state = StateDir::open(dir.path()).unwrap();
        let (mut j, _) = state.journal("s", "c1").unwrap();
        for v in [1, 2, 4] {
            j.append(v, &update(1, v as f32)).unwrap();
        }
        drop(j);
        let (mut j, rec) = state.journal("s", "c1").unwrap();
        assert_eq!(versions(&rec), [1, 2]);
        j.append(3, &update(1, 3.0)).unwrap();
        drop(j);
        let (_, rec) = state.journal("s", "c1").unwrap();
        assert_eq!(versions(&rec), [1, 2, 3]);
    }

    #[test]
    fn a_snapshot_holds_the_placements_exactly_and_empties_the_log() {
        let dir = tempfile::tempdir().unwrap();
        let state = StateDir::open(dir.path()).unwrap();
        let (mut j, _) = state.journal("s", "c1").unwrap();
        for v in 1..=5 {
            j.append(v, &update(1, v as f32)).unwrap();
        }
        j.compact(&placed(5)).unwrap();
        j.append(6, &update(2, 6.0)).unwrap();
        drop(j);
        let (_, rec) = state.journal("s", "c1").unwrap();
        assert_eq!(rec.placed, placed(5), "bit for bit, infinity included");
        assert_eq!(versions(&rec), [6]);
    }

    #[test]
    fn another_content_starts_from_the_file_at_the_version_reached() {
        let dir = tempfile::tempdir().unwrap();
        let state = StateDir::open(dir.path()).unwrap();
        let (mut j, _) = state.journal("s", "c1").unwrap();
        j.compact(&placed(7)).unwrap();
        j.append(8, &update(1, 1.0)).unwrap();
        drop(j);
        let (mut j, rec) = state.journal("s", "c2").unwrap();
        assert_eq!(rec.placed.version, 8, "versions never go back for an id");
        assert!(rec.placed.objects.is_empty() && rec.updates.is_empty());
        j.append(9, &update(1, 2.0)).unwrap();
        drop(j);
        // Back to the first content: its journal was replaced, not kept beside.
        let (_, rec) = state.journal("s", "c1").unwrap();
        assert_eq!(rec.placed.version, 9);
        assert!(rec.updates.is_empty());
        state.remove("s").unwrap();
        assert!(!dir.path().join("state/s").exists());
        state.remove("s").unwrap();
    }

    #[test]
    fn one_server_per_data_dir() {
        let dir = tempfile::tempdir().unwrap();
        let _first = StateDir::open(dir.path()).unwrap();
        let second = StateDir::open(dir.path()).err().unwrap();
        assert!(second.to_string().contains("--state memory"), "{second}");
    }
}
