//! Many walkers at once (`homcull loadgen --mode walkers`): open-loop streaming load.
//!
//! Each of N WebSocket clients walks the demo city's street at 1.4 m/s, its view
//! swinging up to 30°/s ([`crate::latency::walk_pose`]), and sends a pose every
//! 1/60 s on its own clock, whatever the server answers, as a viewer drawing at
//! 60 frames/s does. The closed-loop `ws` mode measures how fast the server answers
//! one pose after another; this one measures how many viewers it keeps up with: a
//! stream whose server falls behind answers only the newest pose (latest pose wins,
//! the rest are dropped), so the answered share of the poses sent and the age of the
//! answers show the overload. Clients start at different points of the street (a
//! few seconds of walk apart) and their clocks are staggered over one frame, so that
//! their culls do not fall together.
//!
//! A *cull* is a region frame on a region stream (`--stream-query
//! '?region_m=0.5&turn_deg=15'`) and every answered pose on a point stream. A point
//! stream counts as *served at 60 Hz* when the server answered at least
//! [`SERVED_SHARE`] of the poses sent and 99 % of its answers within
//! [`SERVED_P99_MS`]. A region stream's client draws the set it holds, valid
//! wherever the region announced with it holds the pose, whether or not the poses
//! inside are acknowledged in time; it counts as served when at least
//! [`SERVED_SHARE`] of the frames are drawn inside the held set's region (after the
//! first set arrived), none of the clients failing.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use futures_util::{SinkExt, StreamExt};
use homcull_proto::frame::{Frame, PoseFrame, RegionFrame};
use serde::Serialize;
use tokio::time::MissedTickBehavior;
use tokio_tungstenite::tungstenite::Message;

use crate::latency::{forward, walk_pose};
use crate::percentiles::Percentiles;

/// Poses each client sends per second.
const FPS: f64 = 60.0;
/// Least share of the poses sent that the server must answer to serve the clients.
pub const SERVED_SHARE: f64 = 0.95;
/// Most milliseconds within which 99 % of the answers must arrive.
pub const SERVED_P99_MS: f64 = 100.0;
/// Seconds of walk between one client's start and the next one's (wrapping after
/// [`START_SPAN_S`]: the demo street is about 200 m long).
const START_STEP_S: f32 = 3.7;
const START_SPAN_S: f32 = 100.0;
/// How long the clients wait for the last answers after they stop sending.
const DRAIN: Duration = Duration::from_millis(500);

/// What load of walkers to put on which server.
#[derive(Debug, Clone)]
pub struct WalkersConfig {
    /// `host:port` on loopback.
    pub host: String,
    pub scene: String,
    /// Concurrent walkers, 1..=2000.
    pub clients: usize,
    /// Seconds each walks, in (0, 600].
    pub seconds: f64,
    /// The stream's query string (`?region_m=0.5&turn_deg=15`; empty: point streams).
    pub query: String,
    pub viewport: [u32; 2],
}

/// What a run of walkers measured.
#[derive(Debug, Clone, Serialize)]
pub struct WalkersReport {
    pub query: String,
    pub clients: usize,
    pub seconds: f64,
    /// Poses sent, and the share of them the server answered.
    pub poses_sent: u64,
    pub answered_share: f64,
    /// The least answered share of any one client.
    pub worst_client_share: f64,
    /// Culls per client and second (see the module docs).
    pub culls_per_client_s: f64,
    /// From sending a pose to its answer's arrival, milliseconds.
    pub answer_ms: Percentiles,
    /// Region streams: the share of the frames drawn (poses sent after the first set
    /// arrived) that the region of the set held then holds; 1 on point streams.
    pub inside_share: f64,
    /// Error frames received and clients that failed (connection refused or lost).
    pub errors: u64,
    pub failed_clients: usize,
    /// Whether the run served every client at 60 Hz (see the module docs).
    pub served: bool,
}

impl WalkersReport {
    /// One line for a terminal.
    pub fn summary(&self) -> String {
        format!(
            "walkers x{} {} for {:.1} s: {:.1} % of {} poses answered (worst client {:.1} %), {:.2} culls per client-second, answer ms p50 {:.2} p99 {:.2}, {:.1} % of frames inside their region, {} errors, {} clients failed: {}",
            self.clients,
            if self.query.is_empty() {
                "point"
            } else {
                &self.query
            },
            self.seconds,
            100.0 * self.answered_share,
            self.poses_sent,
            100.0 * self.worst_client_share,
            self.culls_per_client_s,
            self.answer_ms.p50,
            self.answer_ms.p99,
            100.0 * self.inside_share,
            self.errors,
            self.failed_clients,
            if self.served {
                "served at 60 Hz"
            } else {
                "NOT served at 60 Hz"
            }
        )
    }
}

#[derive(Default)]
struct Walked {
    sent: u64,
    answered: u64,
    /// Region frames received.
    regions: u64,
    /// Frames drawn with a set held, and those of them inside its region.
    drawn: u64,
    inside: u64,
    errors: u64,
    answer_ms: Vec<f64>,
}

/// Runs the walkers and returns what they measured.
pub async fn run(cfg: &WalkersConfig) -> Result<WalkersReport> {
    crate::loadgen::loopback(&format!("http://{}", cfg.host))?;
    if cfg.clients == 0 || cfg.clients > 2000 {
        bail!("--clients must be 1..=2000");
    }
    if !(cfg.seconds > 0.0 && cfg.seconds <= 600.0) {
        bail!("--seconds must be in (0, 600]");
    }
    // Everyone connects first, so that the walk measures serving, not the handshakes.
    let mut sockets = Vec::with_capacity(cfg.clients);
    for _ in 0..cfg.clients {
        let url = format!(
            "ws://{}/v1/scenes/{}/stream{}",
            cfg.host, cfg.scene, cfg.query
        );
        let (mut ws, _) = tokio_tungstenite::connect_async_with_config(url, None, true)
            .await
            .context("connecting a walker")?;
        ws.next().await.context("no hello")??;
        sockets.push(ws);
    }
    let start = tokio::time::Instant::now() + Duration::from_millis(100);
    let n = cfg.clients;
    let tasks: Vec<_> = sockets
        .into_iter()
        .enumerate()
        .map(|(k, ws)| {
            let stagger = Duration::from_secs_f64(k as f64 / n as f64 / FPS);
            let walk_from = (k as f32 * START_STEP_S) % START_SPAN_S;
            let (seconds, viewport) = (cfg.seconds, cfg.viewport);
            tokio::spawn(walker(ws, start + stagger, walk_from, seconds, viewport))
        })
        .collect();
    let mut all = Walked::default();
    let mut worst = 1.0f64;
    let mut failed = 0;
    for t in tasks {
        match t.await? {
            Ok(w) => {
                worst = worst.min(w.answered as f64 / w.sent.max(1) as f64);
                all.sent += w.sent;
                all.answered += w.answered;
                all.regions += w.regions;
                all.drawn += w.drawn;
                all.inside += w.inside;
                all.errors += w.errors;
                all.answer_ms.extend(w.answer_ms);
            }
            Err(e) => {
                tracing::warn!("a walker failed: {e:#}");
                failed += 1;
                worst = 0.0;
            }
        }
    }
    let share = all.answered as f64 / all.sent.max(1) as f64;
    let region = cfg.query.contains("region_m");
    let culls = if region { all.regions } else { all.answered };
    let inside_share = if region {
        all.inside as f64 / all.drawn.max(1) as f64
    } else {
        1.0
    };
    let answer_ms = Percentiles::of(all.answer_ms);
    Ok(WalkersReport {
        query: cfg.query.clone(),
        clients: n,
        seconds: cfg.seconds,
        poses_sent: all.sent,
        answered_share: share,
        worst_client_share: worst,
        culls_per_client_s: culls as f64 / (n as f64 * cfg.seconds),
        answer_ms,
        inside_share,
        errors: all.errors,
        failed_clients: failed,
        served: failed == 0
            && if region {
                inside_share >= SERVED_SHARE
            } else {
                share >= SERVED_SHARE && answer_ms.p99 <= SERVED_P99_MS
            },
    })
}

type Socket =
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

/// One walker: sends a pose every frame from `start` for `seconds`, starting
/// `walk_from` seconds into the walk, while its reader takes the answers.
async fn walker(
    ws: Socket,
    start: tokio::time::Instant,
    walk_from: f32,
    seconds: f64,
    viewport: [u32; 2],
) -> Result<Walked> {
    let (mut tx, mut rx) = ws.split();
    let frames = (seconds * FPS).ceil() as usize;
    // When each pose went out (by sequence number, from 1), and what came back.
    let sent_at = Arc::new(Mutex::new(vec![None::<Instant>; frames + 1]));
    let got = Arc::new(Mutex::new(Walked::default()));
    // Whether a set has arrived, and the region the set held holds for.
    let held = Arc::new(Mutex::new((false, None::<RegionFrame>)));
    let reader = {
        let (sent_at, got, held) = (sent_at.clone(), got.clone(), held.clone());
        tokio::spawn(async move {
            let mut pending = None;
            while let Some(Ok(m)) = rx.next().await {
                let Message::Binary(b) = m else { continue };
                let mut w = got.lock().unwrap();
                let ack = match Frame::decode(&b) {
                    Ok(Frame::Full(f)) => f.ack,
                    Ok(Frame::Delta(d)) => d.ack,
                    Ok(Frame::Region(r)) => {
                        w.regions += 1;
                        pending = Some(r);
                        continue;
                    }
                    Ok(Frame::Error(_)) | Err(_) => {
                        w.errors += 1;
                        continue;
                    }
                    Ok(_) => continue,
                };
                // A region frame holds for the set that follows it.
                let mut h = held.lock().unwrap();
                h.0 = true;
                if let Some(r) = pending.take() {
                    h.1 = Some(r);
                }
                drop(h);
                let at = sent_at.lock().unwrap().get(ack as usize).copied().flatten();
                if let Some(at) = at {
                    w.answered += 1;
                    w.answer_ms.push(at.elapsed().as_secs_f64() * 1e3);
                }
            }
        })
    };
    let mut tick = tokio::time::interval_at(start, Duration::from_secs_f64(1.0 / FPS));
    // Open loop: a late tick is skipped, never made up in a burst.
    tick.set_missed_tick_behavior(MissedTickBehavior::Skip);
    let mut sent = 0u64;
    for k in 0..frames {
        let t = tick.tick().await;
        if t >= start + Duration::from_secs_f64(seconds) {
            break;
        }
        let pose = walk_pose(walk_from + k as f32 / FPS as f32, viewport);
        // The frame drawn now: with the set held, inside its region or not.
        let (any, region) = *held.lock().unwrap();
        if any {
            let mut w = got.lock().unwrap();
            w.drawn += 1;
            w.inside += u64::from(region.is_none_or(|r| r.holds(pose.position, forward(&pose))));
        }
        let seq = k as u32 + 1;
        let frame = PoseFrame::from_pose(seq, false, &pose).context("a quaternion pose")?;
        sent_at.lock().unwrap()[seq as usize] = Some(Instant::now());
        tx.send(Message::Binary(Frame::Pose(frame).encode().into()))
            .await?;
        sent += 1;
    }
    tokio::time::sleep(DRAIN).await;
    let _ = tx.close().await;
    reader.abort();
    let mut w = std::mem::take(&mut *got.lock().unwrap());
    w.sent = sent;
    Ok(w)
}
