//! What a request must show in its headers before its body is read: the API token on
//! writes (uploads, deletes), an allowed `Origin` on writes and WebSocket upgrades,
//! and `Content-Type: application/json` on the JSON routes, so that a cross-site
//! `text/plain` form cannot queue work. They run as route layers (the upgrade checks
//! in its handler), ahead of any body extractor: a refused request costs no body read.
//!
//! Origins: a request without `Origin` (curl, SDKs, other servers) is not a browser's
//! and passes. A browser's passes when its origin's host name is the `Host` it asked
//! (ports are not compared, so a proxy that forwards `Host` without the port keeps
//! working), or when it is listed in `Config::allowed_origins` (`*` allows any).

use std::hash::BuildHasher;
use std::sync::OnceLock;

use axum::extract::{Request, State};
use axum::http::{HeaderMap, Method, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};

use super::config::AuthScope;
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
        let checked = check_origin(req.headers(), &state.config.allowed_origins)
            .and_then(|()| check_token(&state, req.headers()));
        if let Err(e) = checked {
            return e.into_response();
        }
    }
    next.run(req).await
}

/// Refuses (403) a browser request from an origin that is neither this host nor
/// allowed.
pub fn check_origin(headers: &HeaderMap, allowed: &[String]) -> Result<(), ApiError> {
    let Some(origin) = headers.get(header::ORIGIN) else {
        return Ok(());
    };
    let origin = origin.to_str().unwrap_or("");
    let listed = allowed
        .iter()
        .any(|a| a == "*" || a.trim_end_matches('/').eq_ignore_ascii_case(origin));
    let host = headers
        .get(header::HOST)
        .and_then(|h| h.to_str().ok())
        .map(host_name);
    let same_host = origin
        .split_once("://")
        .map(|(_, rest)| host_name(rest.split('/').next().unwrap_or("")))
        .is_some_and(|o| !o.is_empty() && host.is_some_and(|h| h.eq_ignore_ascii_case(o)));
    if listed || same_host {
        Ok(())
    } else {
        Err(ApiError::new(
            StatusCode::FORBIDDEN,
            "forbidden_origin",
            format!("requests from origin `{origin}` are not allowed here (see --allowed-origin)"),
        ))
    }
}

/// The host name of `host[:port]` or `[v6]:port`.
fn host_name(authority: &str) -> &str {
    if let Some(rest) = authority.strip_prefix('[') {
        return rest.split(']').next().unwrap_or("");
    }
    authority.rsplit_once(':').map_or(authority, |(h, _)| h)
}

/// With `--auth cull`, refuses culls without the token.
pub async fn require_token_on_culls(
    State(state): State<AppState>,
    req: Request,
    next: Next,
) -> Response {
    if state.config.auth == AuthScope::Cull {
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
            match state.config.auth {
                AuthScope::Writes => {
                    "this server needs `Authorization: Bearer TOKEN` for uploads and deletes"
                }
                AuthScope::Cull => "this server needs `Authorization: Bearer TOKEN`",
            },
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
    fn origins() {
        let headers = |origin: Option<&str>, host: &str| {
            let mut h = HeaderMap::new();
            h.insert(header::HOST, host.parse().unwrap());
            if let Some(o) = origin {
                h.insert(header::ORIGIN, o.parse().unwrap());
            }
            h
        };
        let none: Vec<String> = vec![];
        assert!(check_origin(&headers(None, "a.example:8080"), &none).is_ok());
        assert!(
            check_origin(
                &headers(Some("http://a.example:8080"), "a.example:8080"),
                &none
            )
            .is_ok()
        );
        assert!(check_origin(&headers(Some("https://a.example"), "a.example"), &none).is_ok());
        assert!(check_origin(&headers(Some("http://[::1]:80"), "[::1]:8080"), &none).is_ok());
        let evil = headers(Some("https://evil.example"), "a.example:8080");
        assert_eq!(
            check_origin(&evil, &none).unwrap_err().status,
            StatusCode::FORBIDDEN
        );
        assert!(check_origin(&headers(Some("null"), "a.example"), &none).is_err());
        assert!(check_origin(&evil, &["https://evil.example".into()]).is_ok());
        assert!(check_origin(&evil, &["*".into()]).is_ok());
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
