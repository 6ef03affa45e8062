//! A stereo pose on a stream, as a binary pose frame (flag bit 1) or a JSON message:
//! the frames carry the REST answer for the same stereo pose, levels included.

use crate::common;

use common::server::{TestServer, post_json, street_walk};
use common::ws::{Tracker, connect, next_frame, pose_frame};
use futures_util::SinkExt;
use homcull_proto::{CullResponse, Pose, Stereo};
use serde_json::json;
use tokio_tungstenite::tungstenite::Message;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stereo_poses_stream_what_rest_answers() {
    let srv = TestServer::start(|_| {}).await;
    let http = reqwest::Client::new();
    let mut ws = connect(&srv, "?lod_px=64,16,4").await;
    let mut t = Tracker::default();
    for (i, pose) in street_walk(8, [480, 270]).into_iter().enumerate() {
        let pose = Pose {
            stereo: Some(Stereo {
                ipd_m: 0.064,
                convergence_m: (i % 4 >= 2).then_some(3.0),
            }),
            ..pose
        };
        let seq = i as u32 + 1;
        let (message, how) = if i % 2 == 0 {
            let text = json!({"seq": seq, "pose": pose, "full": false}).to_string();
            (Message::Text(text.into()), "JSON")
        } else {
            (pose_frame(seq, &pose, false), "binary")
        };
        ws.send(message).await.unwrap();
        let rest: CullResponse = post_json(
            &http,
            srv.url("/v1/scenes/demo/cull"),
            &json!({"pose": pose, "options": {"refine": false, "lod": {"px": [64, 16, 4]}}}),
        )
        .await;
        assert_eq!(t.apply(&next_frame(&mut ws).await), seq);
        assert_eq!(
            (&t.set, &t.levels),
            (&rest.visible, &rest.lod),
            "{how} pose {i}"
        );
    }
    srv.stop().await;
}

/// A JSON pose with a region is refused on a stream (an `invalid_pose` error frame
/// that names the region), and the stream keeps answering the poses after it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stream_refuses_a_region_and_keeps_serving() {
    use homcull_proto::frame::{ErrorCode, Frame};

    let srv = TestServer::start(|_| {}).await;
    let mut ws = connect(&srv, "").await;
    let pose = street_walk(1, [320, 180]).remove(0);
    let mut with_region = serde_json::to_value(&pose).unwrap();
    with_region["region"] = json!({"radius_m": 0.5});
    let text = json!({"seq": 1, "pose": with_region, "full": false}).to_string();
    ws.send(Message::Text(text.into())).await.unwrap();
    match next_frame(&mut ws).await {
        Frame::Error(e) => {
            assert_eq!((e.ack, e.code), (1, ErrorCode::InvalidPose));
            assert!(e.message.contains("region"), "{}", e.message);
        }
        f => panic!("expected an error frame, got {f:?}"),
    }
    ws.send(pose_frame(2, &pose, false)).await.unwrap();
    let mut t = Tracker::default();
    assert_eq!(t.apply(&next_frame(&mut ws).await), 2);
    srv.stop().await;
}
