//! A bounded load generator for a running homcull server, on loopback only.
//!
//! Modes (all closed-loop: each client waits for its answer before the next request):
//! - `ws`: N WebSocket clients each walk poses and wait for the frame that answers
//!   each; reports poses/s, round-trip percentiles, and round trip minus the
//!   server's in-process time (`total_us` of each frame).
//! - `single`: N clients POST one pose per `/cull` request.
//! - `batch`: N clients POST `--batch` poses per `/cull/batch` request.
//!
//! A side task polls `/healthz` every 50 ms to show how the server answers probes
//! under load. With `--transforms-per-s N`, a writer moves objects meanwhile
//! (`POST /v1/scenes/{id}/transforms` every 10 ms, N/100 objects each, round robin
//! over an eighth of the scene's objects, every 8th ID, the traffic; each with a
//! velocity), and one more WebSocket client, streaming with `placements=true`, measures
//! update to visible: from sending an update to the first message of its stream naming
//! that version or a later one. The run stops by itself after `--seconds`.

use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use futures_util::{SinkExt, StreamExt};
use homcull_proto::Pose;
use homcull_proto::frame::{Frame, PoseFrame};
use serde::Serialize;
use tokio_tungstenite::tungstenite::Message;

use crate::percentiles::Percentiles;

/// What load to put on which server.
#[derive(Debug, Clone)]
pub struct LoadConfig {
    /// Base URL of the server (`http://` on a loopback address only).
    pub url: String,
    /// Scene id.
    pub scene: String,
    /// Concurrent clients, 1..=2000.
    pub clients: usize,
    /// Seconds to run, in (0, 600].
    pub seconds: f64,
    /// `ws`, `single` or `batch`.
    pub mode: String,
    /// Poses per REST batch in `batch` mode.
    pub batch: usize,
    /// Object transforms to send per second while the load runs (0: none).
    pub transforms_per_s: f64,
}

/// What a load run measured.
#[derive(Debug, Clone, Serialize)]
pub struct LoadReport {
    pub mode: String,
    pub clients: usize,
    pub seconds: f64,
    pub poses: u64,
    pub poses_per_s: f64,
    pub errors: u64,
    /// Request (or pose) round trip, milliseconds.
    pub rtt_ms: Percentiles,
    /// WebSocket only: round trip minus the server's in-process time per pose.
    pub rtt_minus_server_ms: Option<Percentiles>,
    /// `/healthz` latency while the load ran.
    pub healthz_ms: Percentiles,
    /// WebSocket only: bytes of full and delta frames received.
    pub full_bytes: u64,
    pub delta_bytes: u64,
    pub full_frames: u64,
    pub delta_frames: u64,
    /// Fewest poses any one client got answered (0 = a client starved).
    pub min_client_poses: u64,
    /// Object transforms the server accepted, per second, and requests it refused.
    pub transforms_per_s: f64,
    pub transform_errors: u64,
    /// The scene version the last transforms request made.
    pub last_version: u64,
    /// With a writer: from sending an update to the probe stream's first message
    /// naming its version or a later one, milliseconds.
    pub update_to_visible_ms: Option<Percentiles>,
}

impl LoadReport {
    /// One line for a terminal.
    pub fn summary(&self) -> String {
        format!(
            "{} x{} for {:.1} s: {} poses, {:.0} poses/s, {} errors; rtt ms p50 {:.3} p95 {:.3} p99 {:.3}{}; healthz p99 {:.2} ms",
            self.mode,
            self.clients,
            self.seconds,
            self.poses,
            self.poses_per_s,
            self.errors,
            self.rtt_ms.p50,
            self.rtt_ms.p95,
            self.rtt_ms.p99,
            self.rtt_minus_server_ms
                .map(|p| format!("; rtt minus server p50 {:.3}", p.p50))
                .unwrap_or_default(),
            self.healthz_ms.p99
        ) + &if self.last_version > 0 {
            format!(
                "; {:.0} object transforms/s applied ({} refused), scene version {}, update to visible p50 {:.1} ms",
                self.transforms_per_s,
                self.transform_errors,
                self.last_version,
                self.update_to_visible_ms.map_or(f64::NAN, |p| p.p50)
            )
        } else {
            String::new()
        }
    }
}

/// `host:port` of a loopback `http://` URL; anything else is refused.
pub fn loopback(url: &str) -> Result<String> {
    let rest = url
        .strip_prefix("http://")
        .context("the load generator takes an http:// URL")?;
    let host = rest.split('/').next().unwrap_or("");
    let addr: std::net::SocketAddr = host
        .replace("localhost", "127.0.0.1")
        .parse()
        .with_context(|| format!("`{host}` is not HOST:PORT"))?;
    if !addr.ip().is_loopback() {
        bail!("the load generator only targets loopback addresses, not {addr}");
    }
    Ok(addr.to_string())
}

/// Street-level poses along the x axis (through the demo city's open street).
pub fn walk(n: usize, viewport: [u32; 2], bounds: [[f32; 3]; 2]) -> Vec<Pose> {
    let [lo, hi] = bounds;
    let on_axis = |a: usize| {
        if lo[a] <= 0.0 && hi[a] >= 0.0 {
            0.0
        } else {
            (lo[a] + hi[a]) / 2.0
        }
    };
    let (cx, z) = (on_axis(0), on_axis(2));
    let half = (0.35 * (hi[0] - lo[0])).min(150.0);
    let (x0, x1) = (cx - half, cx + half);
    (0..n)
        .map(|i| {
            let x = x0 + (x1 - x0) * i as f32 / n as f32;
            street_pose([x, lo[1] + 1.7, z], i as f32, viewport)
        })
        .collect()
}

/// A walker's pose at `eye` looking along the street (yaw −90° about +Y, the direction
/// of the walk) with a slow sway of `0.6 · sin(0.05 · phase)` radians; the walks of the
/// load generator and of the tests all use it, with the pose index or the metres walked
/// as the phase.
pub fn street_pose(eye: [f32; 3], phase: f32, viewport: [u32; 2]) -> Pose {
    let yaw = -std::f32::consts::FRAC_PI_2 + 0.6 * (phase * 0.05).sin();
    let (s, c) = (yaw / 2.0).sin_cos();
    Pose {
        rotation: Some([0.0, s, 0.0, c]),
        look_at: None,
        viewport,
        ..Pose::looking_at(eye, [0.0; 3])
    }
}

#[derive(Default)]
struct ClientStats {
    poses: u64,
    errors: u64,
    rtt: Vec<f64>,
    minus_server: Vec<f64>,
    full_bytes: u64,
    delta_bytes: u64,
    full_frames: u64,
    delta_frames: u64,
}

/// A keep-alive HTTP client for one load client (no proxy: loopback only).
pub fn http_client() -> Result<reqwest::Client> {
    Ok(reqwest::Client::builder()
        .no_proxy()
        .tcp_nodelay(true)
        .build()?)
}

/// Runs the load described by `a` and returns what it measured.
pub async fn run(a: &LoadConfig) -> Result<LoadReport> {
    let host = loopback(&a.url)?;
    if a.clients == 0 || a.clients > 2000 {
        bail!("--clients must be 1..=2000");
    }
    if !(a.seconds > 0.0 && a.seconds <= 600.0) {
        bail!("--seconds must be in (0, 600]");
    }
    if !matches!(a.mode.as_str(), "ws" | "single" | "batch") {
        bail!("--mode must be ws, single, batch, walk or walkers");
    }
    if !(a.transforms_per_s >= 0.0 && a.transforms_per_s <= 10_000_000.0) {
        bail!("--transforms-per-s must be in [0, 10000000]");
    }
    let http = http_client()?;
    let res = http
        .get(format!("http://{host}/v1/scenes/{}", a.scene))
        .send()
        .await?;
    let status = res.status();
    let body = res.bytes().await?;
    if status != 200 {
        bail!(
            "scene {}: HTTP {status}: {}",
            a.scene,
            String::from_utf8_lossy(&body)
        );
    }
    let info: homcull_proto::SceneInfo = serde_json::from_slice(&body)?;
    let poses = std::sync::Arc::new(walk(600, [960, 540], info.bounds));
    let deadline = Instant::now() + Duration::from_secs_f64(a.seconds);
    let start = Instant::now();

    let health_url = format!("http://{host}/healthz");
    let health = tokio::spawn(async move {
        let mut lat = Vec::new();
        // A fresh connection per probe, as a kubelet's would be.
        let Ok(probe) = reqwest::Client::builder()
            .no_proxy()
            .pool_max_idle_per_host(0)
            .build()
        else {
            return lat;
        };
        while Instant::now() < deadline {
            let t = Instant::now();
            if let Ok(r) = probe.get(&health_url).send().await {
                if r.status() == 200 {
                    lat.push(t.elapsed().as_secs_f64() * 1e3);
                }
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        lat
    });

    let writer = (a.transforms_per_s > 0.0).then(|| {
        let (host, scene) = (host.clone(), a.scene.clone());
        let per_request = (a.transforms_per_s / 100.0).ceil() as usize;
        tokio::spawn(writer(host, scene, info.objects, per_request, deadline))
    });
    let probe = (a.transforms_per_s > 0.0).then(|| {
        let (host, scene, poses) = (host.clone(), a.scene.clone(), poses.clone());
        tokio::spawn(async move { placements_probe(&host, &scene, &poses, deadline).await })
    });
    let mut tasks = Vec::new();
    for k in 0..a.clients {
        let poses = poses.clone();
        let host = host.clone();
        let scene = a.scene.clone();
        let mode = a.mode.clone();
        let batch = a.batch.max(1);
        tasks.push(tokio::spawn(async move {
            let offset = k * 37;
            match mode.as_str() {
                "ws" => ws_client(&host, &scene, &poses, offset, deadline).await,
                "single" => rest_client(&host, &scene, &poses, offset, 1, deadline).await,
                _ => rest_client(&host, &scene, &poses, offset, batch, deadline).await,
            }
        }));
    }
    let mut all = ClientStats::default();
    let mut min_client_poses = u64::MAX;
    for t in tasks {
        let s = t.await?.unwrap_or_else(|e| {
            tracing::warn!("a load client failed: {e:#}");
            ClientStats {
                errors: 1,
                ..Default::default()
            }
        });
        min_client_poses = min_client_poses.min(s.poses);
        all.poses += s.poses;
        all.full_frames += s.full_frames;
        all.delta_frames += s.delta_frames;
        all.errors += s.errors;
        all.rtt.extend(s.rtt);
        all.minus_server.extend(s.minus_server);
        all.full_bytes += s.full_bytes;
        all.delta_bytes += s.delta_bytes;
    }
    let secs = start.elapsed().as_secs_f64();
    let healthz = health.await.unwrap_or_default();
    let written = match writer {
        Some(w) => w.await??,
        None => Written::default(),
    };
    let update_to_visible = match probe {
        Some(p) => Some(Percentiles::of(update_to_visible(
            &written.sent,
            &p.await??,
        ))),
        None => None,
    };
    Ok(LoadReport {
        mode: a.mode.clone(),
        clients: a.clients,
        seconds: secs,
        poses: all.poses,
        poses_per_s: all.poses as f64 / secs,
        errors: all.errors,
        rtt_ms: Percentiles::of(all.rtt),
        rtt_minus_server_ms: (a.mode == "ws").then(|| Percentiles::of(all.minus_server)),
        healthz_ms: Percentiles::of(healthz),
        full_bytes: all.full_bytes,
        delta_bytes: all.delta_bytes,
        full_frames: all.full_frames,
        delta_frames: all.delta_frames,
        min_client_poses,
        transforms_per_s: written.objects as f64 / secs,
        transform_errors: written.errors,
        last_version: written.version,
        update_to_visible_ms: update_to_visible,
    })
}

/// Per accepted update (its version and when it was sent), the time until the first
/// message of the probe stream (version, when it arrived) naming that version or a
/// later one; updates the stream never reached are left out.
fn update_to_visible(sent: &[(u64, Instant)], seen: &[(u64, Instant)]) -> Vec<f64> {
    sent.iter()
        .filter_map(|&(v, at)| {
            // Versions only grow along one stream.
            let k = seen.partition_point(|&(s, _)| s < v);
            let &(_, arrived) = seen.get(k)?;
            Some(arrived.saturating_duration_since(at).as_secs_f64() * 1e3)
        })
        .collect()
}

/// A WebSocket client streaming with `placements=true`: the scene versions its
/// messages name, with when each arrived.
async fn placements_probe(
    host: &str,
    scene: &str,
    poses: &[Pose],
    deadline: Instant,
) -> Result<Vec<(u64, Instant)>> {
    let (mut ws, _) = tokio_tungstenite::connect_async_with_config(
        format!("ws://{host}/v1/scenes/{scene}/stream?placements=true"),
        None,
        true,
    )
    .await?;
    ws.next().await.context("no hello")??;
    let mut seen = Vec::new();
    let mut seq = 0u32;
    while Instant::now() < deadline {
        seq += 1;
        let pose = &poses[seq as usize % poses.len()];
        let frame = PoseFrame::from_pose(seq, false, pose).context("walk poses use quaternions")?;
        ws.send(Message::Binary(Frame::Pose(frame).encode().into()))
            .await?;
        loop {
            match ws.next().await.context("stream ended")?? {
                Message::Text(t) => {
                    let v: serde_json::Value = serde_json::from_str(&t)?;
                    if let Some(version) = v["placements"]["version"].as_u64() {
                        seen.push((version, Instant::now()));
                    }
                }
                Message::Binary(b) if Frame::decode(&b)?.ack() == seq => break,
                Message::Binary(_)
                | Message::Ping(_)
                | Message::Pong(_)
                | Message::Close(_)
                | Message::Frame(_) => {}
            }
        }
    }
    ws.close(None).await.ok();
    Ok(seen)
}

#[derive(Default)]
struct Written {
    objects: u64,
    errors: u64,
    version: u64,
    /// Each accepted update's version and when it was sent.
    sent: Vec<(u64, Instant)>,
}

/// Every 10 ms until `deadline`, one transforms request moving `per_request` objects
/// (round robin over every 8th of the scene's `objects`, each a little off its loaded
/// place and given a velocity of 1 m/s).
async fn writer(
    host: String,
    scene: String,
    objects: u32,
    per_request: usize,
    deadline: Instant,
) -> Result<Written> {
    let http = http_client()?;
    let url = format!("http://{host}/v1/scenes/{scene}/transforms");
    let mut w = Written::default();
    let movers = objects.div_ceil(8);
    let mut next = 0u32;
    let mut tick = tokio::time::interval(Duration::from_millis(10));
    let mut step = 0u64;
    while Instant::now() < deadline {
        tick.tick().await;
        step += 1;
        let offset = (step % 20) as f32 * 0.05;
        let moved: Vec<serde_json::Value> = (0..per_request.min(movers as usize))
            .map(|_| {
                let id = next * 8;
                next = (next + 1) % movers.max(1);
                serde_json::json!({"id": id, "translation": [offset, 0.0, 0.0], "velocity": [1.0, 0.0, 0.0]})
            })
            .collect();
        let n = moved.len() as u64;
        let sent_at = Instant::now();
        let res = http
            .post(&url)
            .json(&serde_json::json!({ "objects": moved }))
            .send()
            .await?;
        if res.status() == 200 {
            let r: homcull_proto::TransformsResponse = res.json().await?;
            w.objects += n;
            w.version = r.version;
            w.sent.push((r.version, sent_at));
        } else {
            w.errors += 1;
        }
    }
    Ok(w)
}

async fn ws_client(
    host: &str,
    scene: &str,
    poses: &[Pose],
    offset: usize,
    deadline: Instant,
) -> Result<ClientStats> {
    let (mut ws, _) = tokio_tungstenite::connect_async_with_config(
        format!("ws://{host}/v1/scenes/{scene}/stream"),
        None,
        true, // no Nagle delay
    )
    .await?;
    let mut s = ClientStats::default();
    let mut seq = 0u32;
    // Hello first.
    ws.next().await.context("no hello")??;
    while Instant::now() < deadline {
        seq += 1;
        let pose = &poses[(offset + seq as usize) % poses.len()];
        let frame = PoseFrame::from_pose(seq, false, pose).context("walk poses use quaternions")?;
        let t = Instant::now();
        ws.send(Message::Binary(Frame::Pose(frame).encode().into()))
            .await?;
        loop {
            let msg = ws.next().await.context("stream ended")??;
            let Message::Binary(b) = msg else { continue };
            let rtt = t.elapsed().as_secs_f64() * 1e3;
            let f = Frame::decode(&b)?;
            let (ack, server_us) = match &f {
                Frame::Full(v) => {
                    s.full_bytes += b.len() as u64;
                    s.full_frames += 1;
                    (v.ack, v.stats.total_us)
                }
                Frame::Delta(d) => {
                    s.delta_bytes += b.len() as u64;
                    s.delta_frames += 1;
                    (d.ack, d.stats.total_us)
                }
                Frame::Error(e) => {
                    s.errors += 1;
                    (e.ack, 0)
                }
                Frame::Hello(_)
                | Frame::Pose(_)
                | Frame::Transforms(_)
                | Frame::Applied(_)
                | Frame::Region(_) => {
                    continue;
                }
            };
            if ack == seq {
                s.poses += 1;
                s.rtt.push(rtt);
                s.minus_server.push(rtt - server_us as f64 / 1e3);
                break;
            }
        }
    }
    ws.close(None).await.ok();
    Ok(s)
}

async fn rest_client(
    host: &str,
    scene: &str,
    poses: &[Pose],
    offset: usize,
    batch: usize,
    deadline: Instant,
) -> Result<ClientStats> {
    let http = http_client()?;
    let mut s = ClientStats::default();
    let mut i = offset;
    while Instant::now() < deadline {
        let chunk: Vec<&Pose> = (0..batch).map(|k| &poses[(i + k) % poses.len()]).collect();
        i += batch;
        let (path, body) = if batch == 1 {
            (
                format!("/v1/scenes/{scene}/cull"),
                serde_json::to_vec(&serde_json::json!({ "pose": chunk[0] }))?,
            )
        } else {
            (
                format!("/v1/scenes/{scene}/cull/batch"),
                serde_json::to_vec(&serde_json::json!({ "poses": chunk }))?,
            )
        };
        let t = Instant::now();
        let res = http
            .post(format!("http://{host}{path}"))
            .header(reqwest::header::CONTENT_TYPE, "application/json")
            .body(body)
            .send()
            .await?;
        let status = res.status();
        res.bytes().await?; // the whole answer is part of the round trip
        if status == 200 {
            s.poses += batch as u64;
            s.rtt.push(t.elapsed().as_secs_f64() * 1e3);
        } else {
            s.errors += 1;
        }
    }
    Ok(s)
}
