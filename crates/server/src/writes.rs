//! The one way a scene's placements change: an update is checked whole
//! (`Dynamics::check`), made durable as the server keeps its state ([`Durability`]:
//! in memory, or first appended to the scene's journal, [`super::journal`]), then
//! applied (`Dynamics::commit`) as the next version. Nothing is applied that is not
//! kept, and a scene made resident again gets its placements back from its journal
//! ([`recover`]) before it serves.

use std::sync::{Arc, Mutex};

use super::error::ApiError;
use super::journal::{Journal, StateDir, content_of};
use homcull_engine::dynamic::Dynamics;
use homcull_engine::scene::Scene;
use homcull_proto::TransformsRequest;

/// How a scene's updates are kept.
pub enum Durability {
    /// In memory only (`--state memory`).
    Memory,
    /// Journaled before they are applied.
    Journal(Mutex<Journal>),
    /// The journal could not be opened or replayed: updates are refused (503
    /// `state_unavailable`) rather than accepted and lost at the next restart.
    Broken(String),
}

/// The writers' side of a scene: its placements and how updates are kept.
pub struct Writes {
    pub dynamics: Arc<Mutex<Dynamics>>,
    pub durability: Durability,
}

impl Writes {
    /// Checks `req`, journals it (when the scene keeps a journal) and applies it: the
    /// version it made. Nothing is applied unless it is on disk; a journal that cannot
    /// be written refuses the update with 503 `state_unavailable`.
    pub fn apply(&self, req: &TransformsRequest, max_objects: usize) -> Result<u64, ApiError> {
        match &self.durability {
            Durability::Memory => Ok(lock(&self.dynamics).apply(req, max_objects)?),
            Durability::Broken(why) => Err(unavailable(why.clone())),
            Durability::Journal(journal) => {
                // The journal's lock orders the writers; the placements' lock is not
                // held over the flush, so culls do not wait for the disk. Only
                // commits change what a check found, and only writers commit.
                let mut journal = journal.lock().unwrap_or_else(|p| p.into_inner());
                let checked = lock(&self.dynamics).check(req, max_objects)?;
                let started = std::time::Instant::now();
                journal
                    .append(checked.version, req)
                    .map_err(|e| unavailable(format!("writing the placement journal: {e}")))?;
                metrics::histogram!("homcull_journal_append_seconds")
                    .record(started.elapsed().as_secs_f64());
                let mut d = lock(&self.dynamics);
                let version = d.commit(checked);
                if journal.due() {
                    let placed = d.placed();
                    drop(d);
                    match journal.compact(&placed) {
                        Ok(()) => {
                            metrics::counter!("homcull_journal_compactions_total").increment(1)
                        }
                        // The log goes on growing; the next update tries again.
                        Err(e) => tracing::warn!("compacting a placement journal: {e}"),
                    }
                }
                Ok(version)
            }
        }
    }
}

fn lock(d: &Mutex<Dynamics>) -> std::sync::MutexGuard<'_, Dynamics> {
    d.lock().unwrap_or_else(|p| p.into_inner())
}

fn unavailable(message: String) -> ApiError {
    ApiError::new(
        axum::http::StatusCode::SERVICE_UNAVAILABLE,
        "state_unavailable",
        message,
    )
}

/// How scene `id` (as loaded: `scene`) keeps its updates, with its placements
/// `dynamics` restored from its journal in `journals` (`None`: in memory). A journal
/// that cannot be opened or replayed leaves the scene at the file's placements and its
/// updates refused ([`Durability::Broken`]), never accepted to be lost at the next
/// restart.
pub fn recover(
    journals: Option<&StateDir>,
    id: &str,
    scene: &Scene,
    dynamics: &Mutex<Dynamics>,
) -> Durability {
    let Some(dir) = journals else {
        return Durability::Memory;
    };
    let restored = dir
        .journal(id, &content_of(scene))
        .map_err(|e| e.to_string())
        .and_then(|(journal, recovered)| {
            let mut d = dynamics.lock().unwrap_or_else(|p| p.into_inner());
            d.restore(&recovered.placed)
                .map_err(|e| format!("its snapshot: {e}"))?;
            for (version, update) in &recovered.updates {
                // Checked when it was accepted; no limit of today's applies to it.
                match d.apply(update, usize::MAX) {
                    Ok(made) if made == *version => {}
                    Ok(made) => return Err(format!("update {version} replayed as {made}")),
                    Err(e) => return Err(format!("update {version}: {e}")),
                }
            }
            let updates = recovered.updates.len();
            Ok((journal, d.version(), updates))
        });
    match restored {
        Ok((journal, version, updates)) => {
            if version > 0 {
                tracing::info!(%id, version, replayed = updates, "placements restored from the journal");
            }
            Durability::Journal(Mutex::new(journal))
        }
        Err(e) => {
            let why = format!(
                "scene {id}: the placement journal cannot be used ({e}); updates are refused until it is mended or removed"
            );
            tracing::error!("{why}");
            Durability::Broken(why)
        }
    }
}
