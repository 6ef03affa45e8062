//! A small triangle rasterizer with the GPU's sampling rules, for the CPU reference.
//!
//! Triangles are clipped in homogeneous space against the near (z ≤ w, reversed-Z)
//! and far (z ≥ 0) planes, as GPU clipping does; a pixel is covered when its centre
//! lies inside the projected triangle (edges shared by two triangles go to exactly
//! one of them by a top-left rule); depth is the view depth at the pixel centre,
//! interpolated perspective-correctly. Edge functions use f64 so that vertices far
//! outside the viewport (no guard-band clipping) keep their precision.
//!
//! Used for the occlusion map (nearest depth per pixel) and the exact oracle (ID of the
//! nearest triangle per pixel), so the CPU HOM and the CPU oracle agree on coverage
//! exactly as the GPU's two passes do. The setup ([`screen_polygon`],
//! [`ScreenTriangle`]) is shared with the native backend (`core::native`), whose span
//! rasterizer decides coverage with the very same edge functions.

use glam::{Vec3, Vec4};

use crate::camera::Camera;

/// A clipped vertex in screen space (pixels, y down) with its clip-space `1/w`.
#[derive(Clone, Copy, Debug, Default)]
pub struct ScreenVertex {
    pub x: f64,
    pub y: f64,
    pub inv_w: f64,
}

/// Most vertices a triangle has after clipping against two planes.
const MAX_CLIPPED: usize = 8;

/// A triangle clipped against the near and far planes and projected to the screen: a
/// convex polygon, drawn as the fan `(v[0], v[i], v[i+1])`.
pub struct ScreenPolygon {
    pub v: [ScreenVertex; MAX_CLIPPED],
    pub len: usize,
}

impl ScreenPolygon {
    /// The fan's triangles.
    pub fn fan(&self) -> impl Iterator<Item = [ScreenVertex; 3]> + '_ {
        (1..self.len.saturating_sub(1)).map(|i| [self.v[0], self.v[i], self.v[i + 1]])
    }
}

#[inline(always)]
fn clip_polygon(
    poly: &[Vec4; MAX_CLIPPED],
    len: usize,
    out: &mut [Vec4; MAX_CLIPPED],
    dist: impl Fn(Vec4) -> f32,
) -> usize {
    let mut n = 0;
    for i in 0..len {
        let (a, b) = (poly[i], poly[if i + 1 == len { 0 } else { i + 1 }]);
        let (da, db) = (dist(a), dist(b));
        if da >= 0.0 {
            out[n] = a;
            n += 1;
        }
        if (da >= 0.0) != (db >= 0.0) {
            let t = da / (da - db);
            out[n] = a + (b - a) * t;
            n += 1;
        }
    }
    n
}

/// Clips a world-space triangle against the near and far planes and projects it.
/// Always inlined, so that the native backend's kernels compile it at their SIMD
/// level (the same arithmetic: no contraction into fused multiply-adds).
#[inline(always)]
pub fn screen_polygon(cam: &Camera, tri: [Vec3; 3]) -> ScreenPolygon {
    let mut a = [Vec4::ZERO; MAX_CLIPPED];
    let mut b = [Vec4::ZERO; MAX_CLIPPED];
    for (k, p) in tri.iter().enumerate() {
        a[k] = cam.view_proj * p.extend(1.0);
    }
    // Clipping a triangle with every corner inside both planes gives it back unchanged.
    let inside = |c: Vec4| c.w - c.z >= 0.0 && c.z >= 0.0;
    let n = if inside(a[0]) && inside(a[1]) && inside(a[2]) {
        3
    } else {
        let n = clip_polygon(&a, 3, &mut b, |c| c.w - c.z);
        clip_polygon(&b, n, &mut a, |c| c.z)
    };
    let (w, h) = (cam.width as f64, cam.height as f64);
    let mut out = ScreenPolygon {
        v: [ScreenVertex::default(); MAX_CLIPPED],
        len: if n < 3 { 0 } else { n },
    };
    for (v, c) in out.v.iter_mut().zip(a).take(out.len) {
        let iw = 1.0 / c.w as f64;
        *v = ScreenVertex {
            x: (c.x as f64 * iw * 0.5 + 0.5) * w,
            y: (0.5 - c.y as f64 * iw * 0.5) * h,
            inv_w: iw,
        };
    }
    out
}

/// Calls `plot(x, y, view_depth)` for every pixel whose centre the triangle covers.
pub fn raster_triangle(cam: &Camera, tri: [Vec3; 3], mut plot: impl FnMut(u32, u32, f32)) {
    for t in screen_polygon(cam, tri).fan() {
        if let Some(t) = ScreenTriangle::new(cam.width, cam.height, t) {
            t.raster(&mut plot);
        }
    }
}

/// The edge function of `a → b` at `(px, py)`: positive on the inner side of a
/// counter-clockwise (in y-down screen space, clockwise on screen) triangle.
#[inline(always)]
pub fn edge(a: ScreenVertex, b: ScreenVertex, px: f64, py: f64) -> f64 {
    (b.x - a.x) * (py - a.y) - (b.y - a.y) * (px - a.x)
}

/// Top-left rule for a triangle of positive area in y-down screen space.
#[inline(always)]
fn owns_edge(a: ScreenVertex, b: ScreenVertex) -> bool {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    (dy == 0.0 && dx > 0.0) || dy < 0.0
}

/// A screen triangle of positive area, set up for coverage tests: vertices ordered so
/// that the area is positive, the top-left ownership of each edge, and the range of
/// pixels its bounding box reaches inside the viewport.
#[derive(Clone, Copy, Debug)]
pub struct ScreenTriangle {
    pub v: [ScreenVertex; 3],
    pub area: f64,
    /// Whether edge k (opposite vertex k: `v[k+1] → v[k+2]`) owns its pixel centres.
    pub owns: [bool; 3],
    /// Inclusive pixel range of the bounding box, clamped to the viewport.
    pub x0: u32,
    pub x1: u32,
    pub y0: u32,
    pub y1: u32,
}

impl ScreenTriangle {
    /// None for degenerate triangles and those whose box misses every pixel centre.
    #[inline(always)]
    pub fn new(width: u32, height: u32, mut v: [ScreenVertex; 3]) -> Option<Self> {
        let mut area = edge(v[0], v[1], v[2].x, v[2].y);
        if area == 0.0 || !area.is_finite() {
            return None;
        }
        if area < 0.0 {
            v.swap(1, 2);
            area = -area;
        }
        let min_x = v.iter().map(|p| p.x).fold(f64::INFINITY, f64::min);
        let max_x = v.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max);
        let min_y = v.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
        let max_y = v.iter().map(|p| p.y).fold(f64::NEG_INFINITY, f64::max);
        let x0 = (min_x - 0.5).ceil().max(0.0);
        let x1 = (max_x - 0.5).floor().min(width as f64 - 1.0);
        let y0 = (min_y - 0.5).ceil().max(0.0);
        let y1 = (max_y - 0.5).floor().min(height as f64 - 1.0);
        if x0 > x1 || y0 > y1 {
            return None;
        }
        Some(ScreenTriangle {
            owns: [
                owns_edge(v[1], v[2]),
                owns_edge(v[2], v[0]),
                owns_edge(v[0], v[1]),
            ],
            v,
            area,
            x0: x0 as u32,
            x1: x1 as u32,
            y0: y0 as u32,
            y1: y1 as u32,
        })
    }

    /// The three edge functions at a point.
    #[inline]
    pub fn edges(&self, px: f64, py: f64) -> [f64; 3] {
        let v = &self.v;
        [
            edge(v[1], v[2], px, py),
            edge(v[2], v[0], px, py),
            edge(v[0], v[1], px, py),
        ]
    }

    /// Whether edge `k`'s value `e` puts a pixel centre inside (top-left rule on ties).
    #[inline]
    pub fn inside_edge(&self, k: usize, e: f64) -> bool {
        e > 0.0 || (e == 0.0 && self.owns[k])
    }

    /// Clip-space `1/w` at a point with edge values `e`, interpolated perspective-correctly.
    #[inline]
    pub fn inv_w(&self, e: [f64; 3]) -> f64 {
        (e[0] * self.v[0].inv_w + e[1] * self.v[1].inv_w + e[2] * self.v[2].inv_w) / self.area
    }

    /// Calls `plot(x, y, view_depth)` for every covered pixel centre.
    fn raster(&self, plot: &mut impl FnMut(u32, u32, f32)) {
        for y in self.y0..=self.y1 {
            let py = y as f64 + 0.5;
            for x in self.x0..=self.x1 {
                let e = self.edges(x as f64 + 0.5, py);
                if (0..3).all(|k| self.inside_edge(k, e[k])) {
                    plot(x, y, (1.0 / self.inv_w(e)) as f32);
                }
            }
        }
    }
}

/// Renders triangles into a nearest-depth map (`0` = uncovered), `width × height`.
pub fn raster_depth<'a>(
    cam: &Camera,
    tris: impl Iterator<Item = [Vec3; 3]> + 'a,
    depth: &mut [f32],
) {
    let w = cam.width;
    for t in tris {
        raster_triangle(cam, t, |x, y, d| {
            let px = &mut depth[(y * w + x) as usize];
            if *px == 0.0 || d < *px {
                *px = d;
            }
        });
    }
}

/// Renders triangles into an ID buffer with a depth test (nearest wins, first on ties).
pub fn raster_ids(
    cam: &Camera,
    tris: impl Iterator<Item = (u32, [Vec3; 3])>,
    ids: &mut [u32],
    depth: &mut [f32],
) {
    let w = cam.width;
    for (id, t) in tris {
        raster_triangle(cam, t, |x, y, d| {
            let i = (y * w + x) as usize;
            if depth[i] == 0.0 || d < depth[i] {
                depth[i] = d;
                ids[i] = id;
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::look_at;

    #[test]
    fn shared_edges_cover_each_pixel_once() {
        let cam = look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, 64, 48);
        let q = [
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ];
        let mut count = vec![0u32; 64 * 48];
        for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            raster_triangle(&cam, t, |x, y, d| {
                count[(y * 64 + x) as usize] += 1;
                assert!((d - 5.0).abs() < 1e-4);
            });
        }
        assert!(count.iter().all(|&c| c <= 1));
        assert!(count.iter().filter(|&&c| c == 1).count() > 100);
    }

    #[test]
    fn near_clipping_keeps_the_visible_part() {
        // A floor quad running from behind the camera to far ahead.
        let cam = look_at(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 1.0, -1.0), 64, 64);
        let q = [
            Vec3::new(-5.0, 0.0, 5.0),
            Vec3::new(5.0, 0.0, 5.0),
            Vec3::new(5.0, 0.0, -50.0),
            Vec3::new(-5.0, 0.0, -50.0),
        ];
        let mut depth = vec![0.0; 64 * 64];
        raster_depth(
            &cam,
            [[q[0], q[1], q[2]], [q[0], q[2], q[3]]].into_iter(),
            &mut depth,
        );
        // Bottom row is covered, top half (sky) is not.
        assert!(depth[63 * 64 + 32] > 0.0);
        assert_eq!(depth[10 * 64 + 32], 0.0);
        // Depth grows towards the horizon.
        assert!(depth[40 * 64 + 32] > depth[63 * 64 + 32]);
    }
}
