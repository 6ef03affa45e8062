//! The stream option `seen_first` (temporal coherence): occluders the
//! client saw at its previous pose are selected first. With an occluder budget too small
//! for the whole frustum, a walk must then cull more than nearest-first selection
//! (`POST /cull`) does, and still never miss an object the exact oracle sees.

use crate::common;

use common::server::{TestServer, post_json};
use common::ws::{Tracker, connect_hello, next_frame, pose_frame, rest_cull};
use futures_util::SinkExt;
use homcull_proto::{CullResponse, Pose};
use serde_json::json;

/// 60 poses, 0.5 m apart, along the demo city's street.
fn walk() -> Vec<Pose> {
    (0..60)
        .map(|i| {
            let x = -20.0 + 0.5 * i as f32;
            homcull::eval::loadgen::street_pose([x, 1.7, 0.0], i as f32 * 0.1, [480, 270])
        })
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn seen_first_culls_more_under_a_small_budget_and_misses_nothing() {
    if common::gpu().is_none() {
        return;
    }
    // 1,000 triangles: a few dozen of the street's occluders, not all of them.
    let srv = TestServer::start(|a| a.budget = 1_000).await;
    let http = reqwest::Client::new();
    let (mut ws, hello) = connect_hello(&srv, "?seen_first=true").await;
    assert_eq!(hello["seen_first"], json!(true));
    let mut t = Tracker::default();
    let (mut streamed, mut nearest_first) = (0, 0);
    for (i, pose) in walk().iter().enumerate() {
        let seq = i as u32 + 1;
        ws.send(pose_frame(seq, pose, false)).await.unwrap();
        assert_eq!(t.apply(&next_frame(&mut ws).await), seq);
        let oracle: CullResponse = post_json(
            &http,
            srv.url("/v1/scenes/demo/cull"),
            &json!({ "pose": pose, "options": { "method": "exact" } }),
        )
        .await;
        let missed: Vec<u32> = oracle
            .visible
            .iter()
            .copied()
            .filter(|id| t.set.binary_search(id).is_err())
            .collect();
        assert!(
            missed.is_empty(),
            "pose {i}: the oracle sees {missed:?}, not streamed"
        );
        streamed += t.set.len();
        nearest_first += rest_cull(&http, &srv, pose).await.len();
    }
    eprintln!(
        "objects kept over the walk: {streamed} with seen_first, {nearest_first} nearest first"
    );
    assert!(
        streamed < nearest_first,
        "seen_first kept {streamed} objects over the walk, nearest-first {nearest_first}"
    );
    srv.stop().await;
}
