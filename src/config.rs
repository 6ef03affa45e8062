//! The command line: one clap struct per subcommand, every flag also an `HOMCULL_*`
//! environment variable where that makes sense. Defaults are documented here.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};
use homcull_proto::{DebVariant, Method};

#[derive(Debug, Parser)]
#[command(
    name = "homcull",
    version,
    about = "Occlusion culling with Hierarchical Occlusion Maps on wgpu"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Cull one pose and print the visible IDs and stats as JSON.
    Cull(CullArgs),
    /// Run every method and the exact oracle on the same poses and report quality and speed.
    Eval(EvalArgs),
}

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

/// Culling parameters shared by `cull` and `eval`.
#[derive(Debug, Clone, Args)]
pub struct CullParams {
    /// Opacity threshold O_0 (1.0 = conservative; below 1 culls through small holes).
    #[arg(long, default_value_t = 1.0)]
    pub threshold: f32,
    /// Depth estimation buffer: plane, tiles or raster.
    #[arg(long, default_value = "raster")]
    pub deb: DebVariant,
    /// Occluder triangles rendered per pose.
    #[arg(long, env = "HOMCULL_BUDGET", default_value_t = crate::occluders::OccluderParams::default().budget_triangles)]
    pub budget: u32,
}

#[derive(Debug, Args)]
pub struct CullArgs {
    #[command(flatten)]
    pub scene: SceneArg,
    /// The pose as JSON (DESIGN.md §3), e.g. '{"position":[0,1.7,0],"look_at":[10,1.7,0]}'.
    #[arg(long)]
    pub pose: String,
    /// hom, hzb, frustum or exact.
    #[arg(long, default_value = "hom")]
    pub method: Method,
    #[command(flatten)]
    pub params: CullParams,
}

#[derive(Debug, Args)]
pub struct EvalArgs {
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
    /// Methods to compare with the oracle: hom, hom-plane, hom-tiles, hom-raster, hzb, frustum.
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
    #[command(flatten)]
    pub params: CullParams,
}

/// Parses `WIDTHxHEIGHT`.
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
