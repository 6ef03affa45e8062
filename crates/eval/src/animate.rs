//! `homcull animate`: a writer that moves a running server's objects, on loopback
//! only, so that a viewer shows a scene in motion: the demo city's cars drive up and
//! down their streets, the OpenArena maps' brush models (`--prefix model_`, doors and
//! lifts) rise and sink.
//!
//! Each chosen object moves along one axis, `amplitude · sin(2π·t/period + phase)`
//! metres from where the file put it (its phase from its ID, so cars do not move in
//! step), sent `--rate` times a second with its velocity at that instant, valid for two
//! updates, so that the server bounds where it may be until the next one.

use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use homcull_proto::{ObjectList, TransformsResponse};
use serde::Serialize;

use super::loadgen::{http_client, loopback};

/// Which axis an object moves along.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// The longer horizontal side of its bounds (a car drives forward).
    Long,
    X,
    Y,
    Z,
}

/// What to animate on which server.
#[derive(Debug, Clone)]
pub struct AnimateConfig {
    /// Base URL of the server (`http://` on a loopback address only).
    pub url: String,
    pub scene: String,
    /// Objects whose names start with this move.
    pub prefix: String,
    pub axis: Axis,
    /// Metres each side of the loaded place.
    pub amplitude: f32,
    /// Seconds for one round trip.
    pub period_s: f32,
    /// Updates per second.
    pub rate_hz: f32,
    /// How long to run (0: until stopped).
    pub seconds: f64,
    /// `Authorization: Bearer` token, when the server wants one for writes.
    pub token: Option<String>,
}

/// What a run did.
#[derive(Debug, Clone, Default, Serialize)]
pub struct AnimateReport {
    pub objects: usize,
    pub updates: u64,
    pub last_version: u64,
}

/// Moves the chosen objects until `seconds` have passed (or forever with 0).
pub async fn run(a: &AnimateConfig) -> Result<AnimateReport> {
    let host = loopback(&a.url)?;
    if !(a.rate_hz > 0.0 && a.rate_hz <= 1000.0) {
        bail!("--rate must be in (0, 1000]");
    }
    if !(a.period_s > 0.0 && a.amplitude.is_finite() && a.amplitude.abs() <= 1000.0) {
        bail!("--period-s must be positive and --amplitude at most 1000 m");
    }
    let http = http_client()?;
    let base = format!("http://{host}/v1/scenes/{}", a.scene);
    let list: ObjectList = http
        .get(format!("{base}/objects"))
        .send()
        .await?
        .error_for_status()
        .with_context(|| format!("scene `{}`", a.scene))?
        .json()
        .await?;
    let movers: Vec<(u32, [f32; 3])> = list
        .objects
        .iter()
        .filter(|o| o.name.starts_with(&a.prefix) && o.triangles > 0)
        .map(|o| (o.id, direction(a.axis, o.aabb)))
        .collect();
    if movers.is_empty() {
        bail!("no object of scene `{}` is named `{}…`", a.scene, a.prefix);
    }
    tracing::info!(objects = movers.len(), "animating");
    let interval = Duration::from_secs_f32(1.0 / a.rate_hz);
    let valid_ms = 2.0 * interval.as_secs_f64() * 1e3;
    let omega = std::f32::consts::TAU / a.period_s;
    let start = Instant::now();
    let mut tick = tokio::time::interval(interval);
    let mut report = AnimateReport {
        objects: movers.len(),
        ..Default::default()
    };
    while a.seconds <= 0.0 || start.elapsed().as_secs_f64() < a.seconds {
        tick.tick().await;
        let t = start.elapsed().as_secs_f32();
        let objects: Vec<serde_json::Value> = movers
            .iter()
            .map(|&(id, d)| {
                let phase = id as f32 * 2.399; // the golden angle: phases spread evenly
                let (s, c) = (omega * t + phase).sin_cos();
                let at = d.map(|k| k * a.amplitude * s);
                let velocity = d.map(|k| k * a.amplitude * omega * c);
                serde_json::json!({"id": id, "translation": at, "velocity": velocity, "valid_ms": valid_ms})
            })
            .collect();
        let mut req = http.post(format!("{base}/transforms"));
        if let Some(token) = &a.token {
            req = req.bearer_auth(token);
        }
        let res = req
            .json(&serde_json::json!({ "objects": objects }))
            .send()
            .await?;
        let status = res.status();
        if !status.is_success() {
            bail!(
                "the server refused an update: HTTP {status}: {}",
                res.text().await?
            );
        }
        let r: TransformsResponse = res.json().await?;
        report.updates += 1;
        report.last_version = r.version;
    }
    Ok(report)
}

/// The unit vector an object with bounds `aabb` moves along.
fn direction(axis: Axis, aabb: [[f32; 3]; 2]) -> [f32; 3] {
    match axis {
        Axis::X => [1.0, 0.0, 0.0],
        Axis::Y => [0.0, 1.0, 0.0],
        Axis::Z => [0.0, 0.0, 1.0],
        Axis::Long => {
            let [lo, hi] = aabb;
            if hi[0] - lo[0] >= hi[2] - lo[2] {
                [1.0, 0.0, 0.0]
            } else {
                [0.0, 0.0, 1.0]
            }
        }
    }
}
