//! JSON bodies of the REST API (`/v1/...`) besides the cull types in the crate root.

use serde::{Deserialize, Serialize};

use crate::{CullOptions, CullResponse, Pose};

/// A resident scene, as listed by `GET /v1/scenes` and returned by uploads.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SceneInfo {
    /// Stable identifier used in URLs (`demo` for the built-in city).
    pub id: String,
    /// Human-readable name (the upload's `name`, or the file's scene name).
    pub name: String,
    /// Objects in the scene (IDs are `0..objects`).
    pub objects: u32,
    /// Triangles in the scene.
    pub triangles: u32,
    /// Objects selected as occluders by preprocessing.
    pub occluders: u32,
    /// Objects marked dynamic (see `ObjectInfo::dynamic`).
    #[serde(default)]
    pub dynamic_objects: u32,
    /// World bounds `[min, max]` of all objects.
    pub bounds: [[f32; 3]; 2],
    /// Size in bytes of the scene's GLB (`GET /v1/scenes/{id}/glb`).
    pub glb_bytes: u64,
    /// Warnings raised while loading (skipped primitives and the like).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    /// Where a walker may start: a street-level eye in open space, looking level
    /// (absent when none was found, e.g. a scene without floors).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start: Option<WalkStart>,
}

/// A standing eye and a point it looks at, at the same height.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WalkStart {
    pub position: [f32; 3],
    pub look_at: [f32; 3],
}

/// `GET /v1/scenes`.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SceneList {
    pub scenes: Vec<SceneInfo>,
}

/// One row of a scene's object table.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObjectInfo {
    pub id: u32,
    pub name: String,
    /// World AABB `[min, max]` where the object is now (at the list's `version`).
    pub aabb: [[f32; 3]; 2],
    /// World AABB `[min, max]` where the scene file puts it.
    #[serde(default)]
    pub file_aabb: [[f32; 3]; 2],
    /// Where a writer placed it, relative to the file (absent: as loaded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub placement: Option<ObjectPlacement>,
    pub triangles: u32,
    /// True when preprocessing selected the object as an occluder.
    pub occluder: bool,
    /// Marked as one that will move (glTF node extras `"homcull": {"dynamic": true}`
    /// or the upload's `dynamic` parameter); any object may move, marked or not.
    #[serde(default)]
    pub dynamic: bool,
}

/// An object's placement as `GET /v1/scenes/{id}/objects` reports it: what a
/// transforms entry with this `matrix`, `velocity`, `angular_velocity` and `valid_ms`
/// would set again.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObjectPlacement {
    /// Column-major affine 4×4 applied in world space to the file's vertices.
    pub matrix: [f32; 16],
    /// Metres per second.
    pub velocity: [f32; 3],
    /// Radians per second about the vector, about the centre of the placed bounds.
    pub angular_velocity: [f32; 3],
    /// How long the motion holds, ms (absent: until the next update).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub valid_ms: Option<f64>,
}

/// `GET /v1/scenes/{id}/objects`.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObjectList {
    /// The scene version the bounds and placements belong to.
    #[serde(default)]
    pub version: u64,
    pub objects: Vec<ObjectInfo>,
}

/// `POST /v1/scenes/{id}/cull`: one pose and how to cull it.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CullRequest {
    pub pose: Pose,
    #[serde(default)]
    pub options: CullOptions,
}

/// `POST /v1/scenes/{id}/cull/batch`.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BatchRequest {
    pub poses: Vec<Pose>,
    #[serde(default)]
    pub options: CullOptions,
}

/// Answer to a batch, in pose order.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BatchResponse {
    pub results: Vec<CullResponse>,
}

/// The one error shape of the API: `{"error": {"code": "...", "message": "..."}}`.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorBody {
    pub error: ErrorDetail,
}

#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ErrorDetail {
    /// Machine-readable code, e.g. `invalid_pose`, `unknown_scene`, `batch_too_large`.
    pub code: String,
    /// What went wrong, for people.
    pub message: String,
}

impl ErrorBody {
    pub fn new(code: impl Into<String>, message: impl Into<String>) -> Self {
        ErrorBody {
            error: ErrorDetail {
                code: code.into(),
                message: message.into(),
            },
        }
    }
}

/// A pose sent over WebSocket as JSON text (the binary pose frame carries the same).
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseMessage {
    /// The client's pose sequence number; answers carry it back.
    pub seq: u32,
    pub pose: Pose,
    /// Ask for a full frame instead of a delta.
    #[serde(default)]
    pub full: bool,
}

/// `POST /v1/scenes/{id}/transforms`: new placements (and motion) of objects, applied
/// all together or not at all.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformsRequest {
    pub objects: Vec<ObjectTransform>,
    /// How far ahead (ms) an object with a velocity is bounded (its temporal bounding
    /// volume); kept for later requests that leave it out. Default 100 ms.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub horizon_ms: Option<f64>,
}

/// One object's placement relative to where the scene file put it, and its motion.
///
/// Either `matrix` (column-major 4×4 affine, applied in world space to the object as
/// loaded) or any of `translation`, `rotation`, `scale`, which turn and scale the
/// object about the centre of its loaded bounds and then move it. Neither: the object
/// goes back to where the file put it. The placement replaces the previous one.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectTransform {
    pub id: u32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub matrix: Option<[f32; 16]>,
    /// Metres.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub translation: Option<[f32; 3]>,
    /// Unit quaternion `[x, y, z, w]` (normalised on arrival).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation: Option<[f32; 4]>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<[f32; 3]>,
    /// Metres per second: the object may move this way from its new placement.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub velocity: Option<[f32; 3]>,
    /// Radians per second about the axis it points along, turning the object about
    /// the centre of its bounds.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub angular_velocity: Option<[f32; 3]>,
    /// How long (ms) the motion holds; the bounds cover the shorter of this and the
    /// horizon. Default: until the next update of the object.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub valid_ms: Option<f64>,
}

/// Answer to an accepted `POST /v1/scenes/{id}/transforms`.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TransformsResponse {
    /// The scene version the update made; culls from now on name it or a later one.
    pub version: u64,
    /// Objects updated.
    pub applied: u32,
}
