//! The evaluation subcommands' arguments (`eval`, `loadgen`, `animate`, `report`),
//! built with the `eval` cargo feature only.

use std::path::PathBuf;

use clap::Args;

use super::args::{BackendArgs, CullParams, SceneArg, parse_viewport};
use crate::eval::loadgen::LoadConfig;
use crate::eval::report::{ReportOptions, Section};

#[derive(Debug, Args)]
pub struct EvalArgs {
    #[command(flatten)]
    pub backend: BackendArgs,
    #[command(flatten)]
    pub scene: SceneArg,
    /// Sample N random poses where a person would stand.
    #[arg(long, conflicts_with = "poses_file")]
    pub random: Option<usize>,
    /// Seed of the random pose sampler.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// A JSON array of poses in the wire format.
    #[arg(long)]
    pub poses_file: Option<PathBuf>,
    /// Methods to compare with the oracle: hom, hom-refine, hom-raster, hom-tiles,
    /// hom-plane, hzb, frustum (hom-DEB is the box test alone, hom-refine the raster DEB
    /// with per-pixel refinement, plain hom follows --deb and --no-refine).
    #[arg(long, value_delimiter = ',', default_value = "hom,hzb,frustum")]
    pub methods: Vec<String>,
    /// Viewport for sampled poses, WIDTHxHEIGHT.
    #[arg(long, default_value = "960x540", value_parser = parse_viewport)]
    pub viewport: [u32; 2],
    /// Poses per GPU batch.
    #[arg(long, default_value_t = 16)]
    pub batch: usize,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Also measure GPU time per pass (timestamp queries; a second run per method).
    #[arg(long)]
    pub profile: bool,
    #[command(flatten)]
    pub params: CullParams,
}

/// Parses `WIDTHxHEIGHT`.
#[derive(Debug, Args)]
pub struct LoadgenArgs {
    /// Base URL of the server (loopback only).
    #[arg(long, default_value = "http://127.0.0.1:8080")]
    pub url: String,
    /// Scene id.
    #[arg(long, default_value = "demo")]
    pub scene: String,
    /// Concurrent clients.
    #[arg(long, default_value_t = 32)]
    pub clients: usize,
    /// Seconds to run.
    #[arg(long, default_value_t = 5.0)]
    pub seconds: f64,
    /// `ws` (one pose in flight per client), `batch` (REST batches of --batch poses),
    /// `walk` (one client walking the demo street at 60 frames/s, its messages
    /// delayed by --delay-ms each way, every drawn frame checked against the exact
    /// oracle: late reveals, culls per second) or `walkers` (--clients streams each
    /// sending 60 poses/s along the street whatever the answers: answered share,
    /// answer times, culls per client-second, whether all were served at 60 Hz).
    #[arg(long, default_value = "ws")]
    pub mode: String,
    /// `walk`: the delay each way, milliseconds.
    #[arg(long, default_value_t = 0)]
    pub delay_ms: u32,
    /// `walk` and `walkers`: the stream's query string, e.g. `?region_m=0.5&turn_deg=15` or
    /// `?lookahead_ms=150&hold_ms=300`.
    #[arg(long, default_value = "")]
    pub stream_query: String,
    /// Poses per REST batch in `batch` mode.
    #[arg(long, default_value_t = 64)]
    pub batch: usize,
    /// Object transforms per second a writer sends meanwhile (0: none).
    #[arg(long, default_value_t = 0.0)]
    pub transforms_per_s: f64,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

/// `homcull report`: the evaluation and scaling report.
#[derive(Debug, Clone, Args)]
pub struct ReportArgs {
    #[command(flatten)]
    pub backend: BackendArgs,
    /// Where report.md and the plots go (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// A small, fast version (16 poses at 480x270, fewer sizes and clients): a smoke test.
    #[arg(long)]
    pub quick: bool,
    /// The scenes to report on: every .glb in it, plus the demo city.
    #[arg(long, default_value = "../shared/scenes")]
    pub scenes_dir: PathBuf,
    /// Which sections to run (comma-separated): quality (with the threshold curve),
    /// budget, viewport, batch, objects, server, motion, regions. Default: all.
    #[arg(long, value_delimiter = ',', value_enum)]
    pub sections: Vec<ReportSection>,
}

/// A section of `homcull report`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ReportSection {
    Quality,
    Budget,
    Viewport,
    Batch,
    Objects,
    Server,
    Motion,
    Regions,
}

/// `homcull animate`: a writer moving objects of a running server (loopback only).
#[derive(Debug, Clone, Args)]
pub struct AnimateArgs {
    /// Base URL of the server (loopback only).
    #[arg(long, default_value = "http://127.0.0.1:8080")]
    pub url: String,
    /// Scene id.
    #[arg(long, default_value = "demo")]
    pub scene: String,
    /// Objects whose names start with this move (`model_` for the OpenArena maps' doors and lifts).
    #[arg(long, default_value = "car_")]
    pub prefix: String,
    /// The axis they move along: `long` (the longer horizontal side: cars drive forward), x, y or z.
    #[arg(long, default_value = "long")]
    pub axis: AxisArg,
    /// Metres each side of where the file put them.
    #[arg(long, default_value_t = 20.0)]
    pub amplitude: f32,
    /// Seconds for one round trip.
    #[arg(long, default_value_t = 12.0)]
    pub period_s: f32,
    /// Updates per second.
    #[arg(long, default_value_t = 20.0)]
    pub rate: f32,
    /// Seconds to run (0: until stopped).
    #[arg(long, default_value_t = 0.0)]
    pub seconds: f64,
    /// Bearer token for writes, when the server has one.
    #[arg(long, env = "HOMCULL_API_TOKEN")]
    pub token: Option<String>,
}

#[derive(Debug, Clone, Copy, clap::ValueEnum)]
pub enum AxisArg {
    Long,
    X,
    Y,
    Z,
}

impl AnimateArgs {
    pub fn config(&self) -> crate::eval::animate::AnimateConfig {
        use crate::eval::animate::Axis;
        crate::eval::animate::AnimateConfig {
            url: self.url.clone(),
            scene: self.scene.clone(),
            prefix: self.prefix.clone(),
            axis: match self.axis {
                AxisArg::Long => Axis::Long,
                AxisArg::X => Axis::X,
                AxisArg::Y => Axis::Y,
                AxisArg::Z => Axis::Z,
            },
            amplitude: self.amplitude,
            period_s: self.period_s,
            rate_hz: self.rate,
            seconds: self.seconds,
            token: self.token.clone(),
        }
    }
}

impl LoadgenArgs {
    pub fn config(&self) -> LoadConfig {
        LoadConfig {
            url: self.url.clone(),
            scene: self.scene.clone(),
            clients: self.clients,
            seconds: self.seconds,
            mode: self.mode.clone(),
            batch: self.batch,
            transforms_per_s: self.transforms_per_s,
        }
    }
}

impl ReportArgs {
    pub fn options(&self) -> ReportOptions {
        let sections = self
            .sections
            .iter()
            .map(|s| match s {
                ReportSection::Quality => Section::Quality,
                ReportSection::Budget => Section::Budget,
                ReportSection::Viewport => Section::Viewport,
                ReportSection::Batch => Section::Batch,
                ReportSection::Objects => Section::Objects,
                ReportSection::Server => Section::Server,
                ReportSection::Motion => Section::Motion,
                ReportSection::Regions => Section::Regions,
            })
            .collect();
        ReportOptions {
            out: self.out.clone(),
            quick: self.quick,
            scenes_dir: self.scenes_dir.clone(),
            sections,
        }
    }
}
