//! The server's error type: every failure becomes `{"error": {"code", "message"}}`
//! with the right status, and is logged once here with its detail.

use axum::Json;
use axum::http::StatusCode;
use axum::response::{IntoResponse, Response};
use homcull_proto::ErrorBody;

/// An error answered to a client.
#[derive(Debug, Clone, PartialEq)]
pub struct ApiError {
    pub status: StatusCode,
    pub code: &'static str,
    pub message: String,
}

impl ApiError {
    pub fn new(status: StatusCode, code: &'static str, message: impl Into<String>) -> Self {
        ApiError {
            status,
            code,
            message: message.into(),
        }
    }

    pub fn bad_request(code: &'static str, message: impl Into<String>) -> Self {
        Self::new(StatusCode::BAD_REQUEST, code, message)
    }

    pub fn unknown_scene(id: &str) -> Self {
        Self::new(
            StatusCode::NOT_FOUND,
            "unknown_scene",
            format!("no scene with id `{id}` (GET /v1/scenes lists them)"),
        )
    }

    pub fn overloaded(message: impl Into<String>) -> Self {
        Self::new(StatusCode::SERVICE_UNAVAILABLE, "overloaded", message)
    }

    pub fn internal(message: impl Into<String>) -> Self {
        Self::new(StatusCode::INTERNAL_SERVER_ERROR, "internal", message)
    }

    /// Parses a JSON body with serde's own message (line and column) on failure.
    pub fn parse_json<T: serde::de::DeserializeOwned>(body: &[u8]) -> Result<T, ApiError> {
        serde_json::from_slice(body)
            .map_err(|e| Self::bad_request("malformed_json", format!("request body: {e}")))
    }
}

impl std::fmt::Display for ApiError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} ({}): {}", self.code, self.status, self.message)
    }
}

impl IntoResponse for ApiError {
    fn into_response(self) -> Response {
        if self.status.is_server_error() {
            tracing::warn!(code = self.code, "{}", self.message);
        } else {
            tracing::debug!(code = self.code, "{}", self.message);
        }
        (self.status, Json(ErrorBody::new(self.code, self.message))).into_response()
    }
}

impl From<homcull_engine::dynamic::TransformError> for ApiError {
    fn from(e: homcull_engine::dynamic::TransformError) -> Self {
        use homcull_engine::dynamic::TransformError as E;
        let (status, code) = match e {
            E::TooMany { .. } => (StatusCode::PAYLOAD_TOO_LARGE, "too_many_objects"),
            E::UnknownObject { .. } => (StatusCode::BAD_REQUEST, "unknown_object"),
            E::Repeated { .. } | E::Invalid { .. } | E::SharedVertices { .. } | E::Horizon(_) => {
                (StatusCode::BAD_REQUEST, "invalid_transform")
            }
        };
        Self::new(status, code, e.to_string())
    }
}

impl From<homcull_engine::camera::PoseError> for ApiError {
    fn from(e: homcull_engine::camera::PoseError) -> Self {
        Self::bad_request("invalid_pose", e.to_string())
    }
}

impl From<homcull_proto::InvalidOptions> for ApiError {
    fn from(e: homcull_proto::InvalidOptions) -> Self {
        Self::bad_request("invalid_options", e.to_string())
    }
}

impl From<homcull_engine::cull::CullError> for ApiError {
    fn from(e: homcull_engine::cull::CullError) -> Self {
        use homcull_engine::cull::CullError;
        match e {
            CullError::Options(o) => o.into(),
            CullError::Unsupported { .. } => Self::bad_request("method_unsupported", e.to_string()),
            CullError::RegionUnsupported { .. } => {
                Self::bad_request("region_unsupported", e.to_string())
            }
            CullError::Backend { .. } => Self::internal(e.to_string()),
        }
    }
}
