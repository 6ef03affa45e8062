//! The wire crate's tests, one binary: golden vectors, every rejection, round trips of
//! random frames, truncation.
//!
//! One crate for the layer (each module was a test binary of its own). Run one module
//! with `cargo test -p homcull-proto --test wire MODULE::`.

#[path = "../common/mod.rs"]
mod common;

mod golden;
mod golden_frames;
mod reject;
mod reject_levels;
mod roundtrip;
mod truncation;
