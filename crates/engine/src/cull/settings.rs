//! Everything that shapes a cull besides the poses: the options, the method they name
//! ([`CullMethod`]) and the planning limits.

use homcull_proto::{CullOptions, DebVariant};

use super::error::CullError;
use super::method::{BoxTest, CullMethod, Passes};
use super::methods;
use super::prepared::PreparedScene;
use crate::cull::deb::DEFAULT_TILE;

/// Everything that shapes a cull besides the poses.
#[derive(Debug, Clone, Copy)]
pub struct CullSettings {
    pub options: CullOptions,
    /// The method that culls: `options.method`'s ([`methods::of`]) unless replaced by
    /// [`CullSettings::with_method`].
    pub method: &'static dyn CullMethod,
    /// Occluder triangles rendered per pose.
    pub budget_triangles: u32,
    /// Tile side of the `tiles` DEB, pixels.
    pub deb_tile: u32,
}

impl PartialEq for CullSettings {
    fn eq(&self, other: &Self) -> bool {
        self.options == other.options
            && self.method.name() == other.method.name()
            && self.budget_triangles == other.budget_triangles
            && self.deb_tile == other.deb_tile
    }
}

impl CullSettings {
    pub fn new(options: CullOptions, prepared: &PreparedScene) -> Self {
        CullSettings {
            options,
            method: methods::of(options.method),
            budget_triangles: prepared.occluders.params.budget_triangles,
            deb_tile: DEFAULT_TILE,
        }
    }

    /// These settings culling with `method` instead of the one `options` name: a
    /// method of the caller's own, not on the wire.
    pub fn with_method(self, method: &'static dyn CullMethod) -> Self {
        CullSettings { method, ..self }
    }

    /// Checks the options ([`CullOptions::validate`]).
    pub fn validate(&self) -> Result<(), CullError> {
        Ok(self.options.validate()?)
    }

    /// The image-space passes of the method ([`CullMethod::passes`]).
    pub fn passes(&self) -> Option<Passes> {
        self.method.passes(&self.options)
    }

    /// The box test of the method's occlusion passes, if it has them.
    pub fn box_test(&self) -> Option<BoxTest> {
        match self.passes() {
            Some(Passes::Occlusion { test, .. }) => Some(test),
            Some(Passes::Exact) | None => None,
        }
    }

    /// True when the method renders occluders and tests boxes against them (the plan
    /// then selects occluders and in-frustum test boxes).
    pub fn uses_occluders(&self) -> bool {
        self.method.needs(&self.options).occluders
    }

    /// The depth estimation buffer the plan builds.
    pub fn deb_variant(&self) -> DebVariant {
        self.method.needs(&self.options).deb
    }

    /// True when the box test's survivors are refined per pixel (`hom` with `refine`).
    pub fn refines(&self) -> bool {
        matches!(self.passes(), Some(Passes::Occlusion { refine: true, .. }))
    }
}
