//! Writers on a stream: a client may move objects over its WebSocket instead of
//! `POST /v1/scenes/{id}/transforms`, without an HTTP request each:
//!
//! - a text message per update,
//!   `{"seq": 7, "transforms": {"objects": [{"id": 12, "translation": [1, 0, 0]}], "horizon_ms": 100}}`,
//!   answered with a text message `{"transforms": {"seq": 7, "version": 3, "applied": 1}}`
//!   or `{"transforms": {"seq": 7, "error": {"code", "message"}}}` (the REST error codes;
//!   seq 0 when the message did not parse);
//! - or a binary Transforms frame (kind 8, `homcull_proto::frame::TransformsFrame`: no
//!   JSON to parse, for high rates), answered with an Applied frame (kind 9: the
//!   version) or an Error frame (`invalid_transform`, `unauthorized`), `ack` the
//!   update's `seq`.
//!
//! Either is checked and applied as the REST route does (all or nothing). When the
//! server has an API token, only a stream whose upgrade request carried it may write.

use std::sync::Arc;

use homcull_proto::TransformsRequest;
use homcull_proto::frame::{Applied, ErrorCode, ErrorFrame, Frame, TransformsFrame};
use serde::Deserialize;

use crate::error::ApiError;
use crate::transforms;
use crate::writes::Writes;

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
    pub(super) writes: Arc<Writes>,
    /// The upgrade carried the write token (or the server needs none).
    pub(super) may_write: bool,
    pub(super) max_objects: usize,
}

impl Writer {
    /// Applies one update text message and returns the reply to send, and whether the
    /// message was malformed.
    pub(super) async fn apply(&self, text: &str) -> (String, bool) {
        let m: WriterMessage = match serde_json::from_str(text) {
            Ok(m) => m,
            Err(e) => {
                let e = ApiError::bad_request("malformed_json", format!("transforms message: {e}"));
                return (refused(0, &e), true);
            }
        };
        let reply = match self.apply_request(m.transforms).await {
            Ok((version, applied)) => serde_json::json!(
                {"transforms": {"seq": m.seq, "version": version, "applied": applied}}
            )
            .to_string(),
            Err(e) => refused(m.seq, &e),
        };
        (reply, false)
    }

    /// Applies a binary update and returns the frame (server counter `seq`) to answer.
    pub(super) async fn apply_frame(&self, seq: u32, t: &TransformsFrame) -> Frame {
        match self.apply_request(t.to_request()).await {
            Ok((version, applied)) => Frame::Applied(Applied {
                seq,
                ack: t.seq,
                version,
                applied,
            }),
            Err(e) => Frame::Error(ErrorFrame {
                seq,
                ack: t.seq,
                code: match e.code {
                    "unauthorized" => ErrorCode::Unauthorized,
                    "internal" => ErrorCode::Internal,
                    // Not on disk, not applied: worth sending again later.
                    "state_unavailable" => ErrorCode::Overloaded,
                    _ => ErrorCode::InvalidTransform,
                },
                message: e.message,
            }),
        }
    }

    /// The version an update made and the objects it moved, or why it was refused.
    async fn apply_request(&self, req: TransformsRequest) -> Result<(u64, u32), ApiError> {
        if !self.may_write {
            return Err(ApiError::new(
                axum::http::StatusCode::UNAUTHORIZED,
                "unauthorized",
                "this server needs `Authorization: Bearer TOKEN` on the stream's upgrade request to move objects",
            ));
        }
        let applied = req.objects.len() as u32;
        let version = transforms::apply(self.writes.clone(), req, self.max_objects).await?;
        Ok((version, applied))
    }
}

fn refused(seq: u32, e: &ApiError) -> String {
    serde_json::json!({"transforms": {"seq": seq, "error": {"code": e.code, "message": e.message}}})
        .to_string()
}
