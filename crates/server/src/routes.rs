//! REST handlers. Each parses its own input (so that bad input gets our JSON error,
//! not a framework's plain text), checks it, and leaves culling to the cull worker.

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use axum::Json;
use axum::body::Bytes;
use axum::extract::rejection::{BytesRejection, QueryRejection};
use axum::extract::{Path, Query, State};
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use homcull_engine::engine::Backend;
use homcull_proto::{
    BatchRequest, BatchResponse, CullRequest, CullResponse, LodThresholds, ObjectList, SceneInfo,
    SceneList,
};
use serde::Deserialize;

use super::error::ApiError;
use super::state::{AppState, GlbSource, SceneEntry};
use super::writes::Durability;
use homcull_engine::camera::{Camera, stereo};
use homcull_engine::cull::PoseResult;
use homcull_engine::dynamic::marks;
use homcull_engine::lod;
use homcull_engine::scene::load_glb_bytes_within;

/// Liveness: the process answers.
#[utoipa::path(get, path = "/healthz", responses((status = 200, description = "alive")))]
pub async fn healthz() -> Json<serde_json::Value> {
    Json(serde_json::json!({"status": "ok"}))
}

/// Readiness: scenes loaded, the backend ready (`backend`: `gpu`, `cpu` for the
/// native CPU backend, `reference`; `adapter` in words), the worker running.
#[utoipa::path(get, path = "/readyz", responses(
    (status = 200, description = "ready; names the adapter"),
    (status = 503, description = "starting, shutting down, or the cull worker has stopped")))]
pub async fn readyz(State(state): State<AppState>) -> Response {
    let worker_running = !state.worker.health.stopped();
    let ready = state.ready.load(Ordering::SeqCst) && !*state.shutdown.borrow() && worker_running;
    let body = serde_json::json!({
        "ready": ready,
        "worker": if worker_running { "running" } else { "stopped" },
        "worker_restarts": state.worker.health.restarts(),
        "adapter": state.adapter,
        "backend": state.backend.name(),
        "cpu_fallback": matches!(state.backend, Backend::Reference),
        "scenes": state.scene_list().len(),
        "state": state_status(&state),
    });
    let status = if ready {
        StatusCode::OK
    } else {
        StatusCode::SERVICE_UNAVAILABLE
    };
    (status, Json(body)).into_response()
}

/// Where placements are kept, for `/readyz`: the backend and the scenes whose journal
/// cannot be used (their updates are refused).
fn state_status(state: &AppState) -> serde_json::Value {
    let scenes = state.scenes.read().unwrap_or_else(|p| p.into_inner());
    let broken: Vec<&str> = scenes
        .values()
        .filter(|s| matches!(s.writes.durability, Durability::Broken(_)))
        .map(|s| s.info.id.as_str())
        .collect();
    serde_json::json!({
        "backend": if state.journals.is_some() { "journal" } else { "memory" },
        "connected": broken.is_empty(),
        "unavailable_scenes": broken,
    })
}

/// Prometheus metrics in the text exposition format.
#[utoipa::path(get, path = "/metrics", responses((status = 200, description = "Prometheus text format")))]
pub async fn metrics(State(state): State<AppState>) -> Response {
    (
        [(header::CONTENT_TYPE, "text/plain; version=0.0.4")],
        state.metrics.render(),
    )
        .into_response()
}

/// Lists resident scenes.
#[utoipa::path(get, path = "/v1/scenes", responses((status = 200, body = SceneList)))]
pub async fn list_scenes(State(state): State<AppState>) -> Json<SceneList> {
    Json(SceneList {
        scenes: state.scene_list(),
    })
}

#[derive(Debug, Deserialize, utoipa::IntoParams)]
pub struct UploadQuery {
    /// Name of the scene (default `upload`).
    pub name: Option<String>,
    /// Objects to mark dynamic, besides those the file marks: comma-separated object
    /// names, or prefixes ending in `*` (e.g. `car_*,door_1`); each must match.
    pub dynamic: Option<String>,
}

pub(super) fn body_error(e: BytesRejection) -> ApiError {
    if e.status() == StatusCode::PAYLOAD_TOO_LARGE {
        ApiError::new(
            e.status(),
            "too_large",
            format!("request body too large: {e}"),
        )
    } else {
        ApiError::new(e.status(), "bad_body", e.body_text())
    }
}

/// Uploads a GLB; it is stored, preprocessed and made resident.
#[utoipa::path(post, path = "/v1/scenes", params(UploadQuery),
    request_body(content = Vec<u8>, content_type = "model/gltf-binary"),
    responses((status = 201, body = SceneInfo), (status = 400, body = homcull_proto::ErrorBody),
        (status = 401, body = homcull_proto::ErrorBody), (status = 413, body = homcull_proto::ErrorBody)))]
pub async fn upload_scene(
    State(state): State<AppState>,
    query: Result<Query<UploadQuery>, QueryRejection>,
    body: Result<Bytes, BytesRejection>,
) -> Result<(StatusCode, Json<SceneInfo>), ApiError> {
    let Query(q) = query.map_err(|e| ApiError::bad_request("bad_query", e.body_text()))?;
    let body = body.map_err(body_error)?;
    let name = q.name.unwrap_or_else(|| "upload".into());
    if name.is_empty() || name.chars().count() > 200 || name.chars().any(char::is_control) {
        return Err(ApiError::bad_request(
            "bad_name",
            "name must be 1 to 200 printable characters",
        ));
    }
    if body.is_empty() {
        return Err(ApiError::bad_request(
            "invalid_glb",
            "the body is empty; send a GLB file",
        ));
    }
    let dynamic = match q.dynamic.as_deref() {
        None => Vec::new(),
        Some(list) => marks::parse_patterns(list)
            .map_err(|e| ApiError::bad_request("bad_dynamic", e.to_string()))?,
    };
    let st = state.clone();
    let limits = state.config.load_limits();
    let claim = Arc::new(UploadClaim::default());
    let task_claim = claim.clone();
    let task = tokio::task::spawn_blocking(move || -> Result<Arc<SceneEntry>, ApiError> {
        let mut scene = load_glb_bytes_within(&body, &name, &limits)
            .map_err(|e| ApiError::bad_request("invalid_glb", format!("not a usable GLB: {e}")))?;
        if scene.objects.is_empty() {
            return Err(ApiError::bad_request(
                "invalid_glb",
                "the file has no mesh-bearing nodes",
            ));
        }
        marks::mark(&mut scene, &dynamic)
            .map_err(|e| ApiError::bad_request("bad_dynamic", e.to_string()))?;
        st.create(&name, &body, &dynamic, scene, || task_claim.store())
            .map_err(|e| ApiError::internal(format!("storing the scene: {e}")))?
            .ok_or_else(|| load_timeout(0)) // not stored: the client was answered already
    });
    let budget = Duration::from_secs(state.config.load_timeout_s);
    let _abandon_on_drop = AbandonOnDrop(claim.clone());
    tokio::pin!(task);
    let joined = match tokio::time::timeout(budget, &mut task).await {
        Ok(joined) => joined,
        // Over budget: refuse it, unless storing has begun (then it is as good as done).
        Err(_) if claim.abandon() => return Err(load_timeout(budget.as_secs())),
        Err(_) => task.await,
    };
    let entry = joined.map_err(|e| ApiError::internal(format!("upload task failed: {e}")))??;
    Ok((StatusCode::CREATED, Json(entry.info.clone())))
}

/// Whether an upload still in its load may be stored: whichever of the load (about to
/// store) and the handler (over its time budget, or its client gone) comes first wins.
#[derive(Default)]
struct UploadClaim(std::sync::atomic::AtomicU8);

impl UploadClaim {
    const OPEN: u8 = 0;
    const STORING: u8 = 1;
    const ABANDONED: u8 = 2;

    /// The load's side: true if it may store.
    fn store(&self) -> bool {
        self.swap_from_open(Self::STORING)
    }

    /// The handler's side: true if the upload will not be stored.
    fn abandon(&self) -> bool {
        self.swap_from_open(Self::ABANDONED) || self.0.load(Ordering::SeqCst) == Self::ABANDONED
    }

    fn swap_from_open(&self, to: u8) -> bool {
        self.0
            .compare_exchange(Self::OPEN, to, Ordering::SeqCst, Ordering::SeqCst)
            .is_ok()
    }
}

/// Abandons an upload whose request is dropped (its client gone, the request timeout)
/// before its load has begun to store it.
struct AbandonOnDrop(Arc<UploadClaim>);

impl Drop for AbandonOnDrop {
    fn drop(&mut self) {
        self.0.abandon();
    }
}

fn load_timeout(secs: u64) -> ApiError {
    ApiError::new(
        StatusCode::UNPROCESSABLE_ENTITY,
        "load_timeout",
        format!(
            "parsing and indexing the scene took longer than the server allows ({secs} s); \
             it was not stored"
        ),
    )
}

/// One scene's info.
#[utoipa::path(get, path = "/v1/scenes/{id}", params(("id" = String, Path, description = "scene id")),
    responses((status = 200, body = SceneInfo), (status = 404, body = homcull_proto::ErrorBody)))]
pub async fn get_scene(
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<SceneInfo>, ApiError> {
    Ok(Json(state.scene(&id)?.info.clone()))
}

/// The object table: id, name, world AABB where each object is now and where its file
/// puts it, its placement, triangles, occluder flag; all at the `version` it names.
#[utoipa::path(get, path = "/v1/scenes/{id}/objects", params(("id" = String, Path, description = "scene id")),
    responses((status = 200, body = ObjectList), (status = 404, body = homcull_proto::ErrorBody)))]
pub async fn list_objects(
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<Json<ObjectList>, ApiError> {
    Ok(Json(state.scene(&id)?.object_list()))
}

/// The scene as GLB, for clients to draw (object IDs = mesh-bearing nodes in depth-first order).
#[utoipa::path(get, path = "/v1/scenes/{id}/glb", params(("id" = String, Path, description = "scene id")),
    responses((status = 200, content_type = "model/gltf-binary"), (status = 404, body = homcull_proto::ErrorBody)))]
pub async fn get_glb(
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<Response, ApiError> {
    let scene = state.scene(&id)?;
    let (body, len) = match &scene.glb {
        GlbSource::Memory(b) => (axum::body::Body::from(b.clone()), b.len() as u64),
        GlbSource::File(p) => {
            let file = tokio::fs::File::open(p)
                .await
                .map_err(|_| ApiError::unknown_scene(&id))?;
            let len = file
                .metadata()
                .await
                .map_err(|e| ApiError::internal(format!("reading the scene file: {e}")))?
                .len();
            (axum::body::Body::from_stream(file_chunks(file)), len)
        }
    };
    Ok((
        [
            (header::CONTENT_TYPE, "model/gltf-binary".to_string()),
            (header::CONTENT_LENGTH, len.to_string()),
        ],
        body,
    )
        .into_response())
}

/// A file as a stream of 64 KiB chunks, so a download holds one chunk in memory at a
/// time however large the file and however slow the client.
fn file_chunks(
    file: tokio::fs::File,
) -> impl futures_util::Stream<Item = std::io::Result<Bytes>> + Send {
    use tokio::io::AsyncReadExt;
    futures_util::stream::unfold(Some(file), |file| async move {
        let mut file = file?;
        let mut buf = vec![0u8; 64 << 10];
        match file.read(&mut buf).await {
            Ok(0) => None,
            Ok(n) => {
                buf.truncate(n);
                Some((Ok(Bytes::from(buf)), Some(file)))
            }
            Err(e) => Some((Err(e), None)),
        }
    })
}

/// Deletes an uploaded scene (the demo and `--scene` files stay).
#[utoipa::path(delete, path = "/v1/scenes/{id}", params(("id" = String, Path, description = "scene id")),
    responses((status = 204), (status = 401, body = homcull_proto::ErrorBody),
        (status = 404, body = homcull_proto::ErrorBody), (status = 409, body = homcull_proto::ErrorBody)))]
pub async fn delete_scene(
    State(state): State<AppState>,
    Path(id): Path<String>,
) -> Result<StatusCode, ApiError> {
    if state.scene(&id)?.read_only {
        return Err(ApiError::new(
            StatusCode::CONFLICT,
            "read_only",
            format!(
                "scene `{id}` is built in or was given with --scene at start; it cannot be deleted"
            ),
        ));
    }
    let st = state.clone();
    tokio::task::spawn_blocking(move || {
        let _changing = st.changes.lock().unwrap_or_else(|p| p.into_inner());
        let res = st.store.delete(&id);
        st.remove(&id);
        // Its id is never used again: its placements go with it.
        if let Some(Err(e)) = st.journals.as_ref().map(|j| j.remove(&id)) {
            tracing::warn!(%id, "removing a deleted scene's placement journal: {e}");
        }
        res
    })
    .await
    .map_err(|e| ApiError::internal(format!("delete task failed: {e}")))?
    .map_err(|e| ApiError::internal(format!("deleting the scene: {e}")))?;
    Ok(StatusCode::NO_CONTENT)
}

/// Refuses a request whose poses render more pixels in all than the server allows.
fn within_work_budget(state: &AppState, cams: &[Camera]) -> Result<(), ApiError> {
    // A region pose draws its maps, wider than its viewport (`core::region`).
    let pixels: u64 = cams.iter().map(homcull_engine::region::pixels).sum();
    let max = state.config.max_request_pixels;
    if pixels > max {
        return Err(ApiError::new(
            StatusCode::PAYLOAD_TOO_LARGE,
            "work_too_large",
            format!("the poses render {pixels} pixels in all; the limit is {max} per request"),
        ));
    }
    Ok(())
}

/// The answer to a pose seen by `eyes` (one camera, or a stereo pose's two) from the
/// results of its eyes: their union, with a level per visible object (the largest
/// projection over the eyes) when `lod` asks.
fn response(
    results: Vec<PoseResult>,
    eyes: &[Camera],
    scene: &SceneEntry,
    lod: Option<LodThresholds>,
) -> CullResponse {
    let r = PoseResult::union_of(results).expect("one result per eye");
    let lod = lod.map(|t| {
        let placed = scene.placements();
        lod::levels(eyes, &r.visible, |id| placed.bounds(id), &t)
    });
    CullResponse {
        visible: r.visible,
        lod,
        stats: r.stats,
    }
}

/// Culls one pose.
#[utoipa::path(post, path = "/v1/scenes/{id}/cull", params(("id" = String, Path, description = "scene id")),
    request_body = CullRequest,
    responses((status = 200, body = CullResponse), (status = 400, body = homcull_proto::ErrorBody),
        (status = 404, body = homcull_proto::ErrorBody), (status = 503, body = homcull_proto::ErrorBody)))]
pub async fn cull(
    State(state): State<AppState>,
    Path(id): Path<String>,
    body: Result<Bytes, BytesRejection>,
) -> Result<Json<CullResponse>, ApiError> {
    let req: CullRequest = ApiError::parse_json(&body.map_err(body_error)?)?;
    req.options.validate()?;
    let eyes = stereo::eyes(&req.pose)?;
    within_work_budget(&state, &eyes)?;
    let scene = state.scene(&id)?;
    let out = state
        .worker
        .cull(scene.engine.clone(), eyes.clone(), req.options)
        .await?;
    Ok(Json(response(out, &eyes, &scene, req.options.lod)))
}

/// Culls many poses in one GPU submission; results in pose order.
#[utoipa::path(post, path = "/v1/scenes/{id}/cull/batch", params(("id" = String, Path, description = "scene id")),
    request_body = BatchRequest,
    responses((status = 200, body = BatchResponse), (status = 400, body = homcull_proto::ErrorBody),
        (status = 404, body = homcull_proto::ErrorBody), (status = 413, body = homcull_proto::ErrorBody)))]
pub async fn cull_batch(
    State(state): State<AppState>,
    Path(id): Path<String>,
    body: Result<Bytes, BytesRejection>,
) -> Result<Json<BatchResponse>, ApiError> {
    let req: BatchRequest = ApiError::parse_json(&body.map_err(body_error)?)?;
    let max = state.config.max_batch;
    if req.poses.len() > max {
        return Err(ApiError::new(
            StatusCode::PAYLOAD_TOO_LARGE,
            "batch_too_large",
            format!("{} poses in one batch; the limit is {max}", req.poses.len()),
        ));
    }
    req.options.validate()?;
    let eyes = req
        .poses
        .iter()
        .enumerate()
        .map(|(i, p)| {
            stereo::eyes(p)
                .map_err(|e| ApiError::bad_request("invalid_pose", format!("pose {i}: {e}")))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let cams: Vec<Camera> = eyes.iter().flatten().cloned().collect();
    within_work_budget(&state, &cams)?;
    let scene = state.scene(&id)?;
    if cams.is_empty() {
        return Ok(Json(BatchResponse { results: vec![] }));
    }
    let mut out = state
        .worker
        .cull(scene.engine.clone(), cams, req.options)
        .await?
        .into_iter();
    let lod = req.options.lod;
    Ok(Json(BatchResponse {
        results: eyes
            .iter()
            .map(|e| response(out.by_ref().take(e.len()).collect(), e, &scene, lod))
            .collect(),
    }))
}

/// The occluders HOM renders for one pose.
#[derive(Debug, serde::Serialize, utoipa::ToSchema)]
pub struct OccluderList {
    /// Object IDs, nearest first (the order they are selected in).
    pub occluders: Vec<u32>,
    /// Their triangles together.
    pub triangles: u32,
    /// The server's occluder triangle budget per pose.
    pub budget: u32,
}

/// The occluders HOM selects for one pose (in-frustum occluders, nearest first, up to
/// the triangle budget): what the viewer's debug view paints blue.
#[utoipa::path(post, path = "/v1/scenes/{id}/occluders", params(("id" = String, Path, description = "scene id")),
    request_body = CullRequest,
    responses((status = 200, body = OccluderList),
        (status = 400, body = homcull_proto::ErrorBody), (status = 404, body = homcull_proto::ErrorBody)))]
pub async fn occluders(
    State(state): State<AppState>,
    Path(id): Path<String>,
    body: Result<Bytes, BytesRejection>,
) -> Result<Json<OccluderList>, ApiError> {
    let selection = with_pose_plan(&state, &id, body, u64::MAX, |_, p| p.occluders).await?;
    Ok(Json(OccluderList {
        occluders: selection.ids,
        triangles: selection.triangles,
        budget: state.config.budget,
    }))
}

/// Parses a `CullRequest` body, plans its pose on scene `id` as the cull worker would
/// (the server's occluder budget) and runs `f` on the plan off the async runtime: the
/// debug routes' shared part. Viewports over `max_pixels` are refused.
async fn with_pose_plan<T: Send + 'static>(
    state: &AppState,
    id: &str,
    body: Result<Bytes, BytesRejection>,
    max_pixels: u64,
    f: impl FnOnce(&homcull_engine::cull::PreparedScene, homcull_engine::cull::PosePlan) -> T
    + Send
    + 'static,
) -> Result<T, ApiError> {
    let req: CullRequest = ApiError::parse_json(&body.map_err(body_error)?)?;
    let cam = Camera::new(&req.pose)?;
    if cam.width as u64 * cam.height as u64 > max_pixels {
        return Err(ApiError::bad_request(
            "invalid_pose",
            format!("this view renders at most {max_pixels} pixels"),
        ));
    }
    let scene = state.scene(id)?;
    let prepared = scene
        .engine
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .prepared
        .clone();
    let budget = state.config.budget;
    tokio::task::spawn_blocking(move || {
        let mut settings = homcull_engine::cull::CullSettings::new(req.options, &prepared);
        settings.budget_triangles = budget;
        f(
            &prepared,
            homcull_engine::cull::plan(&prepared, &cam, &settings),
        )
    })
    .await
    .map_err(|e| ApiError::internal(format!("planning task failed: {e}")))
}

/// The largest viewport the pyramid view renders (it runs the CPU reference).
const PYRAMID_MAX_PIXELS: u64 = 1920 * 1080;

/// One level of the occlusion pyramid as a PNG data URL (opacity, white = covered).
#[derive(Debug, serde::Serialize, utoipa::ToSchema)]
pub struct PyramidLevel {
    pub level: u32,
    pub width: u32,
    pub height: u32,
    pub png: String,
}

/// The occlusion-map pyramid of one pose, for the viewer's debug panel.
///
/// Computed by the CPU reference of the occluder raster and pyramid passes (the GPU
/// passes are tested equal to it), beside the cull worker so culling is not held up.
#[utoipa::path(post, path = "/v1/scenes/{id}/pyramid", params(("id" = String, Path, description = "scene id")),
    request_body = CullRequest,
    responses((status = 200, description = "{\"levels\": [{\"level\", \"width\", \"height\", \"png\"}]}"),
        (status = 400, body = homcull_proto::ErrorBody), (status = 404, body = homcull_proto::ErrorBody)))]
pub async fn pyramid(
    State(state): State<AppState>,
    Path(id): Path<String>,
    body: Result<Bytes, BytesRejection>,
) -> Result<Json<serde_json::Value>, ApiError> {
    let levels = with_pose_plan(&state, &id, body, PYRAMID_MAX_PIXELS, |prepared, p| {
        use homcull_engine::reference::ReferenceBackend;
        use homcull_engine::reference::pyramid::{self, LevelLayout};
        let cam = &p.cam;
        let layout = LevelLayout::new(cam.width, cam.height);
        let (opacity, _depth) = pyramid::build(
            &layout,
            &ReferenceBackend::occluder_depth(&prepared.scene, &p),
        );
        (0..layout.levels())
            .map(|l| {
                let (w, h) = layout.dims[l];
                let start = layout.index(l, 0, 0);
                let pixels: Vec<u8> = opacity[start..start + (w * h) as usize]
                    .iter()
                    .map(|&o| (o.clamp(0.0, 1.0) * 255.0).round() as u8)
                    .collect();
                PyramidLevel {
                    level: l as u32,
                    width: w,
                    height: h,
                    png: png_data_url(w, h, &pixels),
                }
            })
            .collect::<Vec<_>>()
    })
    .await?;
    Ok(Json(serde_json::json!({ "levels": levels })))
}

/// Encodes 8-bit grey pixels as a `data:image/png;base64,` URL.
fn png_data_url(w: u32, h: u32, pixels: &[u8]) -> String {
    use base64::Engine as _;
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(png::ColorType::Grayscale);
        enc.set_depth(png::BitDepth::Eight);
        let written = enc
            .write_header()
            .and_then(|mut wr| wr.write_image_data(pixels));
        if let Err(e) = written {
            tracing::warn!("PNG encoding failed: {e}");
        }
    }
    format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(out)
    )
}
