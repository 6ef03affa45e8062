//! The server's tests, one binary: REST and WebSocket against a server started in
//! this process on a loopback port, hostile clients included.
//!
//! One crate for the layer (each module was a test binary of its own): the layer's
//! tests link once. Run one module with `cargo test --release --test server MODULE::`.

#[path = "../common/mod.rs"]
mod common;

mod hostile_connections;
mod server_cull;
mod server_errors;
mod server_motion_walk;
mod server_native;
mod server_probes;
mod server_scenes;
mod server_transforms;
mod ws;
mod ws_hostile;
mod ws_lod;
mod ws_region;
mod ws_seen_first;
mod ws_smoothing;
mod ws_stereo;
mod ws_transforms;
