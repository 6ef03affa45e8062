//! The culling core: everything needed to answer "what may be visible from this pose?"
//! for a resident scene, with no notion of a network, a command line or an evaluation.
//!
//! Read in data-flow order:
//! - [`geom`], [`camera`]: boxes, planes, poses, projection and every convention.
//! - [`scene`]: glTF loading, objects and their test boxes, the demo city.
//! - [`bvh`], [`occluders`]: the object BVH and the occluder database with its
//!   per-pose selection.
//! - [`cull`]: the seam between callers and backends: the [`cull::Culler`] trait,
//!   settings, the per-pose plan, pass times and errors.
//! - [`dynamic`]: moving objects: placements writers send, scene versions, and the
//!   temporal bounding volumes of objects in motion.
//! - [`reference`]: the CPU reference backend, the algorithm pass by pass; every GPU pass's
//!   twin and test oracle.
//! - [`native`]: the native CPU backend, the same algorithm as spans and tile bounds,
//!   fast enough to serve from CPU cores.
//! - [`gpu`]: the wgpu backend, the same passes batched on a device.
//! - [`engine`], [`resident`]: a prepared scene with its backend, and the one place a
//!   resident scene (engine, PVS, walk start, object table) is assembled.
//! - [`lod`]: level-of-detail hints from each visible object's size on screen.
//! - [`pvs`], [`sampler`]: what a scene knows of its own playable space (the maps'
//!   potentially-visible sets, street-level eyes), used to serve and to evaluate.
//! - [`region`], [`viewcells`]: answers that hold for a region of eyes and view
//!   directions, and the per-cell PVS precomputed from them.

pub mod bvh;
pub mod camera;
pub mod cull;
pub mod dynamic;
pub mod engine;
pub mod geom;
pub mod gpu;
pub mod lod;
pub mod native;
pub mod occluders;
pub mod pvs;
pub mod reference;
pub mod region;
pub mod resident;
pub mod sampler;
pub mod scene;
pub mod viewcells;
