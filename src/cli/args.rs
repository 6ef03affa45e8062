//! The arguments of the subcommands that serve and cull, and the groups of flags the
//! evaluation's subcommands share (`eval_args`): one clap struct each, every flag also
//! an `HOMCULL_*` environment variable where that makes sense. Defaults are
//! documented here.

use std::path::PathBuf;

use clap::Args;
use homcull_proto::{CullOptions, CullOptionsQuery, DebVariant, InvalidLod, Method, Surface};

use crate::core::engine::BackendChoice;
use crate::core::occluders::OccluderParams;
use crate::server::{AuthScope, Config, StateMode};

/// Which scene to load.
#[derive(Debug, Clone, Args)]
#[group(required = true, multiple = false)]
pub struct SceneArg {
    /// A glTF or GLB file.
    #[arg(long, env = "HOMCULL_SCENE")]
    pub scene: Option<PathBuf>,
    /// The built-in procedural demo city.
    #[arg(long)]
    pub demo: bool,
}

/// Which backend culls, and on how many CPU threads (`serve`, `cull`, `eval`, `report`).
#[derive(Debug, Clone, Args)]
pub struct BackendArgs {
    /// auto (a hardware GPU if there is one, else the native CPU backend), gpu (any
    /// wgpu adapter, software Vulkan included; none is an error) or cpu (native).
    /// `HOMCULL_REQUIRE_GPU=1` makes auto mean gpu.
    #[arg(long, env = "HOMCULL_BACKEND", default_value = "auto")]
    pub backend: BackendChoice,
    /// Threads for the CPU work (planning, and the culling itself on the native
    /// backend); 0 = one per core.
    #[arg(long, env = "HOMCULL_THREADS", default_value_t = 0)]
    pub threads: usize,
}

/// The command line's cull options where a flag is not given.
fn cli_default() -> CullOptions {
    CullOptions::defaults(Surface::Cli)
}

/// Culling parameters shared by `cull` and `eval`.
#[derive(Debug, Clone, Args)]
pub struct CullParams {
    /// Opacity threshold O_0 (1.0 = conservative; below 1 culls through small holes).
    #[arg(long, default_value_t = cli_default().threshold)]
    pub threshold: f32,
    /// Depth estimation buffer: plane, tiles or raster.
    #[arg(long, default_value_t = cli_default().deb)]
    pub deb: DebVariant,
    /// hom: the box test alone, without the per-pixel refinement of its survivors.
    #[arg(long)]
    pub no_refine: bool,
    /// Occluder triangles rendered per pose.
    #[arg(long, env = "HOMCULL_BUDGET", default_value_t = OccluderParams::default().budget_triangles)]
    pub budget: u32,
}

impl CullParams {
    /// The cull options these flags give, with `method` and `lod_px`, over the command
    /// line's defaults.
    pub fn options(
        &self,
        method: Method,
        lod_px: Option<String>,
    ) -> Result<CullOptions, InvalidLod> {
        CullOptionsQuery {
            method: Some(method),
            threshold: Some(self.threshold),
            deb: Some(self.deb),
            refine: self.no_refine.then_some(false),
            lod_px,
        }
        .over(cli_default())
    }

    /// The occluder database's parameters with this budget.
    pub fn occluder_params(&self) -> OccluderParams {
        OccluderParams {
            budget_triangles: self.budget,
            ..Default::default()
        }
    }
}

#[derive(Debug, Args)]
pub struct CullArgs {
    #[command(flatten)]
    pub backend: BackendArgs,
    #[command(flatten)]
    pub scene: SceneArg,
    /// The pose as JSON (the wire format of `POST /cull`), e.g. '{"position":[0,1.7,0],"look_at":[10,1.7,0]}'.
    #[arg(long)]
    pub pose: String,
    /// hom, hzb, frustum or exact.
    #[arg(long, default_value_t = cli_default().method)]
    pub method: Method,
    #[command(flatten)]
    pub params: CullParams,
    /// Level-of-detail thresholds in pixels, largest first (e.g. 64,16,4): the answer
    /// then carries a level per visible object in `lod`.
    #[arg(long)]
    pub lod_px: Option<String>,
}

/// How `homcull pvs` cuts a scene into view cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CellsBy {
    /// Columns of the walkable space, `--cell-m` a side.
    Grid,
    /// The vis clusters of a map that ships a PVS (the OpenArena maps).
    Clusters,
}

#[derive(Debug, Args)]
pub struct PvsArgs {
    #[command(flatten)]
    pub scene: SceneArg,
    /// grid: columns of the walkable space that hold standing eyes, eye heights
    /// 0.5–2.5 m; clusters: one cell per vis cluster of the map's own PVS.
    #[arg(long, value_enum, default_value = "grid")]
    pub cells: CellsBy,
    /// Side of a grid column, and of the boxes a cell is covered by, metres (each box
    /// is one region: smaller boxes are tighter near walls and slower).
    #[arg(long, default_value_t = 2.0)]
    pub cell_m: f32,
    /// Only these clusters, comma-separated (with `--cells clusters`).
    #[arg(long, value_delimiter = ',')]
    pub clusters: Option<Vec<i32>>,
    /// Viewport whose pixels, with `--fov-y-deg`, fix the maps' angular cell
    /// (coarser cells are faster and keep more).
    #[arg(long, default_value = "960x540", value_parser = parse_viewport)]
    pub viewport: [u32; 2],
    /// Vertical field of view, degrees.
    #[arg(long, default_value_t = 60.0)]
    pub fov_y_deg: f32,
    /// hom, hzb or frustum (`exact` answers no region).
    #[arg(long, default_value_t = cli_default().method)]
    pub method: Method,
    #[command(flatten)]
    pub params: CullParams,
    /// Threads answering boxes in parallel; 0 = one per core.
    #[arg(long, env = "HOMCULL_THREADS", default_value_t = 0)]
    pub threads: usize,
    /// Where the PVS is written (JSON, docs/pvs.md), replacing the file when done.
    #[arg(long)]
    pub out: PathBuf,
}

pub fn parse_viewport(s: &str) -> Result<[u32; 2], String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("viewport `{s}` is not WIDTHxHEIGHT"))?;
    let p = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|e| format!("viewport `{s}`: {e}"))
    };
    Ok([p(w)?, p(h)?])
}

/// `homcull serve`: every limit is a flag and a `HOMCULL_*` variable.
#[derive(Debug, Clone, Args)]
pub struct ServeArgs {
    #[command(flatten)]
    pub backend: BackendArgs,
    /// Address to listen on.
    #[arg(long, env = "HOMCULL_ADDR", default_value = "127.0.0.1:8080")]
    pub addr: std::net::SocketAddr,
    /// Where uploaded scenes and their occluder caches live.
    #[arg(long, env = "HOMCULL_DATA_DIR", default_value_os_t = Config::default().data_dir)]
    pub data_dir: PathBuf,
    /// Where placements that writers send are kept: `journal` (in the data dir, flushed
    /// before each update is acknowledged and replayed at start: a restart keeps them;
    /// one server per data dir) or `memory` (lost on restart; for replicas that share
    /// a data dir).
    #[arg(long, env = "HOMCULL_STATE", default_value = "journal")]
    pub state: StateArg,
    /// When set, uploads and deletes need `Authorization: Bearer TOKEN`.
    #[arg(long, env = "HOMCULL_API_TOKEN", hide_env_values = true)]
    pub api_token: Option<String>,
    /// What the token guards: `writes` (uploads and deletes) or `cull` (also culls and
    /// streams; for API-only deployments, the browser viewer cannot send it).
    #[arg(long, env = "HOMCULL_AUTH", default_value = "writes")]
    pub auth: AuthArg,
    /// Most poses in one `cull/batch` request.
    #[arg(long, env = "HOMCULL_MAX_BATCH", default_value_t = Config::default().max_batch)]
    pub max_batch: usize,
    /// Most objects in one `POST /v1/scenes/{id}/transforms` request.
    #[arg(long, env = "HOMCULL_MAX_TRANSFORM_OBJECTS", default_value_t = Config::default().max_transform_objects)]
    pub max_transform_objects: usize,
    /// Largest GLB upload, bytes.
    #[arg(long, env = "HOMCULL_MAX_UPLOAD_BYTES", default_value_t = Config::default().max_upload_bytes)]
    pub max_upload_bytes: usize,
    /// Largest JSON request body, bytes.
    #[arg(long, env = "HOMCULL_MAX_JSON_BYTES", default_value_t = Config::default().max_json_bytes)]
    pub max_json_bytes: usize,
    /// Most concurrent WebSocket clients; more are refused with 503.
    #[arg(long, env = "HOMCULL_MAX_WS_CLIENTS", default_value_t = Config::default().max_ws_clients)]
    pub max_ws_clients: usize,
    /// Most frames per second sent to one WebSocket client.
    #[arg(long, env = "HOMCULL_WS_MAX_FPS", default_value_t = Config::default().ws_max_fps)]
    pub ws_max_fps: f64,
    /// A full frame at least every N frames (deltas in between).
    #[arg(long, env = "HOMCULL_FULL_EVERY", default_value_t = Config::default().full_every)]
    pub full_every: u32,
    /// Most poses the cull worker runs in one batch (one submission on a GPU) [default:
    /// 64]. `--gpu-batch` and `HOMCULL_GPU_BATCH` are its old names.
    #[arg(
        long,
        visible_alias = "gpu-batch",
        env = "HOMCULL_CULL_BATCH",
        value_name = "N"
    )]
    pub cull_batch: Option<usize>,
    /// Jobs waiting for the cull worker before requests are refused with 503.
    #[arg(long, env = "HOMCULL_QUEUE", default_value_t = Config::default().queue)]
    pub queue: usize,
    /// Run every pose in its own submission (for measuring what batching buys).
    #[arg(long, env = "HOMCULL_NO_BATCHING")]
    pub no_batching: bool,
    /// Seconds before a request is answered 408.
    #[arg(long, env = "HOMCULL_REQUEST_TIMEOUT_S", default_value_t = Config::default().request_timeout_s)]
    pub request_timeout_s: u64,
    /// Seconds a WebSocket send may block before the client is dropped.
    #[arg(long, env = "HOMCULL_WS_SEND_TIMEOUT_S", default_value_t = Config::default().ws_send_timeout_s)]
    pub ws_send_timeout_s: u64,
    /// Seconds a WebSocket client may send nothing before it is closed (1008).
    #[arg(long, env = "HOMCULL_WS_IDLE_TIMEOUT_S", default_value_t = Config::default().ws_idle_timeout_s)]
    pub ws_idle_timeout_s: u64,
    /// Seconds to finish in-flight work after SIGTERM/SIGINT.
    #[arg(long, env = "HOMCULL_SHUTDOWN_GRACE_S", default_value_t = Config::default().shutdown_grace_s)]
    pub shutdown_grace_s: u64,
    /// Seconds between rescans of the data dir for scenes other replicas wrote (0 = never).
    #[arg(long, env = "HOMCULL_RESCAN_S", default_value_t = Config::default().rescan_s)]
    pub rescan_s: u64,
    /// Occluder triangles rendered per pose.
    #[arg(long, env = "HOMCULL_BUDGET", default_value_t = Config::default().budget)]
    pub budget: u32,
    /// Do not build the demo city (id `demo`).
    #[arg(long, env = "HOMCULL_NO_DEMO")]
    pub no_demo: bool,
    /// A glTF/GLB file to serve read-only, under its file name without extension as
    /// scene id (`--scene scenes/munich.glb` serves `munich`). Repeat the flag for more;
    /// in the variable, separate paths with commas. A missing or broken file stops the
    /// server at start.
    #[arg(
        long = "scene",
        env = "HOMCULL_SCENES",
        value_delimiter = ',',
        value_name = "FILE"
    )]
    pub scenes: Vec<std::path::PathBuf>,
    /// Most triangles one scene may hold (every instance counted); larger files are
    /// refused before decoding.
    #[arg(long, env = "HOMCULL_MAX_SCENE_TRIANGLES", default_value_t = Config::default().max_scene_triangles)]
    pub max_scene_triangles: u64,
    /// A browser origin (`scheme://host[:port]`, or `*`) allowed to upload, delete and
    /// open streams besides the server's own host. Repeat the flag for more; in the
    /// variable, separate them with commas.
    #[arg(
        long = "allowed-origin",
        env = "HOMCULL_ALLOWED_ORIGINS",
        value_delimiter = ',',
        value_name = "ORIGIN"
    )]
    pub allowed_origins: Vec<String>,
    /// Most pixels one cull request may render, summed over its poses.
    #[arg(long, env = "HOMCULL_MAX_REQUEST_PIXELS", default_value_t = Config::default().max_request_pixels)]
    pub max_request_pixels: u64,
    /// Most bytes one scene's decoded geometry may take.
    #[arg(long, env = "HOMCULL_MAX_DECODED_BYTES", default_value_t = Config::default().max_decoded_bytes)]
    pub max_decoded_bytes: u64,
    /// Seconds an upload may take to parse and index before it is refused (422).
    #[arg(long, env = "HOMCULL_LOAD_TIMEOUT_S", default_value_t = Config::default().load_timeout_s)]
    pub load_timeout_s: u64,
    /// Seconds a connection may take to send a request's headers (from when it opens or
    /// its previous answer went out): closes slow-header and idle keep-alive connections.
    #[arg(long, env = "HOMCULL_HEADER_TIMEOUT_S", default_value_t = Config::default().header_timeout_s)]
    pub header_timeout_s: u64,
    /// Most open connections and WebSocket streams together from one address (0: no
    /// cap); more are answered 429. Behind a proxy every client shares its address.
    #[arg(long, env = "HOMCULL_MAX_CONNECTIONS_PER_ADDRESS", default_value_t = Config::default().max_connections_per_address)]
    pub max_connections_per_address: usize,
    /// Restarts of the cull worker after a panic before the server exits non-zero.
    #[arg(long, env = "HOMCULL_WORKER_RESTARTS", default_value_t = Config::default().worker_restarts)]
    pub worker_restarts: u32,
}

impl ServeArgs {
    /// The server's configuration from these flags (everything but the address).
    /// Fails only on a malformed `HOMCULL_GPU_BATCH`, the old name of
    /// `HOMCULL_CULL_BATCH`, which clap does not read.
    pub fn config(&self) -> Result<Config, String> {
        let cull_batch = match (self.cull_batch, std::env::var(LEGACY_CULL_BATCH_ENV)) {
            (Some(n), _) => n,
            (None, Ok(v)) => v.trim().parse().map_err(|e| {
                format!("{LEGACY_CULL_BATCH_ENV}=`{v}` (the old name of HOMCULL_CULL_BATCH): {e}")
            })?,
            (None, Err(_)) => Config::default().cull_batch,
        };
        Ok(Config {
            data_dir: self.data_dir.clone(),
            state: match self.state {
                StateArg::Journal => StateMode::Journal,
                StateArg::Memory => StateMode::Memory,
            },
            api_token: self.api_token.clone(),
            auth: match self.auth {
                AuthArg::Writes => AuthScope::Writes,
                AuthArg::Cull => AuthScope::Cull,
            },
            max_batch: self.max_batch,
            max_transform_objects: self.max_transform_objects,
            max_upload_bytes: self.max_upload_bytes,
            max_json_bytes: self.max_json_bytes,
            max_ws_clients: self.max_ws_clients,
            ws_max_fps: self.ws_max_fps,
            full_every: self.full_every,
            cull_batch,
            queue: self.queue,
            no_batching: self.no_batching,
            request_timeout_s: self.request_timeout_s,
            ws_send_timeout_s: self.ws_send_timeout_s,
            ws_idle_timeout_s: self.ws_idle_timeout_s,
            shutdown_grace_s: self.shutdown_grace_s,
            rescan_s: self.rescan_s,
            budget: self.budget,
            no_demo: self.no_demo,
            scenes: self.scenes.clone(),
            allowed_origins: self.allowed_origins.clone(),
            max_request_pixels: self.max_request_pixels,
            max_scene_triangles: self.max_scene_triangles,
            max_decoded_bytes: self.max_decoded_bytes,
            load_timeout_s: self.load_timeout_s,
            header_timeout_s: self.header_timeout_s,
            max_connections_per_address: self.max_connections_per_address,
            worker_restarts: self.worker_restarts,
            worker_panics: 0,
        })
    }
}

/// The old name of `HOMCULL_CULL_BATCH`, still read when the new one is unset.
const LEGACY_CULL_BATCH_ENV: &str = "HOMCULL_GPU_BATCH";

#[derive(Debug, Args)]
pub struct HealthcheckArgs {
    /// URL of /healthz; default: port of HOMCULL_ADDR on 127.0.0.1.
    #[arg(long, env = "HOMCULL_HEALTHCHECK_URL")]
    pub url: Option<String>,
}

/// `--state`: where placements are kept.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum StateArg {
    Journal,
    Memory,
}

/// `--auth`: what the API token guards.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum AuthArg {
    Writes,
    Cull,
}
