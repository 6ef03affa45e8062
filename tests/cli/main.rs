//! The command line's tests, one binary: `homcull` run as a process (flags, `cull`,
//! `eval`, `report`, the placement journal across `kill -9`).
//!
//! One crate for the layer (each module was a test binary of its own): the layer's
//! tests link once. Run one module with `cargo test --release --test cli MODULE::`.

#[path = "../common/mod.rs"]
mod common;

mod cli;
mod journal;
mod pvs;
mod report;
