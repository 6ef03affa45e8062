//! The part of an occluder triangle that a region map draws: what lies beyond a clip
//! depth between the map's near plane and the nearest depth a blocking point may have,
//! in one or two screen triangles whose edges remember where they came from.
//!
//! Floors, ceilings and long walls run past the eye; without their near parts a map
//! would leave everything below the horizon untouched. The clipped part ends at the
//! clip line, where the drawn surface ends though the scene's does not: the cells
//! that line touches hold a depth nearer than any blocking point may be, so the box
//! test refuses every neighbourhood holding them, and the line needs no leak.

use glam::Vec3;

use super::raster::{ScreenTriangle, screen_triangle};
use crate::camera::Camera;

/// Where an edge of a drawn piece comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Source {
    /// The part `[t0, t1]` of the triangle's edge `e` (`corner e + t·(corner e+1 − corner e)`).
    Edge { e: usize, t0: f32, t1: f32 },
    /// The clip line, or the diagonal between a clipped quad's two halves.
    Cut,
}

/// A drawn part of an occluder triangle.
pub(super) struct Piece {
    /// The triangle's global index.
    pub(super) tri: u32,
    pub(super) t: ScreenTriangle,
    /// The source of edge `k` (from corner `k` to `k + 1`) of `t`.
    pub(super) edges: [Source; 3],
    /// Whether `t` is the whole triangle, corners in its order.
    pub(super) whole: bool,
}

/// The drawn pieces of triangle `tri` with `corners`: the whole triangle where it lies
/// beyond depth `clip`, else its part beyond `clip` (one or two pieces); none where a
/// corner lies beyond the far plane or the part has no area on the map.
pub(super) fn pieces(cam: &Camera, tri: u32, corners: [Vec3; 3], clip: f32) -> Vec<Piece> {
    let depth = corners.map(|c| -(cam.view * c.extend(1.0)).z);
    if !depth.iter().all(|&d| d <= cam.far) {
        return Vec::new(); // beyond the far plane, or not a number
    }
    if depth.iter().all(|&d| d >= clip) {
        let whole = screen_triangle(cam, corners).map(|t| Piece {
            tri,
            t,
            edges: std::array::from_fn(|e| Source::Edge {
                e,
                t0: 0.0,
                t1: 1.0,
            }),
            whole: true,
        });
        return whole.into_iter().collect();
    }
    // The polygon beyond the clip depth, each corner with the edge it lies on and
    // where along it.
    let inside = |i: usize| depth[i] >= clip;
    let mut polygon: Vec<(Vec3, usize, f32)> = Vec::with_capacity(4);
    for e in 0..3 {
        let f = (e + 1) % 3;
        if inside(e) {
            polygon.push((corners[e], e, 0.0));
        }
        if inside(e) != inside(f) {
            let s = (depth[e] - clip) / (depth[e] - depth[f]);
            polygon.push((corners[e].lerp(corners[f], s), e, s));
        }
    }
    let n = polygon.len();
    if n < 3 {
        return Vec::new();
    }
    // Polygon edge k runs from corner k to k + 1.
    let source = |k: usize| {
        let (_, ea, ta) = polygon[k];
        let (_, eb, tb) = polygon[(k + 1) % n];
        if eb == ea {
            Source::Edge {
                e: ea,
                t0: ta,
                t1: tb,
            }
        } else if eb == (ea + 1) % 3 && tb == 0.0 {
            Source::Edge {
                e: ea,
                t0: ta,
                t1: 1.0,
            }
        } else {
            Source::Cut
        }
    };
    // A fan from corner 0: the diagonals are cuts.
    (1..n - 1)
        .filter_map(|k| {
            let t = screen_triangle(cam, [polygon[0].0, polygon[k].0, polygon[k + 1].0])?;
            let first = if k == 1 { source(0) } else { Source::Cut };
            let last = if k + 1 == n - 1 {
                source(n - 1)
            } else {
                Source::Cut
            };
            Some(Piece {
                tri,
                t,
                edges: [first, source(k), last],
                whole: false,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use homcull_proto::Pose;

    fn camera() -> Camera {
        Camera::new(&Pose::looking_at([0.0, 0.0, 0.0], [0.0, 0.0, -1.0])).unwrap()
    }

    #[test]
    fn a_floor_running_past_the_eye_keeps_its_part_beyond_the_clip_depth() {
        let cam = camera();
        // One corner behind the eye, two ahead: the part beyond depth 1 is a quad.
        let floor = [
            Vec3::new(0.0, -1.7, 5.0),
            Vec3::new(10.0, -1.7, -20.0),
            Vec3::new(-10.0, -1.7, -20.0),
        ];
        let parts = pieces(&cam, 7, floor, 1.0);
        assert_eq!(parts.len(), 2, "a quad in two halves");
        let mut kept_edges = Vec::new();
        for p in &parts {
            assert!(!p.whole);
            assert!(
                p.t.depth.iter().all(|&d| d >= 1.0 - 1e-4),
                "{:?}",
                p.t.depth
            );
            kept_edges.extend(p.edges.iter().filter_map(|s| match *s {
                Source::Edge { e, t0, t1 } => Some((e, t0, t1)),
                Source::Cut => None,
            }));
        }
        kept_edges.sort_by(|a, b| a.partial_cmp(b).unwrap());
        // Edge 1 whole; edges 0 and 2 from or up to where they cross depth 1.
        assert_eq!(kept_edges.len(), 3, "{kept_edges:?}");
        let (s0, s2) = (6.0 / 25.0, 19.0 / 25.0);
        let close = |a: f32, b: f32| (a - b).abs() < 1e-5;
        assert!(kept_edges[0].0 == 0 && close(kept_edges[0].1, s0) && kept_edges[0].2 == 1.0);
        assert_eq!(kept_edges[1], (1, 0.0, 1.0));
        assert!(kept_edges[2].0 == 2 && kept_edges[2].1 == 0.0 && close(kept_edges[2].2, s2));
    }

    #[test]
    fn a_triangle_beyond_the_clip_depth_is_drawn_whole_and_one_behind_not_at_all() {
        let cam = camera();
        let ahead = [
            Vec3::new(0.0, 0.0, -5.0),
            Vec3::new(1.0, 0.0, -5.0),
            Vec3::new(0.0, 1.0, -5.0),
        ];
        let parts = pieces(&cam, 0, ahead, 1.0);
        assert!(parts.len() == 1 && parts[0].whole);
        let behind = ahead.map(|c| c * Vec3::new(1.0, 1.0, -1.0));
        assert!(pieces(&cam, 0, behind, 1.0).is_empty());
    }
}
