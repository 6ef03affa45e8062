//! Writers on a stream: a client may move objects over its WebSocket instead of
//! `POST /v1/scenes/{id}/transforms`, one text message per update, without an HTTP
//! request each:
//!
//! ```json
//! {"seq": 7, "transforms": {"objects": [{"id": 12, "translation": [1, 0, 0]}], "horizon_ms": 100}}
//! ```
//!
//! checked and applied as the REST route does (all or nothing), and answered with a
//! text message `{"transforms": {"seq": 7, "version": 3, "applied": 1}}` or
//! `{"transforms": {"seq": 7, "error": {"code", "message"}}}` (the REST error codes;
//! seq 0 when the message did not parse). When the server has an API token, only a
//! stream whose upgrade request carried it may write (`unauthorized` otherwise).

use std::sync::{Arc, Mutex};

use homcull_proto::TransformsRequest;
use serde::Deserialize;

use crate::core::dynamic::Dynamics;
use crate::server::error::ApiError;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct WriterMessage {
    seq: u32,
    transforms: TransformsRequest,
}

/// Whether a text message is a writer's (pose messages never name `transforms`).
pub(super) fn is_update(text: &str) -> bool {
    text.contains("\"transforms\"")
}

/// What a stream may do with updates.
#[derive(Clone)]
pub(super) struct Writer {
    pub(super) dynamics: Arc<Mutex<Dynamics>>,
    /// The upgrade carried the write token (or the server needs none).
    pub(super) may_write: bool,
    pub(super) max_objects: usize,
}

impl Writer {
    /// Applies one update message and returns the reply to send, and whether the
    /// message was malformed.
    pub(super) async fn apply(&self, text: &str) -> (String, bool) {
        let m: WriterMessage = match serde_json::from_str(text) {
            Ok(m) => m,
            Err(e) => {
                let e = ApiError::bad_request("malformed_json", format!("transforms message: {e}"));
                return (refused(0, &e), true);
            }
        };
        if !self.may_write {
            let e = ApiError::new(
                axum::http::StatusCode::UNAUTHORIZED,
                "unauthorized",
                "this server needs `Authorization: Bearer TOKEN` on the stream's upgrade request to move objects",
            );
            return (refused(m.seq, &e), false);
        }
        let (dynamics, max) = (self.dynamics.clone(), self.max_objects);
        let applied = m.transforms.objects.len() as u32;
        // Blocking: the first update of a scene indexes its vertex ranges.
        let res = tokio::task::spawn_blocking(move || {
            let mut d = dynamics.lock().unwrap_or_else(|p| p.into_inner());
            d.apply(&m.transforms, max)
        })
        .await;
        let reply = match res {
            Ok(Ok(version)) => {
                metrics::counter!("homcull_object_transforms_total").increment(applied as u64);
                serde_json::json!({"transforms": {"seq": m.seq, "version": version, "applied": applied}})
                    .to_string()
            }
            Ok(Err(e)) => refused(m.seq, &ApiError::from(e)),
            Err(e) => refused(
                m.seq,
                &ApiError::internal(format!("transforms task failed: {e}")),
            ),
        };
        (reply, false)
    }
}

fn refused(seq: u32, e: &ApiError) -> String {
    serde_json::json!({"transforms": {"seq": seq, "error": {"code": e.code, "message": e.message}}})
        .to_string()
}
