//! The browser viewer, embedded in the binary (`web/dist`, built from `web/` with npm
//! and committed), so that `cargo run --release` serves it with no extra step.

use axum::http::{StatusCode, Uri, header};
use axum::response::{IntoResponse, Response};
use rust_embed::RustEmbed;

#[derive(RustEmbed)]
#[folder = "../../web/dist"]
struct WebDist;

/// Serves `web/dist/<path>`, `index.html` for `/`; unknown paths fall through to a JSON 404.
pub async fn serve(uri: Uri) -> Response {
    let path = uri.path().trim_start_matches('/');
    let path = if path.is_empty() { "index.html" } else { path };
    match WebDist::get(path) {
        Some(file) => {
            let mime = mime_guess::from_path(path).first_or_octet_stream();
            let cache = if path == "index.html" {
                "no-cache"
            } else {
                "public, max-age=300"
            };
            (
                [
                    (header::CONTENT_TYPE, mime.as_ref().to_string()),
                    (header::CACHE_CONTROL, cache.to_string()),
                ],
                file.data,
            )
                .into_response()
        }
        None => super::error::ApiError::new(
            StatusCode::NOT_FOUND,
            "not_found",
            format!("no such route or file `/{path}` (see /docs)"),
        )
        .into_response(),
    }
}
