//! The engine's tests, one binary: every backend and method against the exact oracle,
//! GPU passes against their CPU twins, on random scenes and the shared real scenes.
//!
//! One crate for the layer (each module was a test binary of its own): the layer's
//! tests link once. Run one module with `cargo test --release --test engine MODULE::`.

#[path = "../common/mod.rs"]
mod common;

mod custom_method;
mod dynamic;
mod dynamic_marks;
mod gpu_batch;
mod gpu_profile;
mod gpu_vs_cpu;
mod lod;
mod native_backend;
mod pvs_oracle;
mod real_scenes;
mod region;
mod stereo;
mod viewcells;
