//! WebSocket helpers of the integration tests: connect (checking the hello frame), read
//! frames, send poses, track the visible set through full and delta frames.

use std::time::Duration;

use futures_util::StreamExt;
use homcull_proto::frame::{Frame, PoseFrame, VisibleFull, apply_delta, apply_delta_with_levels};
use homcull_proto::{CullResponse, Pose};
use serde_json::json;
use tokio_tungstenite::tungstenite::Message;

use super::server::{TestServer, post_json};

pub type Ws =
    tokio_tungstenite::WebSocketStream<tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>>;

/// The demo's stream, its upgrade request carrying `token` as a bearer token if given
/// (the hello frame left unread).
pub async fn open(srv: &TestServer, token: Option<&str>) -> Ws {
    use tokio_tungstenite::tungstenite::client::IntoClientRequest;
    let url = srv.ws_url("/v1/scenes/demo/stream");
    let mut req = url.as_str().into_client_request().unwrap();
    if let Some(t) = token {
        req.headers_mut()
            .insert("authorization", format!("Bearer {t}").parse().unwrap());
    }
    tokio_tungstenite::connect_async(req).await.unwrap().0
}

pub async fn connect(srv: &TestServer, query: &str) -> Ws {
    connect_hello(srv, query).await.0
}

/// [`connect`], also returning the hello frame's JSON.
pub async fn connect_hello(srv: &TestServer, query: &str) -> (Ws, serde_json::Value) {
    let (mut ws, _) =
        tokio_tungstenite::connect_async(srv.ws_url(&format!("/v1/scenes/demo/stream{query}")))
            .await
            .expect("upgrade");
    match next_frame(&mut ws).await {
        Frame::Hello(h) => {
            let info: serde_json::Value = serde_json::from_str(&h.info_json).unwrap();
            assert_eq!(info["protocol_version"], homcull_proto::PROTOCOL_VERSION);
            assert_eq!(info["scene"]["id"], "demo");
            assert_eq!(
                h.object_count,
                info["scene"]["objects"].as_u64().unwrap() as u32
            );
            (ws, info)
        }
        f => panic!("expected hello, got {f:?}"),
    }
}

pub async fn next_frame(ws: &mut Ws) -> Frame {
    loop {
        let msg = tokio::time::timeout(Duration::from_secs(60), ws.next())
            .await
            .expect("a frame within 60 s")
            .expect("stream open")
            .expect("no socket error");
        match msg {
            Message::Binary(b) => return Frame::decode(&b).expect("server frames decode"),
            Message::Ping(_) | Message::Pong(_) => continue,
            m => panic!("unexpected message {m:?}"),
        }
    }
}

pub fn pose_frame(seq: u32, pose: &Pose, want_full: bool) -> Message {
    Message::Binary(
        Frame::Pose(PoseFrame::from_pose(seq, want_full, pose).unwrap())
            .encode()
            .into(),
    )
}

/// Client-side state: the visible set kept up to date by full and delta frames.
#[derive(Default)]
pub struct Tracker {
    pub set: Vec<u32>,
    /// The level of each ID of `set`, on a stream with levels of detail.
    pub levels: Option<Vec<u8>>,
    pub full_bytes: usize,
    pub delta_bytes: usize,
    pub frames: usize,
    pub dropped: u32,
}

impl Tracker {
    /// Applies one visibility frame; returns the pose seq it answers.
    pub fn apply(&mut self, f: &Frame) -> u32 {
        self.frames += 1;
        match f {
            Frame::Full(v) => {
                self.full_bytes += f.encoded_len();
                self.dropped += v.stats.dropped_poses;
                self.set = v.ids.clone();
                self.levels = v.levels.clone();
                v.ack
            }
            Frame::Delta(d) => {
                self.delta_bytes += f.encoded_len();
                self.dropped += d.stats.dropped_poses;
                match &mut self.levels {
                    Some(levels) => apply_delta_with_levels(&mut self.set, levels, d)
                        .expect("deltas apply to the last set and its levels"),
                    None => {
                        assert!(
                            d.lod.is_none(),
                            "levels in a delta after a full frame without"
                        );
                        apply_delta(&mut self.set, d).expect("deltas apply to the last set")
                    }
                }
                d.ack
            }
            f => panic!("expected a visibility frame, got {f:?}"),
        }
    }
}

/// `POST /cull` with the stream's default options (`refine` is false for streams).
pub async fn rest_cull(http: &reqwest::Client, srv: &TestServer, pose: &Pose) -> Vec<u32> {
    let r: CullResponse = post_json(
        http,
        srv.url("/v1/scenes/demo/cull"),
        &json!({ "pose": pose, "options": { "refine": false } }),
    )
    .await;
    r.visible
}

/// Bytes of a full frame carrying `set` (the stats do not change the size).
pub fn full_frame_len(set: &[u32]) -> usize {
    Frame::Full(VisibleFull {
        ids: set.to_vec(),
        ..VisibleFull::default()
    })
    .encoded_len()
}
