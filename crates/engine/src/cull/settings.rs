//! Everything that shapes a cull besides the poses, and what each method asks of the
//! shared planning: the one place a method is described to every backend.

use homcull_proto::{CullOptions, DebVariant, Method};

use super::error::CullError;
use super::prepared::PreparedScene;
use crate::cull::deb::DEFAULT_TILE;

/// Everything that shapes a cull besides the poses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CullSettings {
    pub options: CullOptions,
    /// Occluder triangles rendered per pose.
    pub budget_triangles: u32,
    /// Tile side of the `tiles` DEB, pixels.
    pub deb_tile: u32,
}

impl CullSettings {
    pub fn new(options: CullOptions, prepared: &PreparedScene) -> Self {
        CullSettings {
            options,
            budget_triangles: prepared.occluders.params.budget_triangles,
            deb_tile: DEFAULT_TILE,
        }
    }

    /// Checks the options ([`CullOptions::validate`]).
    pub fn validate(&self) -> Result<(), CullError> {
        Ok(self.options.validate()?)
    }

    /// True when the method renders occluders and tests boxes against them (the plan
    /// then selects occluders and in-frustum test boxes).
    pub fn uses_occluders(&self) -> bool {
        match self.options.method {
            Method::Hom | Method::Hzb => true,
            Method::Frustum | Method::Exact => false,
        }
    }

    /// True when the method needs image-space work at all (`frustum` is the BVH alone).
    pub fn uses_image(&self) -> bool {
        self.options.method != Method::Frustum
    }

    /// The depth estimation buffer the plan builds: `hom` follows its options, `hzb`
    /// compares against the depth pyramid itself (the raster DEB).
    pub fn deb_variant(&self) -> DebVariant {
        match self.options.method {
            Method::Hom => self.options.deb,
            Method::Hzb | Method::Frustum | Method::Exact => DebVariant::Raster,
        }
    }

    /// True when the box test's survivors are refined per pixel (`hom` with `refine`).
    pub fn refines(&self) -> bool {
        self.options.method == Method::Hom && self.options.refine
    }
}
