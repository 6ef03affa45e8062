//! homcull: a networked occlusion-culling server.
//!
//! It keeps a 3D scene and its occluder database resident, takes camera poses, runs
//! Hierarchical Occlusion Maps (Zhang et al. 1997) on a headless wgpu device, and
//! answers with the IDs of the objects that may be visible. Conservative by default:
//! with opacity threshold 1.0 it never culls an object the exact ID-buffer oracle sees.
//!
//! # Layers
//! Each layer uses only the ones above it in this list (`tests/architecture.rs`
//! checks it):
//! - [`core`]: scenes, cameras, occluders, the `Culler` seam and its backends (CPU
//!   reference, GPU), the resident scene.
//! - [`server`]: the HTTP/WebSocket service around the core (axum), its worker and
//!   data dir.
//! - [`eval`]: evaluation against the oracle, the report, the load generator.
//! - [`cli`]: the command line (clap) and its subcommands.
//!
//! `ARCHITECTURE.md` at the repository root draws the data flow.

pub mod cli;
pub mod core;
pub mod eval;
pub mod server;
