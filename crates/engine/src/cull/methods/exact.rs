//! `exact`: the ID-buffer oracle that defines ground truth. Every candidate is
//! rasterized at the pose's viewport; an object is visible where it owns a pixel.

use homcull_proto::CullOptions;

use crate::cull::method::{CullMethod, Needs, Passes};

/// The exact ID-buffer oracle.
#[derive(Debug, Clone, Copy, Default)]
pub struct Exact;

impl CullMethod for Exact {
    fn name(&self) -> &'static str {
        "exact"
    }

    fn needs(&self, _: &CullOptions) -> Needs {
        Needs::FRUSTUM
    }

    fn passes(&self, _: &CullOptions) -> Option<Passes> {
        Some(Passes::Exact)
    }
}
