//! Level-of-detail hints: a level per visible object from its size on screen.
//!
//! A thin client that draws what the server says is visible can also draw small
//! objects coarser. The seed's discrete LOD picks a level by distance; here the level
//! follows the object's projected size in pixels, so that it follows the resolution and
//! field of view too: the larger side of the object's bounding box projected, clipped
//! at the near plane and clamped to the viewport ([`Camera::projected_bounds`]), in
//! float pixels, and for several eyes the largest of them. The thresholds turn a size
//! into a level ([`LodThresholds::level`]: ties go to the finer level).
//!
//! Hints are computed from the answer, after the cull, so they never change what is
//! visible; an object drawn coarser is the client's choice.

use homcull_proto::LodThresholds;

use crate::camera::Camera;
use crate::geom::Aabb;

/// The projected size of `aabb` in pixels: the larger side of its projected bounds, the
/// largest over `eyes` (0 where it projects to nothing).
pub fn projected_size(eyes: &[Camera], aabb: &Aabb) -> f32 {
    eyes.iter()
        .filter_map(|cam| cam.projected_bounds(aabb))
        .map(|(lo, hi)| (hi[0] - lo[0]).max(hi[1] - lo[1]))
        .fold(0.0, f32::max)
}

/// The level of each of `ids` (in order) seen by `eyes`, `bounds(id)` its box.
pub fn levels(
    eyes: &[Camera],
    ids: &[u32],
    bounds: impl Fn(u32) -> Aabb,
    thresholds: &LodThresholds,
) -> Vec<u8> {
    ids.iter()
        .map(|&id| thresholds.level(projected_size(eyes, &bounds(id))))
        .collect()
}
