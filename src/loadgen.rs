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
//! under load. The run stops by itself after `--seconds`.

use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use futures_util::{SinkExt, StreamExt};
use homcull_proto::Pose;
use homcull_proto::frame::{Frame, PoseFrame};
use serde::Serialize;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio_tungstenite::tungstenite::Message;

use crate::config::LoadgenArgs;

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
}

#[derive(Debug, Clone, Copy, Default, Serialize)]
pub struct Percentiles {
    pub p50: f64,
    pub p95: f64,
    pub p99: f64,
    pub max: f64,
}

impl Percentiles {
    pub fn of(mut v: Vec<f64>) -> Self {
        if v.is_empty() {
            return Self::default();
        }
        v.sort_by(f64::total_cmp);
        let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
        Percentiles {
            p50: at(0.5),
            p95: at(0.95),
            p99: at(0.99),
            max: v[v.len() - 1],
        }
    }
}

pub fn main(a: LoadgenArgs) -> Result<()> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()?;
    let report = rt.block_on(run(&a))?;
    if a.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!(
            "{} x{} for {:.1} s: {} poses, {:.0} poses/s, {} errors; rtt ms p50 {:.3} p95 {:.3} p99 {:.3}{}; healthz p99 {:.2} ms",
            report.mode,
            report.clients,
            report.seconds,
            report.poses,
            report.poses_per_s,
            report.errors,
            report.rtt_ms.p50,
            report.rtt_ms.p95,
            report.rtt_ms.p99,
            report
                .rtt_minus_server_ms
                .map(|p| format!("; rtt minus server p50 {:.3}", p.p50))
                .unwrap_or_default(),
            report.healthz_ms.p99
        );
    }
    Ok(())
}

/// `host:port` of a loopback `http://` URL; anything else is refused.
fn loopback(url: &str) -> Result<String> {
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

/// Minimal HTTP/1.1 over one keep-alive connection (no client library in the binary).
struct Http {
    stream: TcpStream,
    host: String,
}

impl Http {
    async fn connect(host: &str) -> Result<Http> {
        let stream = TcpStream::connect(host).await?;
        stream.set_nodelay(true)?;
        Ok(Http {
            stream,
            host: host.to_string(),
        })
    }

    /// Sends a request and returns (status, body).
    async fn request(&mut self, method: &str, path: &str, body: &[u8]) -> Result<(u16, Vec<u8>)> {
        let head = format!(
            "{method} {path} HTTP/1.1\r\nHost: {}\r\nContent-Type: application/json\r\nContent-Length: {}\r\n\r\n",
            self.host,
            body.len()
        );
        self.stream.write_all(head.as_bytes()).await?;
        self.stream.write_all(body).await?;
        let mut buf = Vec::with_capacity(4096);
        let header_end = loop {
            let mut chunk = [0u8; 4096];
            let n = self.stream.read(&mut chunk).await?;
            if n == 0 {
                bail!("connection closed");
            }
            buf.extend_from_slice(&chunk[..n]);
            if let Some(i) = buf.windows(4).position(|w| w == b"\r\n\r\n") {
                break i + 4;
            }
        };
        let head = String::from_utf8_lossy(&buf[..header_end]).to_string();
        let status: u16 = head
            .split_whitespace()
            .nth(1)
            .and_then(|s| s.parse().ok())
            .unwrap_or(0);
        let len: usize = head
            .lines()
            .find_map(|l| {
                let (k, v) = l.split_once(':')?;
                k.eq_ignore_ascii_case("content-length")
                    .then(|| v.trim().parse().ok())?
            })
            .context("response without Content-Length")?;
        let mut body = buf[header_end..].to_vec();
        while body.len() < len {
            let mut chunk = vec![0u8; len - body.len()];
            let n = self.stream.read(&mut chunk).await?;
            if n == 0 {
                bail!("connection closed mid-body");
            }
            body.extend_from_slice(&chunk[..n]);
        }
        Ok((status, body))
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

/// Runs the load described by `a` and returns what it measured.
pub async fn run(a: &LoadgenArgs) -> Result<LoadReport> {
    let host = loopback(&a.url)?;
    if a.clients == 0 || a.clients > 2000 {
        bail!("--clients must be 1..=2000");
    }
    if !(a.seconds > 0.0 && a.seconds <= 600.0) {
        bail!("--seconds must be in (0, 600]");
    }
    let mut http = Http::connect(&host).await?;
    let (status, body) = http
        .request("GET", &format!("/v1/scenes/{}", a.scene), b"")
        .await?;
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

    let health_host = host.clone();
    let health = tokio::spawn(async move {
        let mut lat = Vec::new();
        while Instant::now() < deadline {
            let t = Instant::now();
            if let Ok(mut h) = Http::connect(&health_host).await {
                if let Ok((200, _)) = h.request("GET", "/healthz", b"").await {
                    lat.push(t.elapsed().as_secs_f64() * 1e3);
                }
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        lat
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
    if !matches!(a.mode.as_str(), "ws" | "single" | "batch") {
        bail!("--mode must be ws, single or batch");
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
    })
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
                _ => continue,
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
    let mut http = Http::connect(host).await?;
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
        let (status, _) = http.request("POST", &path, &body).await?;
        if status == 200 {
            s.poses += batch as u64;
            s.rtt.push(t.elapsed().as_secs_f64() * 1e3);
        } else {
            s.errors += 1;
        }
    }
    Ok(s)
}
