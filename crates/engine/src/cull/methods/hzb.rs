//! `hzb`: a hierarchical z-buffer of the same occluders, the baseline HOM is measured
//! against. Each box is compared with the farthest occluder depth over its rect; no
//! refinement.

use homcull_proto::{CullOptions, DebVariant};

use crate::cull::method::{BoxTest, CullMethod, Needs, Passes};

/// A hierarchical z-buffer.
#[derive(Debug, Clone, Copy, Default)]
pub struct Hzb;

impl CullMethod for Hzb {
    fn name(&self) -> &'static str {
        "hzb"
    }

    fn needs(&self, _: &CullOptions) -> Needs {
        // It compares against the depth pyramid itself: the raster DEB.
        Needs {
            occluders: true,
            deb: DebVariant::Raster,
        }
    }

    fn passes(&self, _: &CullOptions) -> Option<Passes> {
        Some(Passes::Occlusion {
            test: BoxTest::Hzb,
            refine: false,
        })
    }
}
