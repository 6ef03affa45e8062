//! A stream's reader: decodes what the client sends. Poses (binary pose frames or
//! JSON text) go into the one-slot mailbox, latest pose wins; writers' updates are
//! applied and answered here, so that moving objects never waits for a cull; malformed
//! messages get an error frame, and a flood of them, an over-long message or an idle
//! client end the stream.

use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use axum::extract::ws::{Message, WebSocket};
use futures_util::StreamExt;
use futures_util::stream::SplitStream;
use glam::Vec3;
use homcull_proto::frame::{ErrorFrame, Frame};
use tokio::sync::{Mutex, mpsc};

use super::frames::{parse_frame, parse_text};
use super::liveness::Liveness;
use super::sink::{Sink, send, send_text};
use super::{MAX_BAD_MESSAGES, Mailbox, writer};
use crate::motion::MotionEstimator;

/// What a reader shares with its stream's sender.
pub(super) struct Reader {
    pub mailbox: Arc<Mailbox>,
    pub liveness: Arc<Liveness>,
    pub sink: Arc<Mutex<Sink>>,
    /// The server's frame counter for this client (writers' replies take numbers).
    pub counter: Arc<AtomicU32>,
    pub writer: writer::Writer,
    /// Error reports for the sender to send (full: the client is not reading).
    pub err_tx: mpsc::Sender<ErrorFrame>,
    pub idle: Duration,
    pub send_timeout: Duration,
}

/// Reads until the client goes, closes, idles or misbehaves: why, and the rest of the
/// socket's stream (to read the client's close after ours).
pub(super) async fn read(
    mut incoming: SplitStream<WebSocket>,
    r: Reader,
) -> (ReaderEnd, SplitStream<WebSocket>) {
    let Reader {
        mailbox,
        liveness,
        sink,
        counter,
        writer,
        err_tx,
        idle,
        send_timeout,
    } = r;
    let mut bad = 0u32;
    let mut motion = MotionEstimator::default();
    let mut idle_at = tokio::time::Instant::now() + idle;
    let end = loop {
        let msg = match tokio::time::timeout_at(idle_at, incoming.next()).await {
            Err(_) => break ReaderEnd::Idle,
            Ok(None) => break ReaderEnd::Gone,
            Ok(Some(msg)) => msg,
        };
        let parsed = match msg {
            Ok(Message::Binary(b)) => {
                let decoded = Frame::decode(&b);
                if let Ok(Frame::Transforms(t)) = &decoded {
                    idle_at = tokio::time::Instant::now() + idle;
                    bad = 0;
                    let seq = counter.fetch_add(1, Ordering::Relaxed).wrapping_add(1);
                    let reply = writer.apply_frame(seq, t).await;
                    if send(&sink, reply, send_timeout).await.is_err() {
                        break ReaderEnd::Gone;
                    }
                    continue;
                }
                parse_frame(decoded)
            }
            Ok(Message::Text(t)) if writer::is_update(&t) => {
                idle_at = tokio::time::Instant::now() + idle;
                let (reply, malformed) = writer.apply(&t).await;
                bad = if malformed { bad + 1 } else { 0 };
                if send_text(&sink, "transforms", reply, send_timeout)
                    .await
                    .is_err()
                {
                    break ReaderEnd::Gone;
                }
                if bad >= MAX_BAD_MESSAGES {
                    break ReaderEnd::TooManyBad;
                }
                continue;
            }
            Ok(Message::Text(t)) => parse_text(&t),
            Ok(Message::Close(_)) => break ReaderEnd::ClientClosed,
            Ok(Message::Pong(_)) => {
                liveness.ponged();
                continue;
            }
            // The library reports an over-long message or frame only by its text.
            Err(e) if e.to_string().contains("too long") => break ReaderEnd::TooLong,
            Err(_) => break ReaderEnd::Gone,
            Ok(_) => continue, // ping/pong are answered by the library
        };
        idle_at = tokio::time::Instant::now() + idle;
        match parsed {
            Ok(mut p) => {
                bad = 0;
                motion.observe(Instant::now(), Vec3::from(p.pose.position));
                p.velocity = motion.velocity();
                mailbox.put(p);
            }
            Err(e) => {
                bad += 1;
                metrics::counter!("homcull_ws_bad_frames_total").increment(1);
                // A full error channel means the client is not reading: drop the report.
                let _ = err_tx.try_send(e);
                if bad >= MAX_BAD_MESSAGES {
                    break ReaderEnd::TooManyBad;
                }
            }
        }
    };
    (end, incoming)
}

/// Why a client's reader stopped.
pub(super) enum ReaderEnd {
    /// The client sent a close frame.
    ClientClosed,
    /// The connection ended or failed.
    Gone,
    /// Nothing arrived for the idle timeout.
    Idle,
    /// A message over [`super::MAX_CLIENT_MESSAGE`].
    TooLong,
    /// [`MAX_BAD_MESSAGES`] malformed messages in a row.
    TooManyBad,
}

impl ReaderEnd {
    /// The close frame to send, if the connection can still take one.
    pub(super) fn close(self) -> Option<(u16, &'static str)> {
        match self {
            ReaderEnd::ClientClosed => Some((1000, "bye")),
            ReaderEnd::Gone => None,
            ReaderEnd::Idle => Some((1008, "idle for too long")),
            ReaderEnd::TooLong => Some((1009, "message too big")),
            ReaderEnd::TooManyBad => Some((1008, "too many malformed messages")),
        }
    }
}
