//! homcull: a networked occlusion-culling server.
//!
//! It keeps a 3D scene and its occluder database resident, takes camera poses, runs
//! Hierarchical Occlusion Maps (Zhang et al. 1997) on a headless wgpu device, and
//! answers with the IDs of the objects that may be visible. Conservative by default:
//! with opacity threshold 1.0 it never culls an object the exact ID-buffer oracle sees.
//!
//! # Layout
//! - [`geom`]: boxes and planes.
//! - [`camera`]: poses, projection, frustum, box → screen rect; all conventions.
//! - [`scene`]: glTF loading, objects, test boxes (sub-bounds), the demo city.
//! - [`bvh`]: object BVH (obvhs) with frustum traversal.
//! - [`occluders`]: occluder database and runtime selection (nearest first, or what a
//!   walk saw at its previous pose first).
//! - [`hom`]: the algorithm on the CPU (raster, pyramid, DEB, object test): the
//!   reference for the GPU and the fallback without one.
//! - [`gpu`]: the same passes on wgpu, batched; GPU time per pass from timestamps.
//! - [`cull`]: the `Culler` trait, per-pose planning, methods frustum/hom/hzb/exact.
//! - [`engine`]: a prepared scene with its backend (GPU, or CPU fallback).
//! - [`eval`]: runs methods against the oracle and aggregates quality and timing.
//! - [`loss`]: which hidden objects HOM keeps, and why (boxes or occluders).
//! - [`sampler`]: random poses where a person would stand, and a walk's start.
//! - [`pvs`]: the OpenArena maps' own potentially-visible sets, an independent check
//!   of the exact oracle, object by object and pixel by pixel.
//! - [`server`]: the HTTP/WebSocket server (axum), its GPU worker and data dir.
//! - [`loadgen`]: a bounded loopback load generator for the server.
//! - [`report`]: `homcull report`, every evaluation side by side as markdown + PNG plots.
//! - [`config`]: the command line.

pub mod bvh;
pub mod camera;
pub mod config;
pub mod cull;
pub mod engine;
pub mod eval;
pub mod geom;
pub mod gpu;
pub mod hom;
pub mod loadgen;
pub mod loss;
pub mod occluders;
pub mod pvs;
pub mod report;
pub mod sampler;
pub mod scene;
pub mod server;
