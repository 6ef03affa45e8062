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
