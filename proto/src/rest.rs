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
    /// World AABB `[min, max]`.
    pub aabb: [[f32; 3]; 2],
    pub triangles: u32,
    /// True when preprocessing selected the object as an occluder.
    pub occluder: bool,
}

/// `GET /v1/scenes/{id}/objects`.
#[cfg_attr(feature = "openapi", derive(utoipa::ToSchema))]
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObjectList {
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
