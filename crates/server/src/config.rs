//! [`Config`]: every limit and setting of a server, as a plain struct. The defaults
//! live here, once; the command line (`cli::args::ServeArgs`) takes them from here and
//! maps each flag and `HOMCULL_*` variable onto a field.

use std::path::PathBuf;

use homcull_engine::occluders::OccluderParams;
use homcull_engine::scene::LoadLimits;

/// What the API token (when set) guards.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AuthScope {
    /// Uploads and deletes.
    #[default]
    Writes,
    /// Uploads, deletes, culls of every kind and streams (API-only deployments: the
    /// browser viewer cannot send the token).
    Cull,
}

/// Where a scene's placements (what writers moved) are kept.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StateMode {
    /// Journaled in the data dir before each update is acknowledged, replayed at
    /// start (`journal`): a restart serves the same placements at the same version.
    #[default]
    Journal,
    /// In memory only: a restart serves the scene files' placements at version 0
    /// (replicas that share a data dir, until they share a state engine).
    Memory,
}

/// How a server runs.
#[derive(Debug, Clone)]
pub struct Config {
    /// Where uploaded scenes and their occluder caches live.
    pub data_dir: PathBuf,
    /// Where placements are kept.
    pub state: StateMode,
    /// When set, uploads and deletes need `Authorization: Bearer TOKEN`.
    pub api_token: Option<String>,
    /// What the token guards besides uploads and deletes.
    pub auth: AuthScope,
    /// Most poses in one `cull/batch` request.
    pub max_batch: usize,
    /// Most objects in one `transforms` request.
    pub max_transform_objects: usize,
    /// Largest GLB upload, bytes.
    pub max_upload_bytes: usize,
    /// Largest JSON request body, bytes.
    pub max_json_bytes: usize,
    /// Most concurrent WebSocket clients; more are refused with 503.
    pub max_ws_clients: usize,
    /// Most frames per second sent to one WebSocket client.
    pub ws_max_fps: f64,
    /// A full frame at least every N frames (deltas in between).
    pub full_every: u32,
    /// Most poses the worker runs in one submission.
    pub cull_batch: usize,
    /// Jobs waiting for the worker before requests are refused with 503.
    pub queue: usize,
    /// Run every pose in its own submission (for measuring what batching buys).
    pub no_batching: bool,
    /// Seconds before a request is answered 408.
    pub request_timeout_s: u64,
    /// Seconds a WebSocket send may block before the client is dropped.
    pub ws_send_timeout_s: u64,
    /// Seconds a WebSocket client may send nothing before it is closed (1008).
    pub ws_idle_timeout_s: u64,
    /// Seconds to finish in-flight work after the shutdown signal.
    pub shutdown_grace_s: u64,
    /// Seconds between rescans of the data dir for scenes other replicas wrote (0 = never).
    pub rescan_s: u64,
    /// Occluder triangles rendered per pose.
    pub budget: u32,
    /// Do not build the demo city (id `demo`).
    pub no_demo: bool,
    /// glTF/GLB files served read-only under their file name without extension.
    pub scenes: Vec<PathBuf>,
    /// Most triangles one scene may hold, counted over every instance; larger uploads
    /// are refused before anything is decoded.
    pub max_scene_triangles: u64,
    /// Browser origins (`scheme://host[:port]`, or `*`) allowed to upload, delete and
    /// open streams besides the server's own host.
    pub allowed_origins: Vec<String>,
    /// Most pixels one cull request may render, summed over its poses (a batch of 64
    /// poses at 1920×1080 is 133M); more is refused with 413.
    pub max_request_pixels: u64,
    /// Most bytes one scene's decoded geometry may take (12 per vertex and per
    /// triangle, per instance).
    pub max_decoded_bytes: u64,
    /// Seconds a scene upload may take to parse and index before it is refused (422)
    /// and discarded unstored.
    pub load_timeout_s: u64,
    /// Seconds a connection may take to send a request's headers, counted from when it
    /// opens or its previous answer went out (closes slow-header and idle keep-alive
    /// connections alike).
    pub header_timeout_s: u64,
    /// Most open connections and WebSocket streams together from one address (0: no
    /// cap); more are answered 429.
    pub max_connections_per_address: usize,
    /// Restarts of the cull worker after a panic before it stays stopped (then `/readyz`
    /// answers 503 and the server exits non-zero).
    pub worker_restarts: u32,
    /// Fault injection for tests: the cull worker panics on its first this many batches.
    /// 0 in service; no flag sets it.
    pub worker_panics: u32,
}

impl Config {
    /// What loading one scene may take (uploads, stored scenes, `--scene` files).
    pub fn load_limits(&self) -> LoadLimits {
        LoadLimits {
            max_triangles: self.max_scene_triangles,
            max_decoded_bytes: self.max_decoded_bytes,
            ..LoadLimits::default()
        }
    }
}

impl Default for Config {
    fn default() -> Self {
        Config {
            data_dir: PathBuf::from("./data"),
            state: StateMode::Journal,
            api_token: None,
            auth: AuthScope::Writes,
            max_batch: 1024,
            max_transform_objects: homcull_engine::dynamic::DEFAULT_MAX_UPDATE_OBJECTS,
            max_upload_bytes: 256 << 20,
            max_json_bytes: 8 << 20,
            max_ws_clients: 1000,
            ws_max_fps: 120.0,
            full_every: 120,
            cull_batch: 64,
            queue: 4096,
            no_batching: false,
            request_timeout_s: 60,
            ws_send_timeout_s: 10,
            ws_idle_timeout_s: 300,
            shutdown_grace_s: 10,
            rescan_s: 2,
            budget: OccluderParams::default().budget_triangles,
            no_demo: false,
            scenes: Vec::new(),
            allowed_origins: Vec::new(),
            max_request_pixels: 256 << 20,
            max_scene_triangles: LoadLimits::default().max_triangles,
            max_decoded_bytes: LoadLimits::default().max_decoded_bytes,
            load_timeout_s: 30,
            header_timeout_s: 20,
            max_connections_per_address: 128,
            worker_restarts: 3,
            worker_panics: 0,
        }
    }
}
