//! Moving objects over WebSocket: a stream that asks (`?placements=true`) is told where
//! the visible moved objects are and which scene version a frame was culled at; a
//! stream may itself move objects (text messages, the write token on its upgrade).

use crate::common;

use common::server::{TestServer, post_json, street_walk};
use homcull_proto::TransformsResponse;
use serde_json::{Value, json};

/// The next message of a stream: a JSON text message or a binary frame.
async fn next_message(ws: &mut common::ws::Ws) -> Result<Value, homcull_proto::frame::Frame> {
    use futures_util::StreamExt;
    use tokio_tungstenite::tungstenite::Message;
    loop {
        let msg = tokio::time::timeout(std::time::Duration::from_secs(60), ws.next())
            .await
            .expect("a message within 60 s")
            .expect("stream open")
            .expect("no socket error");
        match msg {
            Message::Text(t) => return Ok(serde_json::from_str(&t).expect("JSON")),
            Message::Binary(b) => {
                return Err(homcull_proto::frame::Frame::decode(&b).expect("frame"));
            }
            _ => continue,
        }
    }
}

/// A stream with `?placements=true` is told, before the frame culled at a new
/// version, the version and where the visible moved objects are; an object back home
/// is told the identity; a stream without the option gets binary frames only.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn streams_that_ask_are_told_where_moved_objects_are() {
    use futures_util::SinkExt;
    let srv = TestServer::start(|_| {}).await;
    let http = reqwest::Client::new();
    let pose = street_walk(1, [320, 180]).remove(0);
    let (mut ws, hello) = common::ws::connect_hello(&srv, "?placements=true").await;
    assert_eq!(hello["placements"], true);
    let mut plain = common::ws::connect(&srv, "").await;
    let mut seq = 0;
    let mut ask = async |ws: &mut common::ws::Ws| {
        seq += 1;
        ws.send(common::ws::pose_frame(seq, &pose, true))
            .await
            .unwrap();
        seq
    };
    // Version 0: told once, with no objects.
    ask(&mut ws).await;
    let first = next_message(&mut ws).await.expect("placements first");
    assert_eq!(first["placements"]["version"], 0);
    assert_eq!(first["placements"]["objects"], json!([]));
    let Err(homcull_proto::frame::Frame::Full(full)) = next_message(&mut ws).await else {
        panic!("a full frame");
    };
    let visible = full.ids;
    // Move a visible object: told with its matrix.
    let id = visible[visible.len() / 2];
    let moved: TransformsResponse = post_json(
        &http,
        srv.url("/v1/scenes/demo/transforms"),
        &json!({"objects": [{"id": id, "translation": [0.0, 0.5, 0.0]}]}),
    )
    .await;
    ask(&mut ws).await;
    let told = next_message(&mut ws).await.expect("placements");
    assert_eq!(told["placements"]["version"], moved.version);
    let objects = told["placements"]["objects"].as_array().unwrap().clone();
    let entry = objects
        .iter()
        .find(|o| o["id"] == id)
        .expect("the moved object");
    assert_eq!(entry["matrix"][13], 0.5, "column-major: y translation");
    assert!(next_message(&mut ws).await.is_err(), "then the frame");
    // Same version again: nothing to tell, the frame alone.
    ask(&mut ws).await;
    assert!(next_message(&mut ws).await.is_err());
    // Back home: told the identity.
    post_json::<TransformsResponse>(
        &http,
        srv.url("/v1/scenes/demo/transforms"),
        &json!({"objects": [{"id": id}]}),
    )
    .await;
    ask(&mut ws).await;
    let home = next_message(&mut ws).await.expect("placements");
    let entry = home["placements"]["objects"]
        .as_array()
        .unwrap()
        .iter()
        .find(|o| o["id"] == id)
        .cloned()
        .expect("the object back home");
    assert_eq!(entry["matrix"], json!(glam::Mat4::IDENTITY.to_cols_array()));
    // A stream that did not ask: binary frames only.
    plain
        .send(common::ws::pose_frame(1, &pose, true))
        .await
        .unwrap();
    assert!(next_message(&mut plain).await.is_err());
    srv.stop().await;
}

/// Writers on a stream: updates as text messages, answered with the version or the
/// REST error code; when the server has a token, only a stream upgraded with it may
/// write, and the poses of the same stream are still answered.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stream_may_move_objects() {
    use futures_util::SinkExt;
    use tokio_tungstenite::tungstenite::Message;
    let srv = TestServer::start(|c| c.api_token = Some("s3cret".into())).await;
    let update = |seq: u32, body: Value| {
        Message::Text(json!({"seq": seq, "transforms": body}).to_string().into())
    };
    let reply = async |ws: &mut common::ws::Ws| -> Value {
        loop {
            match next_message(ws).await {
                Ok(v) => return v["transforms"].clone(),
                Err(homcull_proto::frame::Frame::Hello(_)) => continue,
                Err(f) => panic!("expected a reply, got {f:?}"),
            }
        }
    };
    // Without the token: refused, nothing applied.
    let mut anon = common::ws::open(&srv, None).await;
    let moving = json!({"objects": [{"id": 3, "translation": [0, 1, 0]}]});
    anon.send(update(1, moving.clone())).await.unwrap();
    let r = reply(&mut anon).await;
    assert_eq!(
        (r["seq"].clone(), r["error"]["code"].clone()),
        (json!(1), json!("unauthorized"))
    );
    // With it: applied, versions follow; a bad update gets its REST code; a malformed
    // message its own; poses on the same stream are still answered.
    let mut ws = common::ws::open(&srv, Some("s3cret")).await;
    ws.send(update(5, moving)).await.unwrap();
    let r = reply(&mut ws).await;
    assert_eq!(
        (r["seq"].clone(), r["version"].clone(), r["applied"].clone()),
        (json!(5), json!(1), json!(1))
    );
    ws.send(update(6, json!({"objects": [{"id": 99_999_999}]})))
        .await
        .unwrap();
    let r = reply(&mut ws).await;
    assert_eq!(r["error"]["code"], "unknown_object", "{r}");
    ws.send(Message::Text(
        r#"{"seq": 7, "transforms": {"objects": 5}}"#.into(),
    ))
    .await
    .unwrap();
    let r = reply(&mut ws).await;
    assert_eq!(
        (r["seq"].clone(), r["error"]["code"].clone()),
        (json!(0), json!("malformed_json"))
    );
    let pose = street_walk(1, [160, 90]).remove(0);
    ws.send(common::ws::pose_frame(1, &pose, true))
        .await
        .unwrap();
    let Err(homcull_proto::frame::Frame::Full(full)) = next_message(&mut ws).await else {
        panic!("a full frame");
    };
    assert_eq!(full.ack, 1);
    srv.stop().await;
}

/// The binary writer (protocol version 4): a Transforms frame is answered with an
/// Applied frame naming the version, a refused one with an Error frame, and the next
/// visibility frame's stats name the version it was culled at.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn binary_transforms_frames_are_applied_and_answered() {
    use futures_util::SinkExt;
    use homcull_proto::frame::{ErrorCode, Frame, MovedObject, TransformsFrame};
    use tokio_tungstenite::tungstenite::Message;
    let srv = TestServer::start(|c| c.api_token = Some("s3cret".into())).await;
    let up = |seq: u32, ids: &[u32]| {
        let objects = ids
            .iter()
            .map(|&id| MovedObject {
                id,
                matrix: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.5, 0.0],
                velocity: [2.0, 0.0, 0.0],
                angular_velocity: [0.0; 3],
                valid_ms: None,
            })
            .collect();
        let f = Frame::Transforms(TransformsFrame {
            seq,
            horizon_ms: Some(50.0),
            objects,
        });
        Message::Binary(f.encode().into())
    };
    let next_frame = async |ws: &mut common::ws::Ws| loop {
        match next_message(ws).await {
            Err(Frame::Hello(_)) => continue,
            Err(f) => return f,
            Ok(v) => panic!("unexpected text {v}"),
        }
    };
    let mut anon = common::ws::open(&srv, None).await;
    anon.send(up(1, &[3])).await.unwrap();
    let Frame::Error(e) = next_frame(&mut anon).await else {
        panic!("an error frame")
    };
    assert_eq!((e.code, e.ack), (ErrorCode::Unauthorized, 1));

    let mut ws = common::ws::open(&srv, Some("s3cret")).await;
    ws.send(up(21, &[3, 4, 9])).await.unwrap();
    let Frame::Applied(a) = next_frame(&mut ws).await else {
        panic!("an applied frame")
    };
    assert_eq!((a.ack, a.version, a.applied), (21, 1, 3));
    ws.send(up(22, &[99_999_999])).await.unwrap();
    let Frame::Error(e) = next_frame(&mut ws).await else {
        panic!("an error frame")
    };
    assert_eq!((e.code, e.ack), (ErrorCode::InvalidTransform, 22));
    assert!(e.message.contains("99999999"), "{}", e.message);
    let pose = street_walk(1, [160, 90]).remove(0);
    ws.send(common::ws::pose_frame(1, &pose, true))
        .await
        .unwrap();
    let Frame::Full(full) = next_frame(&mut ws).await else {
        panic!("a full frame")
    };
    assert_eq!((full.ack, full.stats.scene_version), (1, 1));
    assert!(full.seq > a.seq, "one frame counter for the stream");
    srv.stop().await;
}
