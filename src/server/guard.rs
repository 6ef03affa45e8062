//! What a request must show in its headers before its body is read: the API token on
//! writes (uploads, deletes), and `Content-Type: application/json` on the JSON routes,
//! so that a cross-site `text/plain` form cannot queue work. Both run as route layers,
//! ahead of the handler's body extractor: a refused request costs no body read.

use std::hash::BuildHasher;
use std::sync::OnceLock;

use axum::extract::{Request, State};
use axum::http::{HeaderMap, Method, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use super::error::ApiError;
use super::state::AppState;

/// Refuses uploads and deletes without the right `Authorization: Bearer TOKEN` when the
/// server has a token; reads are let through.
pub async fn require_token_on_writes(
    State(state): State<AppState>,
    req: Request,
    next: Next,
) -> Response {
    let write = matches!(*req.method(), Method::POST | Method::PUT | Method::DELETE);
    if write {
        if let Err(e) = check_token(&state, req.headers()) {
            return e.into_response();
        }
    }
    next.run(req).await
}

/// Refuses a POST whose body is not declared as JSON (415).
pub async fn require_json(req: Request, next: Next) -> Response {
    if req.method() == Method::POST && !is_json(req.headers()) {
        return ApiError::new(
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            "unsupported_media_type",
            "send the request body as `Content-Type: application/json`",
        )
        .into_response();
    }
    next.run(req).await
}

fn is_json(headers: &HeaderMap) -> bool {
    headers
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.split(';').next())
        .is_some_and(|t| t.trim().eq_ignore_ascii_case("application/json"))
}

/// Ok when the server has no token or the request carries it.
pub fn check_token(state: &AppState, headers: &HeaderMap) -> Result<(), ApiError> {
    let Some(token) = &state.config.api_token else {
        return Ok(());
    };
    let given = headers
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "));
    if given.is_some_and(|g| tokens_match(g.as_bytes(), token.as_bytes())) {
        Ok(())
    } else {
        Err(ApiError::new(
            StatusCode::UNAUTHORIZED,
            "unauthorized",
            "this server needs `Authorization: Bearer TOKEN` for uploads and deletes",
        ))
    }
}

/// Compares two secrets in time that depends on neither their contents nor the
/// expected one's length: both are reduced to 64-bit keyed digests (SipHash with a
/// key drawn at random once per process) compared without an early exit; only equal
/// digests are then compared in full.
pub fn tokens_match(given: &[u8], expected: &[u8]) -> bool {
    static KEY: OnceLock<std::collections::hash_map::RandomState> = OnceLock::new();
    let key = KEY.get_or_init(Default::default);
    let (a, b) = (key.hash_one(given), key.hash_one(expected));
    (a ^ b == 0) && given == expected
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_match_only_when_equal() {
        assert!(tokens_match(b"s3cret-token", b"s3cret-token"));
        assert!(!tokens_match(b"s3cret-tokem", b"s3cret-token"));
        assert!(!tokens_match(b"s3cret", b"s3cret-token"));
        assert!(!tokens_match(b"", b"s3cret-token"));
        assert!(!tokens_match(b"s3cret-token-and-more", b"s3cret-token"));
    }

    #[test]
    fn json_content_types() {
        let mut h = HeaderMap::new();
        assert!(!is_json(&h));
        for (v, ok) in [
            ("application/json", true),
            ("application/json; charset=utf-8", true),
            ("Application/JSON", true),
            ("text/plain", false),
            ("application/x-www-form-urlencoded", false),
        ] {
            h.insert(header::CONTENT_TYPE, v.parse().unwrap());
            assert_eq!(is_json(&h), ok, "{v}");
        }
    }
}
