//! The command line's top level: the subcommands, each with its arguments
//! ([`super::args`], and [`super::eval_args`] with the `eval` feature).

use clap::{Parser, Subcommand};

use super::args::{CullArgs, HealthcheckArgs, PvsArgs, ServeArgs};
#[cfg(feature = "eval")]
use super::eval_args::{AnimateArgs, EvalArgs, LoadgenArgs, ReportArgs};

#[derive(Debug, Parser)]
#[command(
    name = "homcull",
    version,
    about = "Occlusion culling with Hierarchical Occlusion Maps, on a wgpu device or the CPU"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Debug, Subcommand)]
#[allow(
    clippy::large_enum_variant,
    reason = "parsed once at start; without `eval`, `serve` alone is large"
)]
pub enum Command {
    /// Serve scenes over HTTP and WebSocket (the default when no subcommand is given).
    Serve(ServeArgs),
    /// Exit 0 if the server's /healthz answers 200 within 2 s (for Docker HEALTHCHECK).
    Healthcheck(HealthcheckArgs),
    #[cfg(feature = "eval")]
    /// Drive a running server with N WebSocket or REST clients on loopback and report throughput and latency.
    Loadgen(LoadgenArgs),
    #[cfg(feature = "eval")]
    /// Move a running server's objects on loopback (the demo city's cars drive) so a viewer shows motion.
    Animate(AnimateArgs),
    /// Cull one pose and print the visible IDs and stats as JSON.
    Cull(CullArgs),
    /// Precompute a view-cell PVS: the objects visible from anywhere in each cell.
    Pvs(PvsArgs),
    #[cfg(feature = "eval")]
    /// Run every method and the exact oracle on the same poses and report quality and speed.
    Eval(EvalArgs),
    #[cfg(feature = "eval")]
    /// Measure quality and speed on every scene and write DIR/report.md plus PNG plots.
    Report(ReportArgs),
}

impl Default for ServeArgs {
    fn default() -> Self {
        let Some(Command::Serve(a)) = Cli::parse_from(["homcull", "serve"]).command else {
            unreachable!("`homcull serve` parses as serve")
        };
        a
    }
}
