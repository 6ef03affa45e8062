//! Writing to a client's socket within the send timeout, counting frames and bytes by
//! kind; a client that does not take a message in time is dropped.

use std::time::Duration;

use axum::extract::ws::{Message, WebSocket};
use futures_util::SinkExt;
use homcull_proto::frame::Frame;
use tokio::sync::Mutex;

pub(super) type Sink = futures_util::stream::SplitSink<WebSocket, Message>;

pub(super) async fn send(sink: &Mutex<Sink>, frame: Frame, timeout: Duration) -> Result<(), ()> {
    let bytes = frame.encode();
    let kind = frame.kind().name();
    metrics::counter!("homcull_ws_frames_total", "kind" => kind).increment(1);
    metrics::counter!("homcull_ws_frame_bytes_total", "kind" => kind).increment(bytes.len() as u64);
    send_message(sink, Message::Binary(bytes.into()), timeout).await
}

/// A text message (placements, a writer's replies) of `kind`.
pub(super) async fn send_text(
    sink: &Mutex<Sink>,
    kind: &'static str,
    text: String,
    timeout: Duration,
) -> Result<(), ()> {
    metrics::counter!("homcull_ws_frames_total", "kind" => kind).increment(1);
    metrics::counter!("homcull_ws_frame_bytes_total", "kind" => kind).increment(text.len() as u64);
    send_message(sink, Message::Text(text.into()), timeout).await
}

async fn send_message(sink: &Mutex<Sink>, message: Message, timeout: Duration) -> Result<(), ()> {
    let mut s = sink.lock().await;
    match tokio::time::timeout(timeout, s.send(message)).await {
        Ok(Ok(())) => Ok(()),
        Ok(Err(_)) => Err(()),
        Err(_) => {
            tracing::info!("a WebSocket client stopped reading; dropping it");
            Err(())
        }
    }
}
