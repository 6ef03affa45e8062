//! homcull: a networked occlusion-culling server.
//!
//! It keeps 3D scenes and their occluder databases resident, takes camera poses, runs
//! Hierarchical Occlusion Maps (Zhang et al. 1997) on a wgpu device or on its native
//! CPU backend, and answers with the IDs of the objects that may be visible.
//! Conservative by default: with opacity threshold 1.0 it never culls an object the
//! exact ID-buffer oracle sees.
//!
//! # Crates by layer
//! Each uses only the ones before it (`tests/repo/architecture.rs` checks it):
//! - `homcull-proto` (`proto/`): the wire types and the binary frame codec.
//! - [`core`] (`homcull-engine`, `crates/engine/`): scenes, cameras, occluders, the
//!   `Culler` seam, its backends (wgpu, native CPU, the CPU reference) and the oracle;
//!   no async runtime, HTTP or command line.
//! - [`server`] (`homcull-server`, `crates/server/`): the HTTP/WebSocket service around
//!   the engine (axum), its cull worker, data dir and limits.
//! - [`eval`] (`homcull-eval`, `crates/eval/`, cargo feature `eval`): evaluation
//!   against the oracle, the report and its plots, the load generator.
//! - [`cli`] (this crate): the command line (clap) and its subcommands.
//!
//! This crate re-exports the layers under their short names, so that tests, benches
//! and examples name one crate. `ARCHITECTURE.md` at the repository root draws the
//! data flow.

// As in every crate of the workspace (`[workspace.lints]`): matches over homcull's
// own enums name every variant. Set here rather than in the package's `[lints]`,
// which would reach its tests too.
#![deny(clippy::wildcard_enum_match_arm)]

pub use homcull_engine as core;
#[cfg(feature = "eval")]
pub use homcull_eval as eval;
pub use homcull_server as server;

pub mod cli;
