//! Abusive WebSocket clients get the right close code, after their error frames, and
//! never a reset: an oversized message closes with 1009, a flood of garbage with 1008
//! after error frames, a client that sends nothing for the idle timeout with 1008; the
//! other clients go on being answered.

use crate::common;

use std::time::{Duration, Instant};

use common::server::{TestServer, street_walk};
use common::ws::{Tracker, connect, next_frame, pose_frame};
use futures_util::{SinkExt, StreamExt};
use homcull_proto::frame::Frame;
use tokio_tungstenite::tungstenite::Message;

/// Reads until the close frame; returns its code and the error frames seen before it.
/// A reset or an end without a close frame fails the test.
async fn close_code(ws: &mut common::ws::Ws) -> (u16, usize) {
    let mut errors = 0;
    loop {
        let msg = tokio::time::timeout(Duration::from_secs(20), ws.next())
            .await
            .expect("a close within 20 s");
        match msg {
            Some(Ok(Message::Close(Some(f)))) => return (u16::from(f.code), errors),
            Some(Ok(Message::Binary(b))) => {
                if matches!(Frame::decode(&b), Ok(Frame::Error(_))) {
                    errors += 1;
                }
            }
            Some(Ok(_)) => {}
            other => panic!("expected a close frame, got {other:?}"),
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn abusive_clients_are_closed_with_the_right_code() {
    let srv = TestServer::start(|c| c.ws_idle_timeout_s = 2).await;
    let poses = street_walk(4, [320, 180]);
    let mut good = connect(&srv, "").await;
    let mut t = Tracker::default();

    let mut big = connect(&srv, "").await;
    let _ = big.send(Message::Binary(vec![0u8; 1 << 20].into())).await;
    assert_eq!(close_code(&mut big).await.0, 1009, "oversized message");

    let mut garbage = connect(&srv, "").await;
    for _ in 0..64 {
        let _ = garbage.send(Message::Binary(vec![0xAB; 40].into())).await;
    }
    let (code, errors) = close_code(&mut garbage).await;
    assert_eq!(code, 1008, "a flood of garbage");
    assert!(errors >= 1, "error frames come before the close");

    // The good client keeps sending, so it is never idle; the silent one is closed.
    let mut silent = connect(&srv, "").await;
    let t0 = Instant::now();
    let silent_closed = tokio::spawn(async move { close_code(&mut silent).await.0 });
    for (i, p) in poses.iter().cycle().take(8).enumerate() {
        good.send(pose_frame(i as u32 + 1, p, false)).await.unwrap();
        assert_eq!(t.apply(&next_frame(&mut good).await), i as u32 + 1);
        tokio::time::sleep(Duration::from_millis(400)).await;
    }
    assert_eq!(silent_closed.await.unwrap(), 1008, "idle client");
    assert!(t0.elapsed() < Duration::from_secs(10));
    srv.stop().await;
}
