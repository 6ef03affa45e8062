//! The network face of homcull: an axum app over resident scenes and one cull worker.
//!
//! - [`routes`]: REST (`/healthz`, `/readyz`, `/metrics`, `/v1/scenes/...`).
//! - [`ws`]: WebSocket streaming with binary frames, deltas and latest-pose-wins.
//! - [`worker`]: the one cull worker that batches every waiting pose into one submission.
//! - [`config`]: [`Config`], every limit and setting, with its defaults.
//! - [`state`]: the registry of resident scenes and shared state; [`scenes`]: how
//!   scenes enter and leave it; [`store`]: the data directory; [`scene_files`]: scenes
//!   named at start (`--scene`), served read-only; [`alloc`]: allocator tuning.
//! - [`transforms`]: writers moving objects; [`writes`]: the one path of their
//!   updates (checked, kept, applied); [`journal`]: updates kept across
//!   restarts (`--state journal`).
//! - [`error`]: the one JSON error shape; [`metrics`]: Prometheus.
//! - [`static_files`]: the embedded browser viewer (`web/dist`) at `/`.
//!
//! [`serve`] builds the state (worker, scenes loading in the background), serves a
//! listener until a shutdown future resolves, then stops accepting, lets in-flight
//! requests finish, and closes WebSockets with a close frame.

pub mod alloc;
pub mod config;
pub mod error;
pub mod guard;
pub mod journal;
pub mod listen;
pub mod metrics;
pub mod motion;
pub mod routes;
pub mod scene_files;
pub mod scenes;
pub mod state;
pub mod static_files;
pub mod store;
pub mod transforms;
pub mod worker;
pub mod writes;
pub mod ws;

use std::future::Future;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Duration;

use axum::Router;
use axum::extract::DefaultBodyLimit;
use axum::middleware::{from_fn, from_fn_with_state};
use axum::routing::{get, post};
use tokio::net::TcpListener;
use tokio::sync::watch;
use tower_http::timeout::TimeoutLayer;
use tower_http::trace::TraceLayer;
use utoipa::OpenApi;
use utoipa_swagger_ui::SwaggerUi;

pub use config::{AuthScope, Config, StateMode};

use homcull_engine::engine::Backend;
use state::{AppState, Inner};
use store::Store;

/// The OpenAPI description served at `/openapi.json`.
#[derive(OpenApi)]
#[openapi(
    info(
        title = "homcull",
        description = "Occlusion culling as a service: send camera poses, get the IDs of objects that may be visible."
    ),
    paths(
        routes::healthz,
        routes::readyz,
        routes::metrics,
        routes::list_scenes,
        routes::upload_scene,
        routes::get_scene,
        routes::list_objects,
        routes::get_glb,
        routes::delete_scene,
        routes::cull,
        routes::cull_batch,
        transforms::transforms,
        routes::occluders,
        routes::pyramid,
        ws::stream
    ),
    components(schemas(
        homcull_proto::Pose,
        homcull_proto::Region,
        homcull_proto::CullOptions,
        homcull_proto::Method,
        homcull_proto::DebVariant,
        homcull_proto::CullStats,
        homcull_proto::CullResponse,
        homcull_proto::SceneInfo,
        homcull_proto::WalkStart,
        homcull_proto::SceneList,
        homcull_proto::ObjectInfo,
        homcull_proto::ObjectPlacement,
        homcull_proto::ObjectList,
        homcull_proto::CullRequest,
        homcull_proto::TransformsRequest,
        homcull_proto::ObjectTransform,
        homcull_proto::TransformsResponse,
        homcull_proto::BatchRequest,
        homcull_proto::BatchResponse,
        homcull_proto::ErrorBody,
        homcull_proto::ErrorDetail,
        homcull_proto::PoseMessage
    ))
)]
pub struct ApiDoc;

/// The router: every route, with body limits, timeouts, tracing and metrics.
pub fn app(state: AppState) -> Router {
    let cfg = &state.config;
    let json_limit = DefaultBodyLimit::max(cfg.max_json_bytes);
    let api = Router::new()
        .route("/healthz", get(routes::healthz))
        .route("/readyz", get(routes::readyz))
        .route("/metrics", get(routes::metrics))
        .route(
            "/v1/scenes",
            get(routes::list_scenes)
                .post(routes::upload_scene)
                .layer(DefaultBodyLimit::max(cfg.max_upload_bytes))
                .route_layer(from_fn_with_state(
                    state.clone(),
                    guard::require_token_on_writes,
                )),
        )
        .route(
            "/v1/scenes/{id}",
            get(routes::get_scene)
                .delete(routes::delete_scene)
                .route_layer(from_fn_with_state(
                    state.clone(),
                    guard::require_token_on_writes,
                )),
        )
        .route("/v1/scenes/{id}/objects", get(routes::list_objects))
        .route("/v1/scenes/{id}/glb", get(routes::get_glb))
        .route(
            "/v1/scenes/{id}/cull",
            post(routes::cull)
                .layer(json_limit)
                .route_layer(from_fn(guard::require_json))
                .route_layer(from_fn_with_state(
                    state.clone(),
                    guard::require_token_on_culls,
                )),
        )
        .route(
            "/v1/scenes/{id}/cull/batch",
            post(routes::cull_batch)
                .layer(json_limit)
                .route_layer(from_fn(guard::require_json))
                .route_layer(from_fn_with_state(
                    state.clone(),
                    guard::require_token_on_culls,
                )),
        )
        .route(
            "/v1/scenes/{id}/occluders",
            post(routes::occluders)
                .layer(json_limit)
                .route_layer(from_fn(guard::require_json))
                .route_layer(from_fn_with_state(
                    state.clone(),
                    guard::require_token_on_culls,
                )),
        )
        .route(
            "/v1/scenes/{id}/pyramid",
            post(routes::pyramid)
                .layer(json_limit)
                .route_layer(from_fn(guard::require_json))
                .route_layer(from_fn_with_state(
                    state.clone(),
                    guard::require_token_on_culls,
                )),
        )
        .route(
            "/v1/scenes/{id}/transforms",
            post(transforms::transforms)
                .layer(json_limit)
                .route_layer(from_fn(guard::require_json))
                .route_layer(from_fn_with_state(
                    state.clone(),
                    guard::require_token_on_writes,
                )),
        )
        .route("/v1/scenes/{id}/stream", get(ws::stream))
        .layer(TimeoutLayer::with_status_code(
            axum::http::StatusCode::REQUEST_TIMEOUT,
            Duration::from_secs(cfg.request_timeout_s),
        ))
        .route_layer(axum::middleware::from_fn(metrics::track));
    api.merge(SwaggerUi::new("/docs").url("/openapi.json", ApiDoc::openapi()))
        .fallback(static_files::serve)
        .layer(TraceLayer::new_for_http())
        .with_state(state)
}

/// Serves `listener` with `config` on `backend` until `shutdown` resolves, then
/// drains (see [`run`]). Before it listens it opens the data dir and parses the
/// `--scene` files: an error there is returned at once and names what failed. The demo
/// city, the `--scene` files and the stored scenes become resident in the background
/// (`/readyz` says when they are in).
pub async fn serve(
    listener: TcpListener,
    config: Config,
    backend: Backend,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    let data_dir = config.data_dir.display().to_string();
    let (state, shutdown_tx) = start(config, backend)?;
    tracing::info!(
        "homcull listening on http://{}/ (viewer at /, API docs at /docs) on {}; data in {data_dir}",
        listener.local_addr()?,
        state.adapter
    );
    run(listener, state, shutdown_tx, shutdown).await
}

/// Builds the server state: opens the data dir, parses the `--scene` files, starts the
/// worker, and starts loading the scenes in the background.
fn start(config: Config, backend: Backend) -> std::io::Result<(AppState, watch::Sender<bool>)> {
    alloc::tune_allocator();
    let store = Store::open(&config.data_dir)?;
    let journals = match config.state {
        StateMode::Journal => Some(journal::StateDir::open(&config.data_dir)?),
        StateMode::Memory => None,
    };
    let files = scene_files::load_all(&config.scenes, &config.load_limits())
        .map_err(std::io::Error::other)?;
    let (shutdown_tx, shutdown) = watch::channel(false);
    let supervision = worker::Supervision {
        max_restarts: config.worker_restarts,
        panic_first_batches: config.worker_panics,
    };
    let worker = worker::spawn(
        config.queue,
        config.cull_batch,
        !config.no_batching,
        supervision,
    );
    let addresses = listen::AddressBook::new(config.max_connections_per_address);
    let adapter = backend.describe();
    let state = AppState(Arc::new(Inner {
        config,
        store,
        journals,
        scenes: Default::default(),
        worker,
        backend,
        adapter,
        ready: AtomicBool::new(false),
        ws_clients: AtomicUsize::new(0),
        addresses,
        shutdown,
        metrics: metrics::handle(),
        changes: Default::default(),
        failed: Default::default(),
    }));
    let st = state.clone();
    tokio::task::spawn_blocking(move || {
        if !st.config.no_demo {
            st.load_demo();
        }
        for file in files {
            st.load_file(file);
        }
        st.rescan();
        st.ready.store(true, Ordering::SeqCst);
        tracing::info!(scenes = st.scene_list().len(), adapter = %st.adapter, "ready");
    });
    if state.config.rescan_s > 0 {
        let st = state.clone();
        let every = Duration::from_secs(state.config.rescan_s);
        tokio::spawn(async move {
            let mut shutdown = st.shutdown.clone();
            loop {
                tokio::select! {
                    _ = tokio::time::sleep(every) => {}
                    _ = shutdown.changed() => break,
                }
                if st.ready.load(Ordering::SeqCst) {
                    let s = st.clone();
                    let _ = tokio::task::spawn_blocking(move || s.rescan()).await;
                }
            }
        });
    }
    Ok((state, shutdown_tx))
}

/// How long a server whose cull worker stopped for good keeps answering (`/readyz` 503,
/// culls 503) before it drains and exits.
const WORKER_DEATH_NOTICE: Duration = Duration::from_secs(2);

/// Serves `listener` until `shutdown` resolves, then drains: no new connections,
/// in-flight requests finish, WebSockets get a close frame. Gives up after the
/// configured grace period. Returns an error if the cull worker stops for good (see
/// [`worker`]), so that the process exits non-zero and its orchestrator restarts it.
async fn run(
    listener: TcpListener,
    state: AppState,
    shutdown_tx: watch::Sender<bool>,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    let grace = Duration::from_secs(state.config.shutdown_grace_s);
    let header_timeout = Duration::from_secs(state.config.header_timeout_s.max(1));
    let mut stopping = state.shutdown.clone();
    let sessions = state.clone();
    let health = state.worker.health.clone();
    let app = app(state.clone());
    let (worker_died_tx, worker_died) = tokio::sync::oneshot::channel::<()>();
    let stop = async move {
        tokio::select! {
            _ = shutdown => {}
            _ = health.wait_stopped() => {
                // `/readyz` answers 503 from now on: give load balancers a moment to
                // take the server out of rotation before its connections close.
                tokio::time::sleep(WORKER_DEATH_NOTICE).await;
                let _ = worker_died_tx.send(());
            }
        }
        tracing::info!("shutting down: draining requests and closing WebSockets");
        let _ = shutdown_tx.send(true);
    };
    let serve = listen::serve(listener, app, state.addresses.clone(), header_timeout, stop);
    // Upgraded WebSockets are not connections the accept loop waits for: wait until
    // every session has sent its close frame (each holds a client slot until then),
    // within the same grace period.
    let serve = async move {
        serve.await;
        while sessions.ws_clients.load(Ordering::SeqCst) > 0 {
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    };
    let deadline = async move {
        let _ = stopping.wait_for(|s| *s).await;
        tokio::time::sleep(grace).await;
    };
    tokio::select! {
        _ = serve => {}
        _ = deadline => tracing::warn!("grace period over; stopping with work in flight"),
    }
    if worker_died.await.is_ok() {
        return Err(std::io::Error::other(format!(
            "the cull worker died {} times; stopping so that the service is restarted",
            state.worker.health.restarts()
        )));
    }
    Ok(())
}

/// Resolves on SIGINT or SIGTERM.
pub async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = ctrl_c => {},
        _ = term => {},
    }
}
