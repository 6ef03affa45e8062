//! The one cull worker: every cull (REST, batch, WebSocket) goes through it.
//!
//! Handlers never touch the GPU. They send a [`CullJob`] over a bounded
//! channel and await a oneshot reply. The worker, a plain thread because culling
//! blocks, takes the first waiting job, drains whatever else is waiting up to
//! `cull_batch` poses, groups the jobs by scene and options, and runs each group as
//! one batch: one submission, one readback. Under load many clients share one
//! submission, and the worker plans and records the next batch while the device runs
//! the last ([`pipeline`]); with one client a pose runs alone with no added wait. A
//! full queue is answered `overloaded` at once instead of growing without bound.
//!
//! The worker is supervised: a panic outside a cull (inside one it becomes that
//! batch's error) fails the jobs it held, and the worker starts over on the same queue,
//! up to `max_restarts` times. After that it stays stopped and [`WorkerHealth`] says so:
//! `/readyz` answers 503 and the server exits non-zero for its orchestrator to restart.

use std::collections::HashMap;
use std::panic::AssertUnwindSafe;
use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use homcull_proto::CullOptions;
use tokio::sync::{mpsc, oneshot, watch};

use super::error::ApiError;
use homcull_engine::camera::Camera;
use homcull_engine::cull::PoseResult;
use homcull_engine::engine::Engine;
use pipeline::{Pipeline, cull_batch};

mod pipeline;

/// A scene's engine, shared between its registry entry and the jobs that cull on it.
/// Only the worker locks it, so it is never contended.
pub type SharedEngine = Arc<std::sync::Mutex<Engine>>;

/// Poses of one request, to be culled with the same options on one scene.
pub struct CullJob {
    /// The engine of the scene the poses are culled on.
    pub engine: SharedEngine,
    pub cams: Vec<Camera>,
    pub options: CullOptions,
    /// Objects (ascending IDs) whose occluders every pose of the job selects first
    /// (`Culler::cull_preferring`): what a stream's client saw at its previous pose.
    pub prefer: Option<Arc<Vec<u32>>>,
    pub reply: oneshot::Sender<Result<Vec<PoseResult>, ApiError>>,
}

/// Sends jobs to the worker.
#[derive(Clone)]
pub struct WorkerHandle {
    tx: mpsc::Sender<CullJob>,
    pub health: Arc<WorkerHealth>,
}

/// How the worker is supervised.
#[derive(Debug, Clone, Copy)]
pub struct Supervision {
    /// Restarts after a panic before the worker stays stopped.
    pub max_restarts: u32,
    /// Fault injection for tests: the worker panics, outside any cull, on each of the
    /// first this many batches it takes. 0 in service.
    pub panic_first_batches: u32,
}

/// Whether the worker runs, and how often it was restarted.
#[derive(Debug)]
pub struct WorkerHealth {
    restarts: AtomicU32,
    stopped: watch::Sender<bool>,
}

impl WorkerHealth {
    pub fn restarts(&self) -> u32 {
        self.restarts.load(Ordering::SeqCst)
    }

    /// Whether the worker has stopped for good (it died more often than it may restart).
    pub fn stopped(&self) -> bool {
        *self.stopped.borrow()
    }

    /// Resolves once the worker has stopped for good.
    pub async fn wait_stopped(&self) {
        let mut rx = self.stopped.subscribe();
        let _ = rx.wait_for(|s| *s).await;
    }
}

impl WorkerHandle {
    /// Culls `cams` on `scene`, waiting for the worker's answer.
    pub async fn cull(
        &self,
        engine: SharedEngine,
        cams: Vec<Camera>,
        options: CullOptions,
    ) -> Result<Vec<PoseResult>, ApiError> {
        self.cull_preferring(engine, cams, options, None).await
    }

    /// [`WorkerHandle::cull`] with the occluders of `prefer` (ascending IDs) selected
    /// first for every pose.
    pub async fn cull_preferring(
        &self,
        engine: SharedEngine,
        cams: Vec<Camera>,
        options: CullOptions,
        prefer: Option<Arc<Vec<u32>>>,
    ) -> Result<Vec<PoseResult>, ApiError> {
        let (reply, rx) = oneshot::channel();
        let job = CullJob {
            engine,
            cams,
            options,
            prefer,
            reply,
        };
        self.tx.try_send(job).map_err(|e| match e {
            mpsc::error::TrySendError::Full(_) => {
                metrics::counter!("homcull_worker_rejected_total").increment(1);
                ApiError::overloaded("the GPU queue is full; try again shortly")
            }
            mpsc::error::TrySendError::Closed(_) => ApiError::new(
                axum::http::StatusCode::SERVICE_UNAVAILABLE,
                "worker_stopped",
                "the cull worker has stopped; the server is restarting",
            ),
        })?;
        rx.await
            .map_err(|_| ApiError::internal("the cull worker dropped the request"))?
    }
}

/// Starts the worker thread under `supervision`. It stops when every [`WorkerHandle`]
/// is dropped.
pub fn spawn(
    queue: usize,
    cull_batch: usize,
    batching: bool,
    supervision: Supervision,
) -> WorkerHandle {
    let (tx, rx) = mpsc::channel(queue.max(1));
    let health = Arc::new(WorkerHealth {
        restarts: AtomicU32::new(0),
        stopped: watch::Sender::new(false),
    });
    let h = health.clone();
    std::thread::Builder::new()
        .name("homcull-gpu".into())
        .spawn(move || supervise(rx, cull_batch.max(1), batching, supervision, &h))
        .expect("spawning the cull worker thread");
    WorkerHandle { tx, health }
}

/// Runs the worker, starting it over after a panic (see the module docs).
fn supervise(
    mut rx: mpsc::Receiver<CullJob>,
    cull_batch: usize,
    batching: bool,
    supervision: Supervision,
    health: &WorkerHealth,
) {
    let mut faults = supervision.panic_first_batches;
    loop {
        let ran = std::panic::catch_unwind(AssertUnwindSafe(|| {
            run(&mut rx, cull_batch, batching, &mut faults)
        }));
        let Err(panic) = ran else {
            return; // every handle is gone: the server has stopped
        };
        let restarts = health.restarts.fetch_add(1, Ordering::SeqCst) + 1;
        metrics::counter!("homcull_worker_restarts_total").increment(1);
        let what = panic_message(&*panic);
        if restarts > supervision.max_restarts {
            tracing::error!(
                "the cull worker died ({what}) after {} restarts; it stays stopped",
                supervision.max_restarts
            );
            health.stopped.send_replace(true);
            return; // drops the queue: waiting and new jobs fail at once
        }
        tracing::error!(
            "the cull worker died ({what}); restart {restarts} of {}",
            supervision.max_restarts
        );
    }
}

fn panic_message(panic: &(dyn std::any::Any + Send)) -> String {
    panic
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_default()
}

fn run(rx: &mut mpsc::Receiver<CullJob>, cull_batch: usize, batching: bool, faults: &mut u32) {
    let mut pipeline = Pipeline::default();
    let mut trim = IdleTrim::default();
    loop {
        // With a batch on the device, take what is waiting without blocking; when
        // nothing is, finish that batch (answering its clients) before waiting.
        let first = if pipeline.idle() {
            if rx.is_empty() {
                trim.on_idle();
            }
            rx.blocking_recv()
        } else {
            match rx.try_recv() {
                Ok(job) => Some(job),
                Err(mpsc::error::TryRecvError::Empty) => {
                    pipeline.drain();
                    continue;
                }
                Err(mpsc::error::TryRecvError::Disconnected) => None,
            }
        };
        let Some(first) = first else {
            pipeline.drain();
            break;
        };
        if *faults > 0 {
            *faults -= 1;
            panic!("injected fault");
        }
        let mut poses = first.cams.len();
        let mut jobs = vec![first];
        while batching && poses < cull_batch {
            match rx.try_recv() {
                Ok(job) => {
                    poses += job.cams.len();
                    jobs.push(job);
                }
                Err(_) => break,
            }
        }
        metrics::gauge!("homcull_worker_queue").set(rx.len() as f64);
        // A job whose client has gone (its request dropped, its socket closed) would
        // only spend device time: drop it here, before it reaches the device.
        let before = jobs.len();
        jobs.retain(|j| !j.reply.is_closed());
        if jobs.len() < before {
            metrics::counter!("homcull_worker_abandoned_total")
                .increment((before - jobs.len()) as u64);
        }
        if batching {
            for group in group_jobs(jobs) {
                pipeline.run_group(group, cull_batch);
            }
        } else {
            for job in jobs {
                run_one_by_one(job);
            }
        }
    }
    tracing::debug!("cull worker stopped");
}

/// Hands freed heap pages back to the OS when the worker runs out of work, at most once a
/// second. A burst of batches frees what it allocated (plans, masks, answers, the
/// software adapter's per-submission memory) into glibc's per-thread arenas, which keep
/// the pages: without this a server's resident memory stays at its busiest moment's
/// (seen in the soak test: +77 MiB after 20 s of load, against +20 MiB with it).
#[derive(Default)]
struct IdleTrim {
    last: Option<Instant>,
}

impl IdleTrim {
    fn on_idle(&mut self) {
        if self
            .last
            .is_some_and(|t| t.elapsed() < Duration::from_secs(1))
        {
            return;
        }
        super::alloc::release_free_heap();
        self.last = Some(Instant::now());
    }
}

/// Method, DEB, threshold bits, refine.
type OptionsKey = (u8, u8, u32, bool);

/// Every field of the options, as a key: jobs share a submission only if they would
/// get the same answer from it.
fn options_key(o: &CullOptions) -> OptionsKey {
    let CullOptions {
        method,
        threshold,
        deb,
        refine,
        lod: _, // levels are computed from the answer after the cull (core::lod)
    } = *o; // destructured: a new option field fails to compile until it is keyed
    (method as u8, deb as u8, threshold.to_bits(), refine)
}

/// Jobs grouped by what can share one submission: same scene, same options.
fn group_jobs(jobs: Vec<CullJob>) -> Vec<Vec<CullJob>> {
    let mut groups: HashMap<(usize, OptionsKey), Vec<CullJob>> = HashMap::new();
    let mut order = Vec::new();
    for job in jobs {
        let key = (Arc::as_ptr(&job.engine) as usize, options_key(&job.options));
        if !groups.contains_key(&key) {
            order.push(key);
        }
        groups.entry(key).or_default().push(job);
    }
    order
        .into_iter()
        .filter_map(|k| groups.remove(&k))
        .collect()
}

/// Without batching: one submission per pose (what batching is measured against).
fn run_one_by_one(job: CullJob) {
    let mut out = Vec::with_capacity(job.cams.len());
    for cam in &job.cams {
        if job.reply.is_closed() {
            return; // the client has gone
        }
        let prefer = [job.prefer.as_deref().map_or(&[][..], Vec::as_slice)];
        match cull_batch(&job.engine, std::slice::from_ref(cam), job.options, &prefer) {
            Ok(mut r) => out.append(&mut r),
            Err(e) => {
                let _ = job.reply.send(Err(e));
                return;
            }
        }
    }
    let _ = job.reply.send(Ok(out));
}

#[cfg(test)]
mod tests {
    use super::*;
    use homcull_proto::{DebVariant, Method};

    #[test]
    fn jobs_differing_in_any_option_do_not_share_a_submission() {
        let base = CullOptions::default();
        let variants = [
            CullOptions {
                method: Method::Hzb,
                ..base
            },
            CullOptions {
                threshold: 0.9,
                ..base
            },
            CullOptions {
                deb: DebVariant::Tiles,
                ..base
            },
            // A stream (box test) and a REST call (refined) at the same moment.
            CullOptions {
                refine: false,
                ..base
            },
        ];
        for v in variants {
            assert_ne!(options_key(&v), options_key(&base), "{v:?}");
        }
        assert_eq!(options_key(&base), options_key(&CullOptions::default()));
    }
}
