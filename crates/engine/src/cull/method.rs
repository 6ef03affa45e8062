//! [`CullMethod`]: one type per culling method (the wire's are in `methods/`, which
//! registers them).
//!
//! A method is a recipe: what the shared planning prepares for it ([`Needs`]) and which
//! image-space passes then cull its poses ([`Passes`]), or, for a method without
//! passes, how its answer follows from the plan alone ([`CullMethod::mask_from_plan`]).
//! Backends run passes, not methods: a method made of passes that exist is one new file
//! (see `methods/`); a new pass is a [`Passes`] variant that every backend's match
//! must then answer, with its work or with [`CullError::Unsupported`] (the compiler
//! finds each one: the matches over it have no wildcard arm).
//!
//! A method on the wire is a variant of `homcull_proto::Method` and one arm of
//! [`super::methods::of`], whose match has no wildcard either, so a variant without its method does not
//! compile; a library's own method (not on the wire) is given to a cull with
//! [`super::CullSettings::with_method`].

use homcull_proto::{CullOptions, DebVariant};

use super::mask::{empty_mask, set_bit};
use super::prepared::PreparedScene;
use crate::camera::Camera;

#[cfg(doc)]
use super::{CullError, Culler};

/// One culling method. A cull checks [`CullMethod::runs_on`] with
/// [`Culler::name`] before it plans.
pub trait CullMethod: std::fmt::Debug + Send + Sync + 'static {
    /// Its name: the wire name for a method of `homcull_proto::Method`.
    fn name(&self) -> &'static str;

    /// What the shared planning prepares for it under `options`.
    fn needs(&self, options: &CullOptions) -> Needs;

    /// The image-space passes that cull a batch of its planned poses under `options`,
    /// on every backend that has them; `None`: the plan alone answers
    /// ([`CullMethod::mask_from_plan`]).
    fn passes(&self, options: &CullOptions) -> Option<Passes>;

    /// Whether it runs on the backend of this short name (`Culler::name`); a cull on
    /// one it does not run on is refused with [`CullError::Unsupported`]. Every
    /// backend by default: each backend runs every [`Passes`] variant.
    fn runs_on(&self, _backend: &str) -> bool {
        true
    }

    /// The visibility bitmask of one planned pose from its camera and its in-frustum
    /// `candidates` (ascending), for a method without passes: by default every
    /// candidate (frustum culling).
    fn mask_from_plan(&self, prep: &PreparedScene, _cam: &Camera, candidates: &[u32]) -> Vec<u32> {
        let mut mask = empty_mask(prep.scene.objects.len());
        candidates.iter().for_each(|&c| set_bit(&mut mask, c));
        mask
    }
}

/// What the shared planning prepares for a method.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Needs {
    /// Occluders selected within the budget, and the in-frustum test boxes tested
    /// against them.
    pub occluders: bool,
    /// The depth estimation buffer built from the occluders' boxes.
    pub deb: DebVariant,
}

impl Needs {
    /// Nothing beyond the frustum query.
    pub const FRUSTUM: Needs = Needs {
        occluders: false,
        deb: DebVariant::Raster,
    };
}

/// The image-space passes of a batch: what backends run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Passes {
    /// The occluders drawn into an occlusion map, each in-frustum test box tested
    /// against it, and with `refine` the survivors re-tested per pixel of their own
    /// triangles.
    Occlusion { test: BoxTest, refine: bool },
    /// The exact ID-buffer oracle: every candidate rasterized, the objects owning a
    /// pixel visible.
    Exact,
}

/// How a test box is tested against the occlusion map.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoxTest {
    /// HOM's test: opacity at the options' threshold, then the depth test against the
    /// options' DEB.
    Hom,
    /// A hierarchical z-buffer: the farthest occluder depth over the box's rect.
    Hzb,
}
