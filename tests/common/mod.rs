//! Shared helpers of the integration tests: the GPU (or a skip), the shared scenes.
#![allow(dead_code)]

use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use homcull::core::gpu::{GpuContext, GpuOptions, require_gpu};

/// The test GPU. Without an adapter the test is skipped with a message, unless
/// `HOMCULL_REQUIRE_GPU=1`, which makes it a failure.
pub fn gpu() -> Option<Arc<GpuContext>> {
    static GPU: OnceLock<Option<Arc<GpuContext>>> = OnceLock::new();
    GPU.get_or_init(|| match GpuContext::new() {
        Ok(ctx) => {
            eprintln!("test adapter: {}", ctx.describe());
            Some(Arc::new(ctx))
        }
        Err(e) => {
            assert!(!require_gpu(), "HOMCULL_REQUIRE_GPU=1 but no adapter: {e}");
            eprintln!(
                "SKIP: no GPU adapter ({e}); set HOMCULL_REQUIRE_GPU=1 to make this a failure"
            );
            None
        }
    })
    .clone()
}

/// A test GPU context of its own (not shared with the other tests of the binary,
/// which run in parallel), for tests that count what the device records.
pub fn private_gpu() -> Option<Arc<GpuContext>> {
    gpu()?;
    let ctx = GpuContext::new().expect("the test adapter opens twice");
    Some(Arc::new(ctx))
}

/// A second test GPU context that takes the path of adapters without forced early
/// depth tests (`GpuOptions::early_depth_test` off), for the refinement's fallback.
pub fn gpu_without_early_z() -> Option<Arc<GpuContext>> {
    static GPU: OnceLock<Option<Arc<GpuContext>>> = OnceLock::new();
    GPU.get_or_init(|| {
        gpu()?;
        let options = GpuOptions {
            early_depth_test: false,
            ..GpuOptions::from_env()
        };
        let ctx = GpuContext::with_options(options).expect("the test adapter opens twice");
        assert!(!ctx.early_depth_test);
        Some(Arc::new(ctx))
    })
    .clone()
}

/// `../shared/scenes` next to the crate, if present.
pub fn scenes_dir() -> Option<PathBuf> {
    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/scenes"));
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("SKIP: {} is absent", dir.display());
        None
    }
}

pub mod hostile;
pub mod process;
pub mod rest;
pub mod scenes;
pub mod server;
pub mod ws;

/// This process's open file descriptors (the in-process test server's included).
pub fn open_fds() -> usize {
    std::fs::read_dir("/proc/self/fd").map_or(0, |d| d.count())
}

/// This process's resident memory, MiB (`/proc/self/statm`).
pub fn rss_mib() -> f64 {
    let statm = std::fs::read_to_string("/proc/self/statm").unwrap_or_default();
    let pages: f64 = statm
        .split_whitespace()
        .nth(1)
        .and_then(|p| p.parse().ok())
        .unwrap_or(0.0);
    pages * 4096.0 / (1 << 20) as f64
}
