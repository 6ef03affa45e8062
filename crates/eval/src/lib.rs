//! Measuring the core: quality against the exact oracle, why hidden objects are kept,
//! the OpenArena PVS audit, the report, and a loopback load generator for the server.
//!
//! Nothing here is on a serving path; the server does not depend on this layer.

pub mod animate;
pub mod compare;
pub mod latency;
pub mod loadgen;
pub mod loss;
pub mod percentiles;
pub mod pvs_audit;
pub mod region_eyes;
pub mod report;
pub mod walkers;

pub use compare::{EvalReport, MethodReport, MethodSpec, evaluate, table};
