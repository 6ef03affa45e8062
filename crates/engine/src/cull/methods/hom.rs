//! `hom`: Hierarchical Occlusion Maps, the default. The occluders' opacity pyramid and
//! depth estimation buffer (the options' `deb`) test each box; with `refine` (the
//! default) the survivors are re-tested per pixel of their own triangles.

use homcull_proto::CullOptions;

use crate::cull::method::{BoxTest, CullMethod, Needs, Passes};

/// Hierarchical Occlusion Maps.
#[derive(Debug, Clone, Copy, Default)]
pub struct Hom;

impl CullMethod for Hom {
    fn name(&self) -> &'static str {
        "hom"
    }

    fn needs(&self, options: &CullOptions) -> Needs {
        Needs {
            occluders: true,
            deb: options.deb,
        }
    }

    fn passes(&self, options: &CullOptions) -> Option<Passes> {
        Some(Passes::Occlusion {
            test: BoxTest::Hom,
            refine: options.refine,
        })
    }
}
