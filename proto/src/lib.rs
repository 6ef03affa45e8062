//! Wire types of homcull: what crosses the network between the server and its clients.
//!
//! Everything here is plain data with serde derives, so the server, the CLI and the
//! test clients agree on one shape. Geometry conventions (units, axes, what a pose
//! means) are defined once in the server crate's `camera` module; this crate only
//! carries the numbers.
//!
//! # Layout
//! - [`Pose`]: a camera pose as clients send it.
//! - [`CullOptions`] (declared once with its defaults per [`Surface`]), [`Method`],
//!   [`DebVariant`]: how to cull.
//! - [`CullStats`], [`CullResponse`]: what a cull answers.
//! - [`lod`]: level-of-detail thresholds ([`LodThresholds`]) and levels.
//! - [`rest`]: the other JSON bodies of the REST API (scenes, objects, batches, errors).
//! - [`frame`]: binary WebSocket frames, encoder and decoder.

use serde::{Deserialize, Serialize};

pub mod frame;
pub mod lod;
mod options;
pub mod rest;

pub use lod::{InvalidLod, LodSpec, LodThresholds, MAX_LOD_THRESHOLDS};
pub use options::{CullOptions, CullOptionsQuery, InvalidOptions, Surface};
pub use rest::*;

/// Version of the wire protocol; bumped on every incompatible change. Binary frames carry
/// it in the low 16 bits of header word 1, the Hello's JSON as `protocol_version`.
/// Version 2 shrank the header and the stats block so that deltas stay small; version 3
/// added the frames with levels of detail (kinds 6 and 7); version 4 names the scene
/// version in the stats block and added the writer's frames (kinds 8 and 9); version
/// 5 added the region frame (kind 10).
pub const PROTOCOL_VERSION: u32 = 5;

/// A camera pose (conventions in ARCHITECTURE.md: right-handed, Y up, metres).
///
/// Orientation is either `rotation` (a unit quaternion `[x, y, z, w]`; the camera looks
/// along its local −Z with +Y up, as a glTF camera) or `look_at` (a world point) with an
/// optional `up` (default +Y). Giving both is an error; giving neither looks along −Z.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pose {
    /// Eye position in metres, world space.
    pub position: [f32; 3],
    /// Orientation as a quaternion `[x, y, z, w]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation: Option<[f32; 4]>,
    /// A world point the camera looks at.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub look_at: Option<[f32; 3]>,
    /// Up vector used with `look_at`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub up: Option<[f32; 3]>,
    /// Vertical field of view in degrees.
    #[serde(default = "default_fov")]
    pub fov_y_deg: f32,
    /// Viewport `[width, height]` in pixels.
    #[serde(default = "default_viewport")]
    pub viewport: [u32; 2],
    /// Near plane distance in metres.
    #[serde(default = "default_near")]
    pub near: f32,
    /// Far plane distance in metres.
    #[serde(default = "default_far")]
    pub far: f32,
    /// Both eyes of a stereo display in one query: the answer holds every object either
    /// eye may see (see [`Stereo`]). Absent: one eye at `position`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stereo: Option<Stereo>,
    /// Visibility from a region: the answer holds every object that an eye anywhere in
    /// the region, looking any way it allows, may see (see [`Region`]). Absent: the
    /// answer holds for the pose's own eye and view.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub region: Option<Region>,
}

/// The eyes and view directions an answer holds for: every eye within `radius_m` of
/// the pose's position, or every eye in `box` (which must hold the position); every
/// view direction within `turn_deg` of the pose's, or every direction with
/// `all_directions`. The pose's viewport and field of view fix the pixel size the
/// answer is culled at; it holds for every eye's pixel grid.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Region {
    /// Radius of the ball of eyes around `position`, metres, in (0, 5].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius_m: Option<f32>,
    /// `[[x0, y0, z0], [x1, y1, z1]]`: the box of eyes (min and max corners), holding
    /// `position`, its diagonal at most 10 m. Instead of `radius_m`.
    #[serde(default, rename = "box", skip_serializing_if = "Option::is_none")]
    pub bounds: Option<[[f32; 3]; 2]>,
    /// View directions within this angle of the pose's, degrees, in [0, 45] (default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub turn_deg: Option<f32>,
    /// Every view direction (instead of `turn_deg`).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub all_directions: bool,
}

/// Two eyes a few centimetres apart: `position` is the point between them, the eyes sit
/// `ipd_m / 2` to its left and right along the camera's right axis, and both look along
/// the pose's direction (parallel optical axes). With `convergence_m` each eye's frustum
/// is shifted sideways (off-axis) so that the two images coincide at that view depth,
/// the zero-parallax plane; without it the frusta are symmetric (zero parallax at
/// infinity). Both eyes use the pose's field of view, viewport, near and far.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stereo {
    /// Distance between the eyes in metres, in (0, 1].
    pub ipd_m: f32,
    /// View depth of the zero-parallax plane in metres, beyond `near`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub convergence_m: Option<f32>,
}

fn default_fov() -> f32 {
    60.0
}
fn default_viewport() -> [u32; 2] {
    [960, 540]
}
fn default_near() -> f32 {
    0.1
}
fn default_far() -> f32 {
    5000.0
}

impl Pose {
    /// A pose at `position` looking at `target`, with the other fields at their defaults.
    pub fn looking_at(position: [f32; 3], target: [f32; 3]) -> Self {
        Pose {
            position,
            rotation: None,
            look_at: Some(target),
            up: None,
            fov_y_deg: default_fov(),
            viewport: default_viewport(),
            near: default_near(),
            far: default_far(),
            stereo: None,
            region: None,
        }
    }
}

/// Culling method.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Hierarchical Occlusion Maps (the default).
    #[default]
    Hom,
    /// Hierarchical z-buffer of the same occluders.
    Hzb,
    /// View-frustum culling only.
    Frustum,
    /// The exact ID-buffer oracle.
    Exact,
}

impl Method {
    /// All methods, in report order.
    pub const ALL: [Method; 4] = [Method::Hom, Method::Hzb, Method::Frustum, Method::Exact];

    /// The lowercase name used on the wire and the command line.
    pub fn name(self) -> &'static str {
        match self {
            Method::Hom => "hom",
            Method::Hzb => "hzb",
            Method::Frustum => "frustum",
            Method::Exact => "exact",
        }
    }
}

impl std::fmt::Display for Method {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Method {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Method::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| format!("unknown method `{s}` (expected hom, hzb, frustum or exact)"))
    }
}

/// Depth estimation buffer variant: how HOM's test bounds the occluders' depth.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum DebVariant {
    /// One plane at the farthest occluder bounding-box corner.
    Plane,
    /// Screen tiles holding the farthest bbox-corner depth of the occluders touching them.
    Tiles,
    /// Per-pixel depth of the rasterized occluders, max-reduced alongside the pyramid.
    #[default]
    Raster,
}

impl DebVariant {
    /// All variants, in report order.
    pub const ALL: [DebVariant; 3] = [DebVariant::Plane, DebVariant::Tiles, DebVariant::Raster];

    /// The lowercase name used on the wire and the command line.
    pub fn name(self) -> &'static str {
        match self {
            DebVariant::Plane => "plane",
            DebVariant::Tiles => "tiles",
            DebVariant::Raster => "raster",
        }
    }
}

impl std::fmt::Display for DebVariant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for DebVariant {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        DebVariant::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| format!("unknown DEB variant `{s}` (expected plane, tiles or raster)"))
    }
}

/// What one cull did, for clients and dashboards.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CullStats {
    /// Objects in the scene.
    pub objects: u32,
    /// Objects whose bounds intersect the view frustum.
    pub candidates: u32,
    /// Objects removed by the frustum test.
    pub culled_by_frustum: u32,
    /// In-frustum objects removed by the occlusion test.
    pub culled_by_occlusion: u32,
    /// Occluders rendered into the occlusion map.
    pub occluders_used: u32,
    /// Occluder triangles rendered (the runtime budget spent).
    pub occluder_triangles: u32,
    /// GPU (or CPU fallback) time of the batch this pose was part of, divided by its size.
    pub gpu_ms: f64,
    /// Wall time of the whole cull of this pose's batch, divided by its size.
    pub total_ms: f64,
    /// The scene version the answer is conservative for: 0 as loaded, one more for
    /// each accepted `POST /v1/scenes/{id}/transforms`.
    #[serde(default)]
    pub scene_version: u64,
}

/// Answer to one pose: visible object IDs in ascending order and statistics.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CullResponse {
    /// IDs of the objects that may be visible, ascending.
    pub visible: Vec<u32>,
    /// With `options.lod`: the level of detail of each visible object, in the order of
    /// `visible` (0 the finest; see [`lod`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lod: Option<Vec<u8>>,
    /// What the cull did.
    pub stats: CullStats,
}
