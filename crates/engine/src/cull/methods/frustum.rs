//! `frustum`: view-frustum culling alone. The plan's BVH query answers: every object
//! whose bounds meet the frustum.

use homcull_proto::CullOptions;

use crate::cull::method::{CullMethod, Needs, Passes};

/// View-frustum culling only.
#[derive(Debug, Clone, Copy, Default)]
pub struct Frustum;

impl CullMethod for Frustum {
    fn name(&self) -> &'static str {
        "frustum"
    }

    fn needs(&self, _: &CullOptions) -> Needs {
        Needs::FRUSTUM
    }

    fn passes(&self, _: &CullOptions) -> Option<Passes> {
        None
    }
}
