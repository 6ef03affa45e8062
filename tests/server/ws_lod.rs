//! Level-of-detail hints on a stream (`?lod_px=`): every frame's levels are those of
//! `POST /cull` for the pose, full frames carry every ID's level and deltas only those
//! of the added IDs and of the kept ones whose level changed, so that deltas stay
//! small along a walk.

use crate::common;

use common::server::{TestServer, get_json, post_json};
use common::ws::{Tracker, connect_hello, next_frame, pose_frame};
use futures_util::SinkExt;
use homcull_proto::frame::{Frame, VisibleFull};
use homcull_proto::{CullResponse, ObjectList, Pose};
use serde_json::json;

const LOD: &str = "?lod_px=64,16,4";

/// `n` poses `step` metres apart along the demo street from `x0`.
fn walk(x0: f32, step: f32, n: usize) -> Vec<Pose> {
    (0..n)
        .map(|i| {
            let x = x0 + step * i as f32;
            homcull::eval::loadgen::street_pose([x, 1.7, 0.0], x + 150.0, [480, 270])
        })
        .collect()
}

/// Streams `poses` with levels, checks set and levels against `POST /cull` after every
/// frame, and returns delta bytes over the bytes of the same answers as full frames.
async fn lod_ratio_of_walk(srv: &TestServer, poses: &[Pose], what: &str) -> f64 {
    let http = reqwest::Client::new();
    let (mut ws, hello) = connect_hello(srv, LOD).await;
    assert_eq!(hello["options"]["lod"], json!({"px": [64.0, 16.0, 4.0]}));
    let mut t = Tracker::default();
    let (mut as_full, mut changed_levels) = (0, 0);
    for (i, pose) in poses.iter().enumerate() {
        let seq = i as u32 + 1;
        ws.send(pose_frame(seq, pose, false)).await.unwrap();
        let f = next_frame(&mut ws).await;
        match &f {
            Frame::Full(v) => assert!(v.levels.is_some(), "{what}: full frames carry levels"),
            Frame::Delta(d) => {
                let lod = d.lod.as_ref().expect("deltas carry levels");
                changed_levels += lod.changed.len();
            }
            f => panic!("{what}: unexpected {f:?}"),
        }
        assert_eq!(t.apply(&f), seq);
        let rest: CullResponse = post_json(
            &http,
            srv.url("/v1/scenes/demo/cull"),
            &json!({"pose": pose, "options": {"refine": false, "lod": {"px": [64, 16, 4]}}}),
        )
        .await;
        assert_eq!(t.set, rest.visible, "{what}: pose {i}");
        assert_eq!(t.levels, rest.lod, "{what}: levels at pose {i}");
        if i > 0 {
            as_full += Frame::Full(VisibleFull {
                ids: t.set.clone(),
                levels: t.levels.clone(),
                ..VisibleFull::default()
            })
            .encoded_len();
        }
    }
    let deltas = poses.len() - 1;
    let ratio = t.delta_bytes as f64 / as_full as f64;
    eprintln!(
        "{what}, with levels: {deltas} deltas, {:.1} B/frame ({:.2} levels changed/frame) vs \
         {:.1} B/frame as full frames: delta/full ratio {ratio:.3}",
        t.delta_bytes as f64 / deltas as f64,
        changed_levels as f64 / deltas as f64,
        as_full as f64 / deltas as f64,
    );
    ratio
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_walk_with_levels_sends_only_what_changed() {
    let srv = TestServer::start(|c| c.full_every = 1000).await;
    let http = reqwest::Client::new();
    let objects: ObjectList = get_json(&http, srv.url("/v1/scenes/demo/objects")).await;
    assert!(!objects.objects.is_empty());
    let steady = lod_ratio_of_walk(
        &srv,
        &walk(-120.0, 0.023, 120),
        "walking speed from x = -120 m",
    )
    .await;
    let start = lod_ratio_of_walk(
        &srv,
        &walk(-150.0, 0.023, 120),
        "walking speed from x = -150 m",
    )
    .await;
    let metre = lod_ratio_of_walk(
        &srv,
        &walk(-150.0, 1.0, 120),
        "1 m per pose from x = -150 m",
    )
    .await;
    eprintln!("delta/full with levels: {steady:.3}, {start:.3}, {metre:.3}");
    // Measured on lavapipe: 0.075, 0.121, 0.136 (without levels: 0.083, 0.132, 0.139).
    assert!(steady <= 0.1, "a steady stretch: {steady:.3}");
    assert!(start <= 0.13, "the street's start: {start:.3}");
    assert!(metre <= 0.15, "1 m per pose: {metre:.3}");
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_thresholds_are_refused_before_the_upgrade() {
    let srv = TestServer::start(|_| {}).await;
    for bad in [
        "lod_px=4,16",
        "lod_px=",
        "lod_px=x",
        "lod_px=1,2,3,4,5,6,7,8,9",
    ] {
        let url = srv.ws_url(&format!("/v1/scenes/demo/stream?{bad}"));
        let err = tokio_tungstenite::connect_async(url).await.err();
        let Some(tokio_tungstenite::tungstenite::Error::Http(r)) = err else {
            panic!("{bad}: the upgrade was not refused: {err:?}");
        };
        assert_eq!(r.status(), 400, "{bad}");
        let body: homcull_proto::ErrorBody =
            serde_json::from_slice(r.body().as_deref().unwrap_or_default()).unwrap();
        assert!(
            body.error.message.contains("lod"),
            "{bad}: {}",
            body.error.message
        );
    }
    srv.stop().await;
}
