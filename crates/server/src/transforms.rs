//! `POST /v1/scenes/{id}/transforms`: writers move a scene's objects. An update is
//! checked whole and applied whole (`core::dynamic::Dynamics::apply`), makes the next
//! scene version, and reaches the next cull of the scene: the worker's engine moves to
//! the latest version when it starts a batch, so culls never wait for writers, nor
//! writers for culls. With `--state journal` (the default) each update is journaled
//! before it is applied and acknowledged ([`super::journal`]), so a restart serves the
//! same placements at the same version; with `--state memory` a restart starts again
//! from the file.

use std::sync::Arc;

use axum::Json;
use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::{Path, State};
use homcull_proto::{TransformsRequest, TransformsResponse};

use super::error::ApiError;
use super::routes::body_error;
use super::state::AppState;
use super::writes::Writes;

/// Moves objects: new placements (relative to the loaded scene) and declared motion,
/// all applied or none; answers the scene version they make.
#[utoipa::path(post, path = "/v1/scenes/{id}/transforms", params(("id" = String, Path, description = "scene id")),
    request_body = TransformsRequest,
    responses((status = 200, body = TransformsResponse), (status = 400, body = homcull_proto::ErrorBody),
        (status = 401, body = homcull_proto::ErrorBody), (status = 404, body = homcull_proto::ErrorBody),
        (status = 413, body = homcull_proto::ErrorBody)))]
pub async fn transforms(
    State(state): State<AppState>,
    Path(id): Path<String>,
    body: Result<Bytes, BytesRejection>,
) -> Result<Json<TransformsResponse>, ApiError> {
    let req: TransformsRequest = ApiError::parse_json(&body.map_err(body_error)?)?;
    let scene = state.scene(&id)?;
    let applied = req.objects.len() as u32;
    let version = apply(
        scene.writes.clone(),
        req,
        state.config.max_transform_objects,
    )
    .await?;
    Ok(Json(TransformsResponse { version, applied }))
}

/// Applies one update to a scene's placements (at most `max_objects` objects): the
/// version it made, or why it was refused. The one path of every writer, REST or
/// stream.
pub async fn apply(
    writes: Arc<Writes>,
    req: TransformsRequest,
    max_objects: usize,
) -> Result<u64, ApiError> {
    let applied = req.objects.len() as u64;
    // Blocking: the first update of a scene indexes its vertex ranges, and the journal
    // flushes to disk.
    let version = tokio::task::spawn_blocking(move || writes.apply(&req, max_objects))
        .await
        .map_err(|e| ApiError::internal(format!("transforms task failed: {e}")))??;
    metrics::counter!("homcull_object_transforms_total").increment(applied);
    Ok(version)
}
