//! Depth estimation buffers built from occluder boxes: the depth half of HOM's test
//! for the plane and tiles variants.
//!
//! - Plane (variant 1): one value, the farthest bbox-corner depth of all selected
//!   occluders; everything behind it may be hidden.
//! - Tiles (variant 2, the seed's): the screen is cut into square tiles; each holds the
//!   farthest bbox-corner depth of the occluders whose projected rect touches it.
//!
//! Both are tiny and cheap, so they are built on the CPU per pose and uploaded; the
//! third variant (per-pixel raster depth) is the depth half of the pyramid. A tile no
//! occluder touches holds +∞: nothing there can hide anything, even with approximate
//! thresholds.

use homcull_proto::DebVariant;

use crate::camera::{Camera, ScreenRect};
use crate::geom::Aabb;

/// Relative depth margin: an occluder at view depth `d` hides an object whose nearest
/// depth is `n` only if `d * (1 + DEPTH_MARGIN) < n`. It absorbs float error between
/// interpolated depths, box-corner depths and the oracle's depth buffer (all far
/// below 1e-5 relative), so ties are never culled.
pub const DEPTH_MARGIN: f32 = 1e-4;

/// Whether an occluder depth lies safely in front of an object's nearest depth.
#[inline]
pub fn in_front(occluder_depth: f32, object_near: f32) -> bool {
    occluder_depth * (1.0 + DEPTH_MARGIN) < object_near
}

/// Default tile side in pixels for the tiles variant (the seed's 64).
pub const DEFAULT_TILE: u32 = 64;

/// A grid of depth tiles over the viewport (one tile for the plane variant).
#[derive(Debug, Clone, PartialEq)]
pub struct DepthEstimationBuffer {
    /// Tile side in pixels.
    pub tile: u32,
    pub cols: u32,
    pub rows: u32,
    pub depth: Vec<f32>,
}

impl DepthEstimationBuffer {
    /// Builds the buffer of a box-based variant; the raster variant gets an empty
    /// 1×1 buffer (its depths come from the pyramid).
    pub fn build(
        variant: DebVariant,
        tile: u32,
        cam: &Camera,
        occluders: impl Iterator<Item = Aabb>,
    ) -> Self {
        let tile = match variant {
            DebVariant::Tiles => tile.max(1),
            DebVariant::Plane | DebVariant::Raster => cam.width.max(cam.height),
        };
        let cols = cam.width.div_ceil(tile);
        let rows = cam.height.div_ceil(tile);
        let mut deb = DepthEstimationBuffer {
            tile,
            cols,
            rows,
            depth: vec![f32::INFINITY; (cols * rows) as usize],
        };
        if variant == DebVariant::Raster {
            return deb;
        }
        let mut touched = vec![false; deb.depth.len()];
        for b in occluders {
            let Some(r) = cam.project_box(&b) else {
                continue;
            };
            let (tx0, ty0, tx1, ty1) = deb.tile_range(&r);
            for ty in ty0..=ty1 {
                for tx in tx0..=tx1 {
                    let i = (ty * cols + tx) as usize;
                    deb.depth[i] = if touched[i] {
                        deb.depth[i].max(r.far)
                    } else {
                        r.far
                    };
                    touched[i] = true;
                }
            }
        }
        deb
    }

    /// Inclusive tile range a rect touches.
    pub fn tile_range(&self, r: &ScreenRect) -> (u32, u32, u32, u32) {
        (
            r.x0 / self.tile,
            r.y0 / self.tile,
            (r.x1 - 1) / self.tile,
            (r.y1 - 1) / self.tile,
        )
    }

    /// Whether every tile the rect touches lies in front of `near` (see [`super::in_front`]).
    pub fn all_in_front(&self, r: &ScreenRect, near: f32) -> bool {
        let (tx0, ty0, tx1, ty1) = self.tile_range(r);
        (ty0..=ty1).all(|ty| {
            (tx0..=tx1).all(|tx| in_front(self.depth[(ty * self.cols + tx) as usize], near))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::look_at;
    use glam::Vec3;

    #[test]
    fn tiles_hold_farthest_corner_of_touching_occluders() {
        let cam = look_at(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, 256, 128);
        let near_box = Aabb::new(Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 1.0));
        let deb = DepthEstimationBuffer::build(DebVariant::Tiles, 64, &cam, [near_box].into_iter());
        assert_eq!((deb.cols, deb.rows), (4, 2));
        let centre = (deb.cols + 2) as usize;
        assert!((deb.depth[centre] - 10.0).abs() < 1e-4);
        assert_eq!(deb.depth[0], f32::INFINITY);
        let plane =
            DepthEstimationBuffer::build(DebVariant::Plane, 64, &cam, [near_box].into_iter());
        assert_eq!(plane.depth.len(), 1);
        assert!((plane.depth[0] - 10.0).abs() < 1e-4);
    }
}
