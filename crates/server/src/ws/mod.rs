//! WebSocket streaming: `GET /v1/scenes/{id}/stream`.
//!
//! The server sends a hello frame, then answers poses with full or delta frames
//! (binary, `homcull_proto::frame`). Each client has two tasks:
//! - the reader ([`reader`]) decodes poses (binary pose frames or JSON text
//!   [`PoseMessage`]) and puts each into a one-slot mailbox, replacing any pose still waiting there:
//!   **latest pose wins**, superseded poses are dropped and counted, never queued;
//! - the sender takes the mailbox's pose when the previous answer is out (and no
//!   sooner than the frame-rate cap allows), sends it to the cull worker, and writes a
//!   delta against the last set it sent, or a full frame on the first answer, every
//!   `full_every` frames, when the client asks, and when the change is too big for a
//!   delta frame (more than 65535 IDs added or removed, see `VisibleDelta::fits`).
//!
//! Options in the query string: `method`, `threshold`, `deb` as for `POST /cull`, and the
//! opt-in smoothing `lookahead_ms` and `hold_ms` ([`super::motion`]), which stream a
//! superset of the pose's cull, and `placements=true`: JSON text messages saying where
//! moved objects are ([`placements`]); `region_m` and `turn_deg` make it a region
//! stream, which culls once per region and answers the poses inside it without a
//! cull ([`region`]). A stream may also move objects ([`writer`]).
//!
//! A client that stops reading is dropped within the send timeout, not when the kernel's
//! buffers fill: the sender pings it every quarter of the timeout, and a ping left
//! unanswered for the whole timeout ends the stream (browsers and WebSocket libraries
//! answer pings as they read). A client that sends no pose for the idle timeout is
//! closed (1008); pongs do not count as sending. Malformed frames get an error frame; a
//! flood of them closes the socket. A stream keeps its connection's place under the
//! per-address cap (`listen::ConnectionSlot`).

mod frames;
mod liveness;
mod placements;
mod reader;
mod region;
mod sink;
mod writer;

use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use axum::extract::rejection::QueryRejection;
use axum::extract::ws::{CloseFrame, Message, Utf8Bytes, WebSocket, WebSocketUpgrade};
use axum::extract::{Extension, Path, Query, State};
use axum::response::Response;
use futures_util::{SinkExt, StreamExt};
use glam::Vec3;
use homcull_proto::frame::{ErrorCode, ErrorFrame, Frame, Hello};
use homcull_proto::{CullOptions, CullOptionsQuery, PROTOCOL_VERSION, Pose, Surface};
use serde::Deserialize;
use tokio::sync::{Mutex, Notify, mpsc};

use frames::{Sent, frame_stats, smoothed, visibility_frame};
use liveness::{Liveness, Tick};
use sink::{send, send_text};

use super::error::ApiError;
use super::listen::{AddressSlot, ConnectionSlot};
use super::motion::{HeldSet, MAX_HOLD_MS, MAX_LOOKAHEAD_MS, moved};
use super::state::{AppState, SceneEntry, WsClientSlot};
use homcull_engine::camera::Camera;
use homcull_engine::camera::stereo;
use homcull_engine::lod;

/// Largest message a client may send (a pose frame is 68 bytes).
const MAX_CLIENT_MESSAGE: usize = 64 << 10;
/// Consecutive malformed messages after which the socket is closed.
const MAX_BAD_MESSAGES: u32 = 64;

/// A stream's own choices, from the query string beside its cull options
/// ([`CullOptionsQuery`], whose defaults for streams are `CullOptions::defaults`'s).
#[derive(Debug, Deserialize, utoipa::IntoParams)]
pub struct StreamQuery {
    /// Also cull the pose extrapolated this far ahead along the client's recent motion
    /// and stream the union (0 = off, the default; at most 1000). Covers what walking
    /// reveals during a round trip.
    pub lookahead_ms: Option<u32>,
    /// Keep each object in the streamed set this long after a cull last returned it
    /// (0 = off, the default; at most 10000). Stops flicker of tiny distant objects.
    pub hold_ms: Option<u32>,
    /// Select first, as occluders, the objects streamed for the previous pose
    /// (temporal coherence; default false). Matters only when the occluder budget
    /// cannot take every in-frustum occluder; then the set may be smaller than
    /// `POST /cull`'s for the same pose (never missing what the pose shows).
    pub seen_first: Option<bool>,
    /// Before a frame, a JSON text message with the scene version it was culled at and
    /// where its moved objects are, when either changed (default false).
    pub placements: Option<bool>,
    /// Cull once per region instead of once per pose: every eye within this many
    /// metres of the region's centre (0 < r ≤ 5). Each region is announced with a region
    /// frame before its set; poses that stay inside get empty deltas. Mono poses only;
    /// no smoothing.
    pub region_m: Option<f32>,
    /// With `region_m`: view directions within this many degrees of the pose's (0–45,
    /// default 0).
    pub turn_deg: Option<f32>,
}

/// A stream's other choices: occluders seen first, placements told, and whether it
/// may move objects ([`writer`]).
#[derive(Debug, Clone, Copy)]
struct Choices {
    seen_first: bool,
    placements: bool,
    may_write: bool,
    region: Option<region::RegionSpec>,
}

/// How a stream shapes its sets (see [`super::motion`]); both off by default, when the
/// streamed set equals `POST /cull`'s for the same pose.
#[derive(Debug, Clone, Copy, Default, serde::Serialize)]
struct Smoothing {
    lookahead_ms: u32,
    hold_ms: u32,
}

/// Opens a visibility stream (WebSocket upgrade). See the README for the frame layout.
#[utoipa::path(get, path = "/v1/scenes/{id}/stream",
    params(("id" = String, Path, description = "scene id"), CullOptionsQuery, StreamQuery),
    responses((status = 101, description = "switching to WebSocket"),
        (status = 404, body = homcull_proto::ErrorBody), (status = 503, body = homcull_proto::ErrorBody)))]
pub async fn stream(
    State(state): State<AppState>,
    connection: Option<Extension<ConnectionSlot>>,
    Path(id): Path<String>,
    options: Result<Query<CullOptionsQuery>, QueryRejection>,
    query: Result<Query<StreamQuery>, QueryRejection>,
    headers: axum::http::HeaderMap,
    ws: WebSocketUpgrade,
) -> Result<Response, ApiError> {
    let bad_query = |e: QueryRejection| ApiError::bad_request("bad_query", e.body_text());
    let Query(q) = query.map_err(bad_query)?;
    let Query(options) = options.map_err(bad_query)?;
    let options = options
        .over(CullOptions::defaults(Surface::Stream))
        .map_err(|e| ApiError::bad_request("invalid_options", e.to_string()))?;
    options.validate()?;
    let smoothing = Smoothing {
        lookahead_ms: q.lookahead_ms.unwrap_or(0),
        hold_ms: q.hold_ms.unwrap_or(0),
    };
    if smoothing.lookahead_ms > MAX_LOOKAHEAD_MS || smoothing.hold_ms > MAX_HOLD_MS {
        return Err(ApiError::bad_request(
            "invalid_options",
            format!(
                "lookahead_ms must be at most {MAX_LOOKAHEAD_MS} and hold_ms at most \
                 {MAX_HOLD_MS}, got {} and {}",
                smoothing.lookahead_ms, smoothing.hold_ms
            ),
        ));
    }
    let region = region::RegionSpec::of(q.region_m, q.turn_deg)
        .map_err(|e| ApiError::bad_request("invalid_options", e))?;
    if region.is_some() && (smoothing.lookahead_ms != 0 || smoothing.hold_ms != 0) {
        return Err(ApiError::bad_request(
            "invalid_options",
            "a region stream takes no lookahead_ms or hold_ms: its sets hold for the region",
        ));
    }
    let choices = Choices {
        region,
        seen_first: q.seen_first.unwrap_or(false),
        placements: q.placements.unwrap_or(false),
        may_write: super::guard::check_token(&state, &headers).is_ok(),
    };
    super::guard::check_origin(&headers, &state.config.allowed_origins)?;
    if state.config.auth == super::AuthScope::Cull {
        super::guard::check_token(&state, &headers)?;
    }
    let scene = state.scene(&id)?;
    let slot = state.try_ws_slot().ok_or_else(|| {
        ApiError::overloaded(format!(
            "too many WebSocket clients (limit {})",
            state.config.max_ws_clients
        ))
    })?;
    // The stream goes on counting as its connection against the per-address cap (taken
    // only now: a refused upgrade leaves the connection, still open, counted).
    let address = connection.and_then(|Extension(c)| c.take());
    Ok(ws
        .max_message_size(MAX_CLIENT_MESSAGE)
        .max_frame_size(MAX_CLIENT_MESSAGE)
        .on_upgrade(move |socket| {
            let slots = (slot, address);
            client(socket, state, scene, options, smoothing, choices, slots)
        }))
}

/// A pose waiting to be culled.
struct Pending {
    seq: u32,
    pose: Pose,
    /// The pose's cameras: one, or a stereo pose's two eyes.
    eyes: Vec<Camera>,
    want_full: bool,
    /// Eye velocity when it arrived (m/s), for the lookahead.
    velocity: Vec3,
}

/// The one-slot mailbox between a client's reader and sender.
#[derive(Default)]
struct Mailbox {
    pose: std::sync::Mutex<Option<Pending>>,
    ready: Notify,
    dropped: AtomicU32,
}

impl Mailbox {
    fn put(&self, p: Pending) {
        let mut slot = self.pose.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(old) = slot.replace(p) {
            // Keep a pending request for a full frame even if its pose is superseded.
            if old.want_full {
                if let Some(new) = slot.as_mut() {
                    new.want_full = true;
                }
            }
            self.dropped.fetch_add(1, Ordering::Relaxed);
            metrics::counter!("homcull_ws_dropped_poses_total").increment(1);
        }
        drop(slot);
        self.ready.notify_one();
    }

    fn take(&self) -> Option<Pending> {
        self.pose.lock().unwrap_or_else(|e| e.into_inner()).take()
    }
}

async fn client(
    socket: WebSocket,
    state: AppState,
    scene: Arc<SceneEntry>,
    options: CullOptions,
    smoothing: Smoothing,
    choices: Choices,
    _slots: (WsClientSlot, Option<AddressSlot>),
) {
    let seen_first = choices.seen_first;
    let mut told = choices.placements.then(placements::Told::default);
    let (sink, incoming) = socket.split();
    let sink = Arc::new(Mutex::new(sink));
    let send_timeout = Duration::from_secs(state.config.ws_send_timeout_s);
    // The server's frame counter for this client, shared with the reader (which
    // answers writers' updates itself).
    let counter = Arc::new(AtomicU32::new(0));
    let mut seq: u32 = 0;
    let hello = Frame::Hello(Hello {
        seq,
        object_count: scene.info.objects,
        info_json: serde_json::json!({
            "protocol_version": PROTOCOL_VERSION,
            "scene": scene.info,
            "adapter": state.adapter,
            "backend": state.backend.name(),
            "cpu_fallback": matches!(state.backend, homcull_engine::engine::Backend::Reference),
            "options": options,
            "smoothing": smoothing,
            "seen_first": seen_first,
            "placements": choices.placements,
            "region": choices.region,
            "full_every": state.config.full_every,
            "max_fps": state.config.ws_max_fps,
        })
        .to_string(),
    });
    if send(&sink, hello, send_timeout).await.is_err() {
        return;
    }

    let mailbox = Arc::new(Mailbox::default());
    let (err_tx, mut err_rx) = mpsc::channel::<ErrorFrame>(8);
    let idle = Duration::from_secs(state.config.ws_idle_timeout_s.max(1));
    let liveness = Arc::new(Liveness::new());
    let writer = writer::Writer {
        writes: scene.writes.clone(),
        may_write: choices.may_write,
        max_objects: state.config.max_transform_objects,
    };
    let reader = tokio::spawn(reader::read(
        incoming,
        reader::Reader {
            mailbox: mailbox.clone(),
            liveness: liveness.clone(),
            sink: sink.clone(),
            counter: counter.clone(),
            writer,
            err_tx,
            idle,
            send_timeout,
        },
    ));

    let min_interval = Duration::from_secs_f64(1.0 / state.config.ws_max_fps.max(0.1));
    let mut last_started: Option<Instant> = None;
    let mut last_set: Vec<u32> = Vec::new();
    // With `options.lod`: the level of each ID of `last_set`, as last sent.
    let mut last_levels: Option<Vec<u8>> = None;
    let mut held = HeldSet::new(Duration::from_millis(smoothing.hold_ms.into()));
    let mut since_full = u32::MAX;
    // On a region stream: the region whose set the client holds.
    let mut held_region: Option<region::Held> = None;
    let mut shutdown = state.shutdown.clone();
    let mut reader = reader;
    let mut incoming_left = None;
    let ping_every = (send_timeout / 4).max(Duration::from_millis(100));
    let mut ping = tokio::time::interval_at(tokio::time::Instant::now() + ping_every, ping_every);
    ping.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let close = loop {
        tokio::select! {
            _ = mailbox.ready.notified() => {}
            _ = ping.tick() => {
                match liveness.on_tick(send_timeout) {
                    Tick::Wait => {}
                    Tick::Ping => {
                        let mut s = sink.lock().await;
                        let sent = tokio::time::timeout(send_timeout, s.send(Message::Ping(Default::default())));
                        if !matches!(sent.await, Ok(Ok(()))) {
                            break None;
                        }
                    }
                    Tick::Unanswered => {
                        tracing::info!("a WebSocket client stopped reading (a ping went unanswered); dropping it");
                        metrics::counter!("homcull_ws_unresponsive_total").increment(1);
                        break None;
                    }
                }
                continue;
            }
            Some(e) = err_rx.recv() => {
                seq = counter.fetch_add(1, Ordering::Relaxed).wrapping_add(1);
                if send(&sink, Frame::Error(ErrorFrame { seq, ..e }), send_timeout).await.is_err() {
                    break None;
                }
                continue;
            }
            _ = shutdown.changed() => break Some((1001, "server shutting down")),
            ended = &mut reader => {
                let Ok((end, rest)) = ended else { break None };
                // Error reports still queued go out before the close frame.
                while let Ok(e) = err_rx.try_recv() {
                    seq = counter.fetch_add(1, Ordering::Relaxed).wrapping_add(1);
                    let _ = send(&sink, Frame::Error(ErrorFrame { seq, ..e }), send_timeout).await;
                }
                incoming_left = Some(rest);
                break end.close();
            }
        }
        // Frame-rate cap: culls start at most `ws_max_fps` times a second (a cull that
        // takes longer than the interval adds no wait).
        if let Some(t) = last_started {
            tokio::time::sleep_until((t + min_interval).into()).await;
        }
        let Some(p) = mailbox.take() else { continue };
        let started = Instant::now();
        last_started = Some(started);
        // A region stream answers a pose inside the held region without a cull.
        let version = scene.placements().version();
        if let Some(h) = held_region
            .as_ref()
            .filter(|h| h.holds(&p, version, started))
        {
            seq = counter.fetch_add(1, Ordering::Relaxed).wrapping_add(1);
            let dropped = mailbox.dropped.swap(0, Ordering::Relaxed);
            let held = Sent {
                ids: &last_set,
                levels: last_levels.as_deref(),
            };
            let want_full = p.want_full || since_full >= state.config.full_every;
            let frame = h.answer((seq, p.seq), dropped, started, held, want_full);
            since_full = if matches!(frame, Frame::Full(_)) {
                0
            } else {
                since_full + 1
            };
            if send(&sink, frame, send_timeout).await.is_err() {
                break None;
            }
            continue;
        }
        // Refused, never culled as a point: the held region must match the held set.
        let last = held_region.as_ref();
        let asked = match choices
            .region
            .map(|spec| spec.camera(&p, last, liveness.rtt()))
        {
            None => None,
            Some(Ok(asked)) => Some(asked),
            Some(Err(message)) => {
                seq = counter.fetch_add(1, Ordering::Relaxed).wrapping_add(1);
                let refused = Frame::Error(ErrorFrame {
                    seq,
                    ack: p.seq,
                    code: ErrorCode::InvalidPose,
                    message,
                });
                if send(&sink, refused, send_timeout).await.is_err() {
                    break None;
                }
                continue;
            }
        };
        let mut cams = match &asked {
            Some((_, cam)) => vec![cam.clone()],
            None => p.eyes.clone(),
        };
        let eyes = cams.clone();
        let ahead = p.velocity * (smoothing.lookahead_ms as f32 * 1e-3);
        if ahead != Vec3::ZERO {
            // The pose was valid, so the moved one is too unless it left f32 range.
            if let Ok(eyes) = stereo::eyes(&moved(&p.pose, ahead)) {
                cams.extend(eyes);
            }
        }
        let prefer = seen_first.then(|| Arc::new(last_set.clone()));
        let answer = state
            .worker
            .cull_preferring(scene.engine.clone(), cams, options, prefer)
            .await
            .map(|results| smoothed(results, &mut held, &eyes, &scene));
        seq = counter.fetch_add(1, Ordering::Relaxed).wrapping_add(1);
        let frame = match answer {
            Err(e) => Frame::Error(ErrorFrame {
                seq,
                ack: p.seq,
                code: if e.code == "overloaded" {
                    ErrorCode::Overloaded
                } else {
                    ErrorCode::Internal
                },
                message: e.message,
            }),
            Ok(r) => {
                let told = told.as_mut().and_then(|t| t.message(&r));
                if let Some(text) = told
                    && send_text(&sink, "placements", text, send_timeout)
                        .await
                        .is_err()
                {
                    break None;
                }
                let stats = frame_stats(&r, mailbox.dropped.swap(0, Ordering::Relaxed), started);
                if let Some((asked, _)) = &asked {
                    // The region goes out before its set.
                    seq = counter.fetch_add(1, Ordering::Relaxed).wrapping_add(1);
                    let hold = scene
                        .placements()
                        .answers_hold_s()
                        .map(Duration::from_secs_f32);
                    let version = r.stats.scene_version;
                    let eye = (asked, &p.eyes[0]);
                    let mut h = region::Held::new((seq, p.seq), eye, started, version, hold);
                    h.stats = stats;
                    if send(&sink, Frame::Region(h.frame), send_timeout)
                        .await
                        .is_err()
                    {
                        break None;
                    }
                    held_region = Some(h);
                    seq = counter.fetch_add(1, Ordering::Relaxed).wrapping_add(1);
                }
                let want_full = p.want_full || since_full >= state.config.full_every;
                let levels = options.lod.map(|t| {
                    let placed = scene.placements();
                    lod::levels(&p.eyes, &r.visible, |id| placed.bounds(id), &t)
                });
                let last = Sent {
                    ids: &last_set,
                    levels: last_levels.as_deref(),
                };
                let now = Sent {
                    ids: &r.visible,
                    levels: levels.as_deref(),
                };
                let frame = visibility_frame(seq, p.seq, stats, last, now, want_full);
                last_levels = levels;
                if matches!(frame, Frame::Full(_)) {
                    since_full = 0;
                } else {
                    since_full += 1;
                }
                last_set = r.visible;
                frame
            }
        };
        if send(&sink, frame, send_timeout).await.is_err() {
            break None;
        }
    };
    reader.abort();
    if let Some((code, reason)) = close {
        let frame = CloseFrame {
            code,
            reason: Utf8Bytes::from_static(reason),
        };
        let mut s = sink.lock().await;
        let _ = tokio::time::timeout(send_timeout, s.send(Message::Close(Some(frame)))).await;
        // Read on until the client's close (or a second): closing with its messages
        // still unread would reset the connection and lose the frames sent above.
        if let Some(mut rest) = incoming_left {
            let deadline = tokio::time::Instant::now() + Duration::from_secs(1);
            while let Ok(Some(Ok(m))) = tokio::time::timeout_at(deadline, rest.next()).await {
                if matches!(m, Message::Close(_)) {
                    break;
                }
            }
        }
    }
}
