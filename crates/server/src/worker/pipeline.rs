//! The worker's batches as a pipeline of depth two: while the device runs one batch,
//! the worker plans, records and submits the next, then waits for the first.
//!
//! A batch is started ([`Engine::start_cull`]: planned, recorded, submitted) and
//! finished later ([`Engine::finish_cull`]: read back, answered). [`Pipeline`] keeps
//! at most one batch started and not finished between calls: starting another
//! finishes the older one right after the new one is on the device, and
//! [`Pipeline::drain`] finishes it when the worker has nothing else to start. With one
//! client the pipeline is always drained before the worker waits, so nothing waits
//! longer than before; under load the device never idles while the host plans.
//! A group of jobs (same scene, same options) may span several batches; its jobs are
//! answered when its last batch finishes, or at its first error.
//!
//! [`Engine::start_cull`]: homcull_engine::engine::Engine::start_cull
//! [`Engine::finish_cull`]: homcull_engine::engine::Engine::finish_cull

use std::panic::AssertUnwindSafe;
use std::time::Instant;

use homcull_proto::CullOptions;

use super::{CullJob, SharedEngine, panic_message};
use crate::error::ApiError;
use homcull_engine::camera::Camera;
use homcull_engine::cull::{PoseResult, StartedCull};

/// Groups being answered and the batch on the device.
#[derive(Default)]
pub(super) struct Pipeline {
    /// Groups with batches started and not all finished, by sequence number.
    groups: Vec<GroupRun>,
    next_group: u64,
    in_flight: Option<Flight>,
}

/// The jobs of one group and the answers gathered so far.
struct GroupRun {
    seq: u64,
    jobs: Vec<CullJob>,
    results: Vec<PoseResult>,
    /// Batches started and not finished.
    pending: usize,
    /// Every batch of the group has been started (or it stopped early).
    sealed: bool,
    /// An error has been sent to its jobs; answers still coming are dropped.
    failed: bool,
}

/// A batch started and not finished.
struct Flight {
    group: u64,
    engine: SharedEngine,
    started: StartedCull,
    options: CullOptions,
    at: Instant,
}

impl Pipeline {
    /// Whether no batch is on the device.
    pub(super) fn idle(&self) -> bool {
        self.in_flight.is_none()
    }

    /// Runs a group of jobs that share an engine and options as batches of at most
    /// `cull_batch` poses, each started before the previous one is finished. Between
    /// batches it stops if every client of the group has gone (a huge batch from a
    /// client that timed out does not hold the device for others).
    pub(super) fn run_group(&mut self, jobs: Vec<CullJob>, cull_batch: usize) {
        let seq = self.next_group;
        self.next_group += 1;
        let engine = jobs[0].engine.clone();
        let options = jobs[0].options;
        let cams: Vec<Camera> = jobs.iter().flat_map(|j| j.cams.iter().cloned()).collect();
        let prefer: Vec<Option<std::sync::Arc<Vec<u32>>>> = jobs
            .iter()
            .flat_map(|j| std::iter::repeat_n(j.prefer.clone(), j.cams.len()))
            .collect();
        self.groups.push(GroupRun {
            seq,
            jobs,
            results: Vec::with_capacity(cams.len()),
            pending: 0,
            sealed: false,
            failed: false,
        });
        for (chunk, chunk_prefer) in cams.chunks(cull_batch).zip(prefer.chunks(cull_batch)) {
            // Gone when an earlier batch of the group failed (it was answered then).
            let Some(group) = self.group(seq) else { break };
            if group.jobs.iter().all(|j| j.reply.is_closed()) {
                metrics::counter!("homcull_worker_abandoned_total")
                    .increment(group.jobs.len() as u64);
                group.failed = true; // nobody to answer
                break;
            }
            let prefer: Vec<&[u32]> = chunk_prefer
                .iter()
                .map(|p| p.as_deref().map_or(&[][..], Vec::as_slice))
                .collect();
            let at = Instant::now();
            match start_batch(&engine, chunk, options, &prefer) {
                Ok(started) => {
                    group.pending += 1;
                    let flight = Flight {
                        group: seq,
                        engine: engine.clone(),
                        started,
                        options,
                        at,
                    };
                    if let Some(older) = self.in_flight.replace(flight) {
                        if older.started.in_flight() {
                            // This batch was recorded while the device ran the older one.
                            metrics::counter!("homcull_worker_overlapped_batches_total")
                                .increment(1);
                        }
                        self.finish(older);
                    }
                }
                Err(e) => {
                    fail(group, e);
                    break;
                }
            }
        }
        if let Some(group) = self.group(seq) {
            group.sealed = true;
        }
        self.answer_complete();
    }

    /// Finishes the batch on the device, if any, and answers the groups it completes.
    pub(super) fn drain(&mut self) {
        if let Some(flight) = self.in_flight.take() {
            self.finish(flight);
        }
        self.answer_complete();
    }

    fn group(&mut self, seq: u64) -> Option<&mut GroupRun> {
        self.groups.iter_mut().find(|g| g.seq == seq)
    }

    fn finish(&mut self, flight: Flight) {
        let Flight {
            group,
            engine,
            started,
            options,
            at,
        } = flight;
        let poses = started.poses();
        let out = finish_batch(&engine, started);
        metrics::histogram!("homcull_cull_batch_poses").record(poses as f64);
        metrics::histogram!("homcull_cull_batch_seconds").record(at.elapsed().as_secs_f64());
        metrics::counter!("homcull_culls_total", "method" => options.method.name())
            .increment(poses as u64);
        let Some(group) = self.group(group) else {
            return;
        };
        group.pending -= 1;
        match out {
            Ok(mut r) if !group.failed => group.results.append(&mut r),
            Ok(_) => {}
            Err(e) => fail(group, e),
        }
        self.answer_complete();
    }

    /// Answers and forgets every group whose batches are all finished.
    fn answer_complete(&mut self) {
        let (done, running): (Vec<_>, Vec<_>) = std::mem::take(&mut self.groups)
            .into_iter()
            .partition(|g| g.failed || (g.sealed && g.pending == 0));
        self.groups = running;
        for group in done {
            if group.failed {
                continue; // already answered with the error
            }
            // Hand each job its slice, in order.
            let mut results = group.results;
            for job in group.jobs.into_iter().rev() {
                let tail = results.split_off(results.len() - job.cams.len());
                let _ = job.reply.send(Ok(tail));
            }
        }
    }
}

/// Sends `e` to every job of `group` (once: the jobs are handed their answer and
/// dropped) and marks it failed.
fn fail(group: &mut GroupRun, e: ApiError) {
    group.failed = true;
    for job in std::mem::take(&mut group.jobs) {
        let _ = job.reply.send(Err(e.clone()));
    }
}

/// Starts one batch on a scene's engine, turning panics into errors so that one bad
/// batch never takes the worker down.
fn start_batch(
    engine: &SharedEngine,
    cams: &[Camera],
    options: CullOptions,
    prefer: &[&[u32]],
) -> Result<StartedCull, ApiError> {
    guarded(|| {
        let mut engine = engine.lock().unwrap_or_else(|p| p.into_inner());
        let settings = engine.settings(options);
        engine.start_cull(cams, &settings, prefer)
    })
}

/// Finishes a batch [`start_batch`] started on the same engine, as guarded.
fn finish_batch(engine: &SharedEngine, started: StartedCull) -> Result<Vec<PoseResult>, ApiError> {
    guarded(|| {
        let mut engine = engine.lock().unwrap_or_else(|p| p.into_inner());
        engine.finish_cull(started)
    })
}

/// Runs `f`, a step of a cull, with a panic turned into an internal error.
fn guarded<T>(
    f: impl FnOnce() -> Result<T, homcull_engine::cull::CullError>,
) -> Result<T, ApiError> {
    match std::panic::catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(t)) => Ok(t),
        Ok(Err(e)) => Err(e.into()),
        Err(panic) => {
            tracing::error!("a cull panicked: {}", panic_message(&*panic));
            Err(ApiError::internal("the cull failed inside the engine"))
        }
    }
}

/// One batch started and finished at once (the worker without batching).
pub(super) fn cull_batch(
    engine: &SharedEngine,
    cams: &[Camera],
    options: CullOptions,
    prefer: &[&[u32]],
) -> Result<Vec<PoseResult>, ApiError> {
    let at = Instant::now();
    let out = start_batch(engine, cams, options, prefer).and_then(|s| finish_batch(engine, s));
    metrics::histogram!("homcull_cull_batch_poses").record(cams.len() as f64);
    metrics::histogram!("homcull_cull_batch_seconds").record(at.elapsed().as_secs_f64());
    metrics::counter!("homcull_culls_total", "method" => options.method.name())
        .increment(cams.len() as u64);
    out
}
