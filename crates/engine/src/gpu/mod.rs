//! GPU backend on wgpu: headless device, one file per pass, each named like its CPU
//! twin in `hom/`.
//!
//! - [`device`]: adapter, device and queue (honours `WGPU_*` environment variables),
//!   and the optional features found there.
//! - [`context`]: [`GpuContext`], a device plus the passes every scene shares.
//! - [`counted`]: counts of the buffers, bind groups, passes and submissions made
//!   (every one goes through `GpuDevice` and its counting [`counted::Encoder`]).
//! - [`prelude`]: the constants the kernels share with Rust, generated into every
//!   shader from the Rust ones.
//! - [`encode`]: binding entries, uniform slots and dispatch shapes.
//! - [`arena`]: grow-only buffers and cached bind groups, kept between batches.
//! - [`scene_buffers`]: a scene's vertices, indices and test boxes, uploaded once.
//! - [`raster`]: occluder raster (view depth) and oracle raster (object IDs), sharing
//!   one invariant vertex stage (twin: `hom/raster.rs`).
//! - [`pyramid`]: the 2×2 reductions, two levels per dispatch (compute); level 0 is
//!   the occlusion map itself (twin: `hom/pyramid.rs`).
//! - [`test`]: the per-object HOM / HZB test (compute), writing a bitmask (twin:
//!   `hom/test.rs`).
//! - [`refine`]: HOM's refinement: the box test's survivors re-rasterized against the
//!   occluders' depth buffer (early depth tests where the adapter can force them),
//!   writing a second bitmask (twin: `hom/refine.rs`).
//! - [`oracle`]: ID buffer → visibility bitmask (compute; twin: `reference/oracle.rs`).
//! - [`targets`], [`passes`]: the atlas (a viewport-sized slot per pose of a group)
//!   and the pipelines every scene on a device shares.
//! - [`inputs`]: what a batch writes before it records (pose uniforms, draws, each
//!   pass's inputs), in buffers kept between batches.
//! - [`readback`]: buffer and texture readback.
//! - [`in_flight`]: batches submitted and not yet read back (the host records the next
//!   batch while the device runs one).
//! - [`batch`]: [`GpuBackend`], which records all passes of a batch of poses into one
//!   submission with one readback, a fixed number of passes per group of poses.
//! - [`profile`]: GPU time per pass from timestamps written between the passes.
//!
//! Tests run every pass and its CPU twin on the same input.

pub mod arena;
pub mod batch;
pub mod context;
pub mod counted;
pub mod device;
pub mod encode;
pub mod in_flight;
pub mod inputs;
pub mod oracle;
pub mod passes;
pub mod prelude;
pub mod profile;
pub mod pyramid;
pub mod raster;
pub mod readback;
pub mod refine;
pub mod scene_buffers;
pub mod targets;
pub mod test;

pub use batch::GpuBackend;
pub use context::{GpuContext, open_gpu, require_gpu};
pub use counted::RecordCounts;
pub use device::{GpuDevice, GpuError, GpuOptions};
pub use encode::UNIFORM_SLOT;
