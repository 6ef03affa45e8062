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
//! exactly as the GPU's two passes do.

use glam::{Vec3, Vec4};

use crate::core::camera::Camera;

#[derive(Clone, Copy)]
struct ScreenVertex {
    x: f64,
    y: f64,
    inv_w: f64,
}

fn clip_polygon(poly: &mut Vec<Vec4>, scratch: &mut Vec<Vec4>, dist: impl Fn(Vec4) -> f32) {
    scratch.clear();
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
        let (da, db) = (dist(a), dist(b));
        if da >= 0.0 {
            scratch.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            let t = da / (da - db);
            scratch.push(a + (b - a) * t);
        }
    }
    std::mem::swap(poly, scratch);
}

/// Calls `plot(x, y, view_depth)` for every pixel whose centre the triangle covers.
pub fn raster_triangle(cam: &Camera, tri: [Vec3; 3], mut plot: impl FnMut(u32, u32, f32)) {
    let mut poly: Vec<Vec4> = tri.iter().map(|p| cam.view_proj * p.extend(1.0)).collect();
    let mut scratch = Vec::with_capacity(8);
    clip_polygon(&mut poly, &mut scratch, |c| c.w - c.z);
    clip_polygon(&mut poly, &mut scratch, |c| c.z);
    if poly.len() < 3 {
        return;
    }
    let (w, h) = (cam.width as f64, cam.height as f64);
    let sv: Vec<ScreenVertex> = poly
        .iter()
        .map(|c| {
            let iw = 1.0 / c.w as f64;
            ScreenVertex {
                x: (c.x as f64 * iw * 0.5 + 0.5) * w,
                y: (0.5 - c.y as f64 * iw * 0.5) * h,
                inv_w: iw,
            }
        })
        .collect();
    for i in 1..sv.len() - 1 {
        raster_screen_triangle(cam.width, cam.height, [sv[0], sv[i], sv[i + 1]], &mut plot);
    }
}

fn edge(a: ScreenVertex, b: ScreenVertex, px: f64, py: f64) -> f64 {
    (b.x - a.x) * (py - a.y) - (b.y - a.y) * (px - a.x)
}

/// Top-left rule for a triangle of positive area in y-down screen space.
fn owns_edge(a: ScreenVertex, b: ScreenVertex) -> bool {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    (dy == 0.0 && dx > 0.0) || dy < 0.0
}

fn raster_screen_triangle(
    width: u32,
    height: u32,
    mut v: [ScreenVertex; 3],
    plot: &mut impl FnMut(u32, u32, f32),
) {
    let mut area = edge(v[0], v[1], v[2].x, v[2].y);
    if area == 0.0 || !area.is_finite() {
        return;
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
        return;
    }
    let owns = [
        owns_edge(v[1], v[2]),
        owns_edge(v[2], v[0]),
        owns_edge(v[0], v[1]),
    ];
    let inside = |e: f64, own: bool| e > 0.0 || (e == 0.0 && own);
    for y in y0 as u32..=y1 as u32 {
        let py = y as f64 + 0.5;
        for x in x0 as u32..=x1 as u32 {
            let px = x as f64 + 0.5;
            let e0 = edge(v[1], v[2], px, py);
            let e1 = edge(v[2], v[0], px, py);
            let e2 = edge(v[0], v[1], px, py);
            if inside(e0, owns[0]) && inside(e1, owns[1]) && inside(e2, owns[2]) {
                let inv_w = (e0 * v[0].inv_w + e1 * v[1].inv_w + e2 * v[2].inv_w) / area;
                plot(x, y, (1.0 / inv_w) as f32);
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
    use crate::core::camera::look_at;

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
