//! The server's probes, docs and metrics: `/healthz`, `/readyz` (naming the adapter),
//! the OpenAPI description and Swagger UI, and `/metrics` after a cull.

use crate::common;

use common::rest::pose_json;
use common::server::{TestServer, get_json, post_json, street_walk};
use homcull_proto::CullResponse;
use serde_json::{Value, json};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn probes_docs_and_metrics_answer() {
    let srv = TestServer::start(|_| {}).await;
    let http = reqwest::Client::new();
    eprintln!("adapter: {}", srv.adapter);

    assert_eq!(
        http.get(srv.url("/healthz")).send().await.unwrap().status(),
        200
    );
    let ready: Value = get_json(&http, srv.url("/readyz")).await;
    assert_eq!(ready["ready"], true);
    assert_eq!(ready["adapter"], srv.adapter.as_str());
    let api: Value = get_json(&http, srv.url("/openapi.json")).await;
    for path in [
        "/v1/scenes",
        "/v1/scenes/{id}/cull",
        "/v1/scenes/{id}/cull/batch",
        "/v1/scenes/{id}/stream",
    ] {
        assert!(api["paths"][path].is_object(), "openapi lacks {path}");
    }
    assert_eq!(
        http.get(srv.url("/docs/")).send().await.unwrap().status(),
        200
    );
    let poses = street_walk(1, [320, 180]);
    let cull = srv.url("/v1/scenes/demo/cull");
    // The metrics saw a cull.
    let r: CullResponse = post_json(&http, &cull, &json!({"pose": pose_json(&poses[0])})).await;
    assert!(!r.visible.is_empty());
    let metrics = http
        .get(srv.url("/metrics"))
        .send()
        .await
        .unwrap()
        .text()
        .await
        .unwrap();
    for name in [
        "homcull_http_requests_total",
        "homcull_http_request_seconds",
        "homcull_culls_total",
        "homcull_cull_batch_poses",
        "homcull_cull_batch_seconds",
    ] {
        assert!(metrics.contains(name), "metrics lack {name}");
    }
    assert!(metrics.contains(r#"route="/v1/scenes/{id}/cull""#));
    srv.stop().await;
}
