//! The occlusion map of one pose: the occluders' nearest `1/w` per pixel, and a
//! pyramid of per-tile bounds over it for the box test.
//!
//! Per pixel the map holds the largest `1/w` (the nearest view depth) of the occluder
//! fragments there, 0 where none is: coverage and depth in one number, since an
//! uncovered pixel is "infinitely far" and hides nothing. Above the pixels, tiles of
//! [`TILE`]×[`TILE`] pixels and their 2×2 groups (a quadtree) keep two bounds: `far`,
//! the smallest `1/w` under the texel (0 if any pixel there is uncovered: HOM's
//! "fully opaque" and the farthest occluder depth in one test), and `near`, the
//! largest. A box is hidden when every pixel of its screen rect holds a `1/w` above
//! its threshold ([`OcclusionMap::rect_hidden`]): a texel whose `far` is above it
//! settles its whole area, one whose `near` is not settles that the box is visible,
//! and only the tiles in between are read pixel by pixel. That is the conservative
//! HOM test (opacity 1 at every level, raster DEB) answered exactly: the same answer
//! as testing every pixel of the rect.

use glam::Vec3;

use super::span::{LANES, Span, span_triangles};
use crate::core::camera::{Camera, ScreenRect};
use crate::core::cull::deb::DEPTH_MARGIN;
use crate::core::scene::Scene;

/// Side of the pyramid's finest texels, in pixels.
pub const TILE: u32 = 8;

/// [`OcclusionMap::draw_occluders`] bounds the map after the nearest 1/CHECKPOINT of
/// the occluders (but at least [`MIN_BEFORE_CHECKPOINT`]).
const CHECKPOINT: usize = 4;
const MIN_BEFORE_CHECKPOINT: usize = 8;

/// Most levels of the tile pyramid (a 2^20-pixel side).
const MAX_LEVELS: usize = 18;

/// One pose's occlusion map; reused from pose to pose to keep its memory.
#[derive(Default)]
pub struct OcclusionMap {
    pub width: u32,
    pub height: u32,
    /// Nearest occluder `1/w` per pixel, row-major (0 = uncovered).
    pub inv_w: Vec<f32>,
    dims: Vec<(u32, u32)>,
    offsets: Vec<usize>,
    /// Smallest `1/w` under each texel, all levels.
    far: Vec<f32>,
    /// Largest `1/w` under each texel, all levels.
    near: Vec<f32>,
}

impl OcclusionMap {
    /// Clears the map for a `width × height` viewport.
    pub fn reset(&mut self, width: u32, height: u32) {
        let n = (width * height) as usize;
        if (self.width, self.height) != (width, height) {
            self.width = width;
            self.height = height;
            self.dims.clear();
            self.offsets.clear();
            let (mut w, mut h) = (width.div_ceil(TILE).max(1), height.div_ceil(TILE).max(1));
            let mut total = 0;
            loop {
                self.dims.push((w, h));
                self.offsets.push(total);
                total += (w * h) as usize;
                if (w == 1 && h == 1) || self.dims.len() == MAX_LEVELS {
                    break;
                }
                w = w.div_ceil(2);
                h = h.div_ceil(2);
            }
            self.far = vec![0.0; total];
            self.near = vec![0.0; total];
            self.inv_w = vec![0.0; n];
        } else {
            self.inv_w.fill(0.0);
        }
    }

    /// Draws the front faces of occluders `ids` (nearest first), leaving out those
    /// already hidden: after the nearest [`CHECKPOINT`] share of them the map is
    /// bounded once, and each later occluder whose box that map already hides (the box
    /// test, margin included) is skipped. Its fragments all lie behind what the map
    /// holds there, which only grows nearer, so skipping it leaves the final map
    /// exactly as drawing it would. Answers the number skipped; bound the map again
    /// before testing against it.
    pub fn draw_occluders(&mut self, scene: &Scene, cam: &Camera, ids: &[u32]) -> usize {
        let eye = cam.position;
        let front = |id: &u32| {
            scene
                .corners_of(&scene.objects[*id as usize])
                .filter(move |t| front_facing(eye, t))
        };
        let first = ids
            .len()
            .div_ceil(CHECKPOINT)
            .max(MIN_BEFORE_CHECKPOINT)
            .min(ids.len());
        self.draw(cam, ids[..first].iter().flat_map(front));
        if first == ids.len() {
            return 0;
        }
        self.build_bounds();
        let mut skipped = 0;
        let rest = ids[first..].iter().filter(|&&id| {
            let hidden = cam
                .project_box(&scene.objects[id as usize].aabb)
                .is_none_or(|r| self.rect_hidden(&r, (1.0 + DEPTH_MARGIN) / r.near));
            skipped += hidden as usize;
            !hidden
        });
        let rest: Vec<u32> = rest.copied().collect();
        self.draw(cam, rest.iter().flat_map(front));
        skipped
    }

    /// Draws triangles into the map (the nearest fragment wins each pixel).
    pub fn draw(&mut self, cam: &Camera, tris: impl Iterator<Item = [Vec3; 3]>) {
        draw_triangles(self, cam, tris)
    }

    /// Builds the tile bounds from the pixels.
    pub fn build_bounds(&mut self) {
        let (tw, th) = self.dims[0];
        let w = self.width as usize;
        let (far, near) = (&mut self.far, &mut self.near);
        far[..(tw * th) as usize].fill(f32::INFINITY);
        near[..(tw * th) as usize].fill(0.0);
        for (y, row) in self.inv_w.chunks_exact(w).enumerate() {
            let t0 = (y / TILE as usize) * tw as usize;
            tile_row_bounds(
                row,
                &mut far[t0..t0 + tw as usize],
                &mut near[t0..t0 + tw as usize],
            );
        }
        for l in 1..self.dims.len() {
            let (w, h) = self.dims[l];
            let (cw, ch) = self.dims[l - 1];
            let (o, co) = (self.offsets[l], self.offsets[l - 1]);
            for y in 0..h {
                for x in 0..w {
                    let (mut f, mut n) = (f32::INFINITY, 0.0f32);
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let (cx, cy) = (2 * x + dx, 2 * y + dy);
                        if cx < cw && cy < ch {
                            let j = co + (cy * cw + cx) as usize;
                            f = f.min(far[j]);
                            n = n.max(near[j]);
                        }
                    }
                    let i = o + (y * w + x) as usize;
                    far[i] = f;
                    near[i] = n;
                }
            }
        }
    }

    /// True if every pixel of `r` holds a `1/w` above `t` (the map was bounded by
    /// [`OcclusionMap::build_bounds`]). `t = (1 + margin) / near` asks whether
    /// occluders lie in front of depth `near` everywhere; `t = 0` whether they cover.
    pub fn rect_hidden(&self, r: &ScreenRect, t: f32) -> bool {
        let (tx0, ty0) = (r.x0 / TILE, r.y0 / TILE);
        let (tx1, ty1) = ((r.x1 - 1) / TILE, (r.y1 - 1) / TILE);
        let mut k = 0;
        while k + 1 < self.dims.len()
            && ((tx1 >> k) - (tx0 >> k) > 1 || (ty1 >> k) - (ty0 >> k) > 1)
        {
            k += 1;
        }
        let mut stack = [(0u8, 0u32, 0u32); 4 + 3 * MAX_LEVELS];
        let mut top = 0;
        for y in (ty0 >> k)..=(ty1 >> k) {
            for x in (tx0 >> k)..=(tx1 >> k) {
                stack[top] = (k as u8, x, y);
                top += 1;
            }
        }
        while top > 0 {
            top -= 1;
            let (l, x, y) = stack[top];
            let l = l as usize;
            let i = self.offsets[l] + (y * self.dims[l].0 + x) as usize;
            if self.far[i] > t {
                continue; // every pixel under the texel hides
            }
            if self.near[i] <= t {
                return false; // none does, and the texel overlaps the rect
            }
            if l == 0 {
                if !self.pixels_hidden(r, x, y, t) {
                    return false;
                }
                continue;
            }
            let c = l - 1;
            for cy in (2 * y).max(ty0 >> c)..=(2 * y + 1).min(ty1 >> c) {
                for cx in (2 * x).max(tx0 >> c)..=(2 * x + 1).min(tx1 >> c) {
                    stack[top] = (c as u8, cx, cy);
                    top += 1;
                }
            }
        }
        true
    }

    /// Whether every pixel of `r` inside tile `(tx, ty)` holds a `1/w` above `t`.
    fn pixels_hidden(&self, r: &ScreenRect, tx: u32, ty: u32, t: f32) -> bool {
        let x0 = r.x0.max(tx * TILE) as usize;
        let x1 = r.x1.min((tx + 1) * TILE) as usize;
        let y0 = r.y0.max(ty * TILE);
        let y1 = r.y1.min((ty + 1) * TILE);
        let w = self.width as usize;
        (y0..y1).all(|y| {
            let row = &self.inv_w[y as usize * w..][x0..x1];
            row.iter().fold(true, |all, &v| all & (v > t))
        })
    }
}

/// Whether a triangle faces the eye (counter-clockwise seen from it, glTF's front).
/// Occluders draw only their front faces: a back face of a closed mesh lies behind
/// a front face of the same mesh, and leaving any triangle out only leaves the map
/// farther or uncovered, never nearer, so it can cost culling but never culls wrongly.
#[inline]
pub fn front_facing(eye: Vec3, t: &[Vec3; 3]) -> bool {
    (t[1] - t[0]).cross(t[2] - t[0]).dot(t[0] - eye) < 0.0
}

/// [`OcclusionMap::draw`], compiled once per SIMD level (the span kernels inline).
#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
fn draw_triangles<I: Iterator<Item = [Vec3; 3]>>(map: &mut OcclusionMap, cam: &Camera, tris: I) {
    let rows = (0, map.height - 1);
    let w = map.width as usize;
    for tri in tris {
        span_triangles(cam, tri, |t| {
            t.spans(rows, |y, s| {
                let at = y as usize * w + s.x0 as usize;
                keep_nearest(&mut map.inv_w[at..at + s.pixels()], &s);
                true
            })
        });
    }
}

/// `dst[i] = max(dst[i], 1/w of the span's pixel i)`: the nearest fragment wins.
#[inline(always)]
fn keep_nearest(dst: &mut [f32], s: &Span) {
    let mut chunks = dst.chunks_exact_mut(LANES);
    let mut i = 0;
    for c in &mut chunks {
        let v = s.lanes(i);
        // `max`, not a conditional store: a masked store is microcoded on some CPUs.
        for k in 0..LANES {
            c[k] = c[k].max(v[k]);
        }
        i += LANES;
    }
    let v = s.lanes(i);
    for (d, &v) in chunks.into_remainder().iter_mut().zip(&v) {
        *d = d.max(v);
    }
}

/// Folds one pixel row into the bounds of the tiles it crosses.
#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
fn tile_row_bounds(row: &[f32], far: &mut [f32], near: &mut [f32]) {
    let mut chunks = row.chunks_exact(TILE as usize);
    for ((c, f), n) in (&mut chunks).zip(far.iter_mut()).zip(near.iter_mut()) {
        let (mut lo, mut hi) = (*f, *n);
        for &v in c {
            lo = if v < lo { v } else { lo };
            hi = if v > hi { v } else { hi };
        }
        (*f, *n) = (lo, hi);
    }
    let rest = chunks.remainder();
    if !rest.is_empty() {
        let last = far.len() - 1;
        for &v in rest {
            far[last] = far[last].min(v);
            near[last] = near[last].max(v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::core::camera::look_at;
    use crate::core::hom::raster::raster_depth;
    use rand::{Rng, SeedableRng};

    #[test]
    fn map_matches_the_reference_depth_map_and_rects_test_every_pixel() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let (w, h) = (83u32, 45u32);
        let cam = look_at(Vec3::new(0.0, 0.5, 8.0), Vec3::ZERO, w, h);
        let tris: Vec<[Vec3; 3]> = (0..120)
            .map(|_| {
                let c = Vec3::new(
                    rng.random_range(-4.0..4.0),
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-6.0..3.0),
                );
                [0, 1, 2].map(|_| {
                    c + Vec3::new(
                        rng.random_range(-2.0..2.0),
                        rng.random_range(-2.0..2.0),
                        rng.random_range(-1.0..1.0),
                    )
                })
            })
            .collect();
        let mut reference = vec![0.0; (w * h) as usize];
        raster_depth(&cam, tris.iter().copied(), &mut reference);
        let mut map = OcclusionMap::default();
        map.reset(w, h);
        map.draw(&cam, tris.iter().copied());
        for (i, (&r, &m)) in reference.iter().zip(&map.inv_w).enumerate() {
            assert_eq!(r > 0.0, m > 0.0, "coverage of pixel {i}");
            if r > 0.0 {
                assert!(
                    (r * m - 1.0).abs() < 2e-6,
                    "depth of pixel {i}: {r} vs {}",
                    1.0 / m
                );
            }
        }
        map.build_bounds();
        let mut hidden = 0;
        for _ in 0..4000 {
            let x0 = rng.random_range(0..w);
            let y0 = rng.random_range(0..h);
            let r = ScreenRect {
                x0,
                y0,
                x1: (x0 + rng.random_range(1..16)).min(w),
                y1: (y0 + rng.random_range(1..12)).min(h),
                near: 1.0,
                far: 2.0,
            };
            let t = [0.0, 0.1, 0.125, 0.15][rng.random_range(0..4)];
            let want =
                (r.y0..r.y1).all(|y| (r.x0..r.x1).all(|x| map.inv_w[(y * w + x) as usize] > t));
            assert_eq!(map.rect_hidden(&r, t), want, "{r:?} at {t}");
            hidden += want as u32;
        }
        assert!(
            hidden > 100,
            "only {hidden} hidden rects: the test says little"
        );
    }
}
