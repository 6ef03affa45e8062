//! Prometheus metrics: one process-wide recorder, and a middleware that counts and
//! times every request by route.
//!
//! Metric names (all prefixed `homcull_`): `http_requests_total{route,status}`,
//! `http_request_seconds{route}`, `culls_total{method}`, `cull_batch_poses`,
//! `cull_batch_seconds`, `worker_queue`, `worker_rejected_total`, `ws_clients`,
//! `ws_frames_total{kind}`, `ws_frame_bytes_total{kind}`, `ws_dropped_poses_total`,
//! `ws_bad_frames_total`, `scenes`.

use std::sync::OnceLock;
use std::time::Instant;

use axum::extract::{MatchedPath, Request};
use axum::middleware::Next;
use axum::response::Response;
use metrics_exporter_prometheus::{Matcher, PrometheusBuilder, PrometheusHandle};

/// The process-wide recorder (installed on first use; servers in one process share it).
pub fn handle() -> PrometheusHandle {
    static HANDLE: OnceLock<PrometheusHandle> = OnceLock::new();
    HANDLE
        .get_or_init(|| {
            let secs = [
                0.0001, 0.00025, 0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5,
                1.0, 2.5, 5.0,
            ];
            let poses = [
                1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, 128.0, 256.0, 512.0, 1024.0,
            ];
            let builder = PrometheusBuilder::new()
                .set_buckets_for_metric(Matcher::Suffix("seconds".into()), &secs)
                .and_then(|b| b.set_buckets_for_metric(Matcher::Suffix("poses".into()), &poses))
                .expect("non-empty buckets");
            match builder.install_recorder() {
                Ok(h) => h,
                // Another recorder is installed (an embedding program's): render ours anyway.
                Err(_) => PrometheusBuilder::new().build_recorder().handle(),
            }
        })
        .clone()
}

/// Counts and times each request under its route template (`/v1/scenes/{id}`).
pub async fn track(req: Request, next: Next) -> Response {
    let route = req
        .extensions()
        .get::<MatchedPath>()
        .map_or("unmatched".to_string(), |p| p.as_str().to_string());
    let start = Instant::now();
    let res = next.run(req).await;
    let status = res.status().as_u16().to_string();
    metrics::counter!("homcull_http_requests_total", "route" => route.clone(), "status" => status)
        .increment(1);
    metrics::histogram!("homcull_http_request_seconds", "route" => route)
        .record(start.elapsed().as_secs_f64());
    res
}
