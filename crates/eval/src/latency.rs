//! A delayed walk (`homcull loadgen --mode walk`): one client walks the demo city's
//! street (or another scene from its walk start, [`WalkPath`]) at 1.4 m/s, its view
//! swinging up to 30°/s, drawing at 60 frames/s whatever the server answers, its
//! messages delayed each way (the client delays its own sends and receipts: loopback
//! only). Afterwards every drawn frame is checked against the exact oracle at its pose:
//! a *late reveal* is an object the oracle sees there that the set the client held at
//! that moment lacks. On a region stream (`region`) the frames drawn outside the region
//! their set was announced for are counted too, and the culls are the region frames; on
//! a point stream every answered pose is a cull.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use futures_util::{SinkExt, StreamExt};
use glam::{Quat, Vec3};
use homcull_proto::frame::{Frame, PoseFrame, RegionFrame, apply_delta};
use homcull_proto::{BatchResponse, Pose, SceneInfo};
use tokio_tungstenite::tungstenite::Message;

/// Walking speed, m/s.
const SPEED: f32 = 1.4;
/// Amplitude (radians) and angular frequency (rad/s) of the view's swing: at most
/// 30°/s.
const SWING: f32 = 0.35;
const SWING_RATE: f32 = 30.0 * std::f32::consts::PI / 180.0 / SWING;
/// Drawn frames per second.
const FPS: f32 = 60.0;

/// What one delayed walk is.
#[derive(Debug, Clone)]
pub struct WalkConfig {
    /// `host:port` on loopback.
    pub host: String,
    pub scene: String,
    pub seconds: f32,
    /// Each way, milliseconds.
    pub delay_ms: u32,
    /// The stream's query (`?region_m=0.5&turn_deg=15`, `?lookahead_ms=150&hold_ms=300`).
    pub query: String,
    pub viewport: [u32; 2],
    /// Where it walks ([`WalkPath::of`]).
    pub path: WalkPath,
}

/// Where a walk goes: from `from`, level along unit `dir`, the view swinging about it.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct WalkPath {
    pub from: Vec3,
    pub dir: Vec3,
}

impl WalkPath {
    /// The demo city's street: along +x from x = −100, 1.7 m up.
    pub const DEMO_STREET: WalkPath = WalkPath {
        from: Vec3::new(-100.0, 1.7, 0.0),
        dir: Vec3::X,
    };

    /// The path of scene `scene` on the server at `host`: the demo street for the
    /// demo city, else from the scene's walk start (`GET /v1/scenes/{id}`) along its
    /// level direction.
    pub async fn of(host: &str, scene: &str) -> Result<Self> {
        if scene == "demo" {
            return Ok(Self::DEMO_STREET);
        }
        let res = crate::loadgen::http_client()?
            .get(format!("http://{host}/v1/scenes/{scene}"))
            .send()
            .await?;
        if !res.status().is_success() {
            bail!("scene {scene}: {} {}", res.status(), res.text().await?);
        }
        let info: SceneInfo = res.json().await?;
        let start = info
            .start
            .with_context(|| format!("scene {scene} has no walk start"))?;
        let from = Vec3::from(start.position);
        let dir = (Vec3::from(start.look_at) - from) * Vec3::new(1.0, 0.0, 1.0);
        Ok(WalkPath {
            from,
            dir: dir
                .try_normalize()
                .context("a walk start looking straight up")?,
        })
    }

    /// The pose drawn `t` seconds into the walk, at 1.4 m/s, the view swinging up to
    /// 30°/s about the path's direction.
    pub fn pose(&self, t: f32, viewport: [u32; 2]) -> Pose {
        // The yaw that turns −z onto the path's direction, then the swing.
        let yaw = (-self.dir.x).atan2(-self.dir.z) + SWING * (SWING_RATE * t).sin();
        let (s, c) = (yaw / 2.0).sin_cos();
        let eye = self.from + self.dir * (SPEED * t);
        Pose {
            rotation: Some([0.0, s, 0.0, c]),
            look_at: None,
            viewport,
            ..Pose::looking_at(eye.to_array(), (eye + self.dir).to_array())
        }
    }
}

/// What the walk found.
#[derive(Debug, Clone, serde::Serialize)]
pub struct WalkReport {
    pub scene: String,
    pub query: String,
    pub delay_ms: u32,
    pub frames: usize,
    /// Frames drawn before the first answer arrived (not counted below).
    pub waiting: usize,
    /// Frames drawn with a late reveal, and the late objects summed over frames.
    pub late_frames: usize,
    pub late_objects: usize,
    /// Late objects per second of walking.
    pub late_per_s: f64,
    /// Frames drawn outside the region their set holds for (region streams).
    pub outside_region: usize,
    /// Culls per second: region frames on a region stream, answered poses otherwise.
    pub culls_per_s: f64,
    /// Mean objects held ÷ mean objects the oracle sees, over the drawn frames.
    pub held_over_seen: f64,
}

/// The pose drawn `t` seconds into a walk of the demo street ([`WalkPath::DEMO_STREET`]).
pub fn walk_pose(t: f32, viewport: [u32; 2]) -> Pose {
    WalkPath::DEMO_STREET.pose(t, viewport)
}

/// The view direction of a pose given by its rotation (unit; −z for none).
pub fn forward(pose: &Pose) -> [f32; 3] {
    let q = Quat::from_array(pose.rotation.unwrap_or([0.0, 0.0, 0.0, 1.0]));
    (q.normalize() * Vec3::NEG_Z).to_array()
}

/// Walks once and checks every drawn frame (see the module docs).
pub async fn walk(cfg: &WalkConfig) -> Result<WalkReport> {
    crate::loadgen::loopback(&format!("http://{}", cfg.host))?;
    let frames = (cfg.seconds * FPS) as usize;
    if frames == 0 {
        bail!("--seconds must give at least one frame");
    }
    let poses: Vec<Pose> = (0..frames)
        .map(|k| cfg.path.pose(k as f32 / FPS, cfg.viewport))
        .collect();
    let url = format!(
        "ws://{}/v1/scenes/{}/stream{}",
        cfg.host, cfg.scene, cfg.query
    );
    let (ws, _) = tokio_tungstenite::connect_async_with_config(url, None, true).await?;
    let (mut tx, mut rx) = ws.split();
    let hello = rx.next().await.context("no hello")??;
    if !matches!(hello, Message::Binary(_)) {
        bail!("expected a hello frame");
    }
    let delay = Duration::from_millis(cfg.delay_ms.into());
    let start = tokio::time::Instant::now() + Duration::from_millis(100);
    // Every frame with the moment the client sees it (its receipt, delayed).
    let received: Arc<Mutex<Vec<(Duration, Frame)>>> = Arc::default();
    let reader = {
        let received = received.clone();
        tokio::spawn(async move {
            while let Some(Ok(m)) = rx.next().await {
                if let Message::Binary(b) = m
                    && let Ok(f) = Frame::decode(&b)
                {
                    let seen = tokio::time::Instant::now() + delay - start;
                    received.lock().unwrap().push((seen, f));
                }
            }
        })
    };
    for (k, pose) in poses.iter().enumerate() {
        let drawn = start + Duration::from_secs_f32(k as f32 / FPS);
        tokio::time::sleep_until(drawn + delay).await;
        let frame =
            PoseFrame::from_pose(k as u32 + 1, k == 0, pose).context("a quaternion pose")?;
        tx.send(Message::Binary(Frame::Pose(frame).encode().into()))
            .await?;
    }
    // The last answers, then the oracle.
    tokio::time::sleep(2 * delay + Duration::from_millis(500)).await;
    let _ = tx.close().await;
    reader.abort();
    let received = std::mem::take(&mut *received.lock().unwrap());
    let oracle = exact_sets(cfg, &poses).await?;

    let (mut set, mut region, mut next) = (Vec::<u32>::new(), None::<RegionFrame>, 0);
    // Frames drawn before the first set arrived count apart: nothing to hold yet.
    let (mut waiting, mut first) = (0, false);
    let (mut late_frames, mut late_objects, mut outside) = (0, 0, 0);
    let (mut held_sum, mut seen_sum) = (0usize, 0usize);
    // The region of the set held: a region frame applies to the set that follows it.
    let mut pending_region = None;
    for (k, pose) in poses.iter().enumerate() {
        let now = Duration::from_secs_f32(k as f32 / FPS);
        while next < received.len() && received[next].0 <= now {
            match &received[next].1 {
                Frame::Region(r) => pending_region = Some(*r),
                Frame::Full(f) => {
                    first = true;
                    set = f.ids.clone();
                    region = pending_region.take().or(region);
                }
                Frame::Delta(d) => {
                    apply_delta(&mut set, d).context("deltas apply in order")?;
                    region = pending_region.take().or(region);
                }
                Frame::Hello(_)
                | Frame::Pose(_)
                | Frame::Error(_)
                | Frame::Transforms(_)
                | Frame::Applied(_) => {}
            }
            next += 1;
        }
        if !first {
            waiting += 1;
            continue;
        }
        let late = oracle[k]
            .iter()
            .filter(|id| set.binary_search(id).is_err())
            .count();
        late_frames += usize::from(late > 0);
        late_objects += late;
        held_sum += set.len();
        seen_sum += oracle[k].len();
        if let Some(r) = &region {
            outside += usize::from(!r.holds(pose.position, forward(pose)));
        }
    }
    let regions = received
        .iter()
        .filter(|(_, f)| matches!(f, Frame::Region(_)))
        .count();
    let answers = received
        .iter()
        .filter(|(_, f)| matches!(f, Frame::Full(_) | Frame::Delta(_)))
        .count();
    let culls = if regions > 0 { regions } else { answers };
    Ok(WalkReport {
        scene: cfg.scene.clone(),
        query: cfg.query.clone(),
        delay_ms: cfg.delay_ms,
        frames,
        waiting,
        late_frames,
        late_objects,
        late_per_s: late_objects as f64 * FPS as f64 / (frames - waiting).max(1) as f64,
        outside_region: outside,
        culls_per_s: culls as f64 / cfg.seconds as f64,
        held_over_seen: held_sum as f64 / seen_sum.max(1) as f64,
    })
}

/// The exact oracle's set at each pose (`POST …/cull/batch`, 64 poses at a time).
async fn exact_sets(cfg: &WalkConfig, poses: &[Pose]) -> Result<Vec<Vec<u32>>> {
    let http = crate::loadgen::http_client()?;
    let mut sets = Vec::with_capacity(poses.len());
    for chunk in poses.chunks(64) {
        let res = http
            .post(format!(
                "http://{}/v1/scenes/{}/cull/batch",
                cfg.host, cfg.scene
            ))
            .json(&serde_json::json!({"poses": chunk, "options": {"method": "exact"}}))
            .send()
            .await?;
        if !res.status().is_success() {
            bail!("the oracle's batch: {} {}", res.status(), res.text().await?);
        }
        let r: BatchResponse = res.json().await?;
        sets.extend(r.results.into_iter().map(|c| c.visible));
    }
    Ok(sets)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_walk_goes_along_its_path_looking_along_it_at_first() {
        for dir in [Vec3::X, Vec3::NEG_Z, Vec3::new(0.6, 0.0, -0.8), Vec3::NEG_X] {
            let path = WalkPath {
                from: Vec3::new(1.0, 1.7, 2.0),
                dir,
            };
            let at0 = path.pose(0.0, [64, 36]);
            assert!(Vec3::from(at0.position).distance(path.from) < 1e-6);
            let look = Vec3::from(forward(&at0));
            assert!(look.distance(dir) < 1e-5, "{dir}: looks along {look}");
            let at1 = path.pose(1.0, [64, 36]);
            let walked = Vec3::from(at1.position) - path.from;
            assert!(walked.distance(dir * SPEED) < 1e-5, "{walked}");
            // The swing turns the view, level, by at most SWING.
            let turned = Vec3::from(forward(&at1));
            assert!(turned.y.abs() < 1e-6 && turned.angle_between(dir) <= SWING + 1e-5);
        }
        // The demo street is the walk it always was: along +x from x = −100.
        let p = walk_pose(2.0, [64, 36]);
        assert!((p.position[0] - (-100.0 + 2.0 * SPEED)).abs() < 1e-5);
    }
}
