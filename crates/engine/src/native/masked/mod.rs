//! The masked occlusion map: coverage as bitmasks and depth as two conservative
//! bounds per row of a tile, in the spirit of Masked Software Occlusion Culling
//! (Andersson et al. 2015), with per-pixel depth drawn only for the tiles the
//! refinement reads.
//!
//! The screen is cut into tiles of [`TILE_W`]×[`TILE_H`] pixels: one `u32` of coverage
//! per tile row, so a tile's masks are one AVX2 register. Each row of a tile (a 32×1
//! strip) keeps two lower bounds on the `1/w` of the nearest occluder fragment of its
//! pixels (`1/w` is the inverse view depth: larger is nearer, 0 is "nothing there"):
//! - `base`: every pixel of the row holds an occluder fragment at least this near
//!   (0 until the row is covered whole);
//! - `layer` over the pixels of `mask`: each of them holds one at least this near.
//!
//! A triangle is drawn tile by tile: its exact covered pixels of each row (the spans of
//! [`SpanTriangle::row_block`], so coverage is the oracle's own: pixel centres and the
//! top-left rule) as a mask, and the least `1/w` of its plane over the row's covered
//! pixels (at the span's ends) as its bound there. [`merge_row`] folds the pair into
//! the row keeping both statements true: a layer grown to the whole row becomes the
//! base, and where the row cannot keep everything it keeps whichever bound holds more
//! (the greater sum of bounds over its pixels). A base only grows; a layer may be
//! lowered to hold over more pixels; every statement stays a lower bound.
//!
//! Why the tests on it never cull what the oracle sees:
//! 1. Every statement a row makes is a lower bound on what the oracle's per-pixel
//!    depth test holds there: a covered pixel is one the oracle covers with that
//!    occluder triangle, and the plane's least value along a span is at one of its
//!    ends, taken in f64 and rounded down ([`BOUND_ROUNDING`]).
//! 2. [`MaskedMap::rect_hidden`] answers hidden only if every pixel of the rect is
//!    shown by a bound to lie in front of the threshold; the box test asks it with the
//!    box's nearest depth and the margin, as the per-pixel map's test does.
//! 3. The refinement ([`MaskedMap::triangle_hidden_per_pixel`]) culls a fragment only
//!    where a bound, or the tile's exact per-pixel depth ([`exact`]), lies in front of
//!    it by the refinement's margin.
//!
//! Occluders and triangles the map already hides are left out of the draw (their
//! fragments lie behind bounds of drawn fragments, so no pixel's nearest fragment
//! changes). The pyramid over the tiles is rebuilt at checkpoints; between them it
//! may be stale, which is safe: its `far` reads bases, which only grow, and its
//! `near` only decides when to descend to the tiles, which are read as they are.
//!
//! The tiles the refinement cannot settle from the bounds are drawn per pixel, once
//! per pose, from the triangles drawn into them (listed per tile as they are drawn).
//! The per-pixel values are the same f64 plane stepped in f32 as the per-pixel map's,
//! so the margin argument of `native::refine` carries over.
//!
//! Measured against the per-pixel map (`native::map`), which stays the served path:
//! the same answers after the refinement, a weaker box test alone, and no faster in
//! all (README, "Native CPU backend").

mod backend;
mod draw;
mod exact;

use super::descent::{self, Texel, TexelTest};
use super::span::SpanTriangle;
use crate::camera::{Camera, ScreenRect};
use crate::scene::Scene;
pub use backend::{MaskedBackend, hidden_masked};
use draw::{draw_part, for_each_tile, greater, lesser, raster};
pub use draw::{merge, merge_row, span_mask, tile_rows};
use exact::ExactTiles;

/// Tile width in pixels: the bits of one `u32`.
pub const TILE_W: u32 = 32;
/// Tile height in pixels (rows).
pub const TILE_H: u32 = 8;
const H: usize = TILE_H as usize;

/// A tile's bounds are rounded down by this relative amount when stored: an f64 plane
/// value rounded to f32 may round up by 2^-24 of itself, and the f64 evaluation is off
/// the exact plane by far less.
const BOUND_ROUNDING: f64 = 1e-6;

/// [`MaskedMap::draw_occluders`] rebuilds the pyramid over the tiles after each
/// 1/CHECKPOINTS share of the occluders (at least [`MIN_PER_CHECKPOINT`]), so that
/// later occluders and triangles can be tested against what is already drawn.
const CHECKPOINTS: usize = 4;
const MIN_PER_CHECKPOINT: usize = 8;

/// Triangles whose pixel box is at least this large are tested against the map
/// before they are drawn (a test of a few tiles costs about one tile's draw).
const SKIP_TEST_MIN_PIXELS: u32 = 16;

/// Most levels of the pyramid over the tiles.
const MAX_LEVELS: usize = 18;
const _: () = assert!(MAX_LEVELS <= descent::MAX_DESCENT_LEVELS);

/// One tile's coverage and bounds (see the module docs), kept per row of the tile: row
/// `r` is a 32×1 strip with its own mask and bounds (the depth is as fine as a row,
/// the coverage a bit per pixel).
#[derive(Clone, Copy, Default, Debug, PartialEq)]
pub struct Tile {
    /// Bit `k` of row `r`: pixel `(TILE_W·tx + k, TILE_H·ty + r)` holds at least
    /// `layer[r]`.
    pub mask: [u32; H],
    /// Every pixel of row `r` holds an occluder fragment at `1/w ≥ base[r]`.
    pub base: [f32; H],
    /// Every pixel of `mask[r]` holds one at `1/w ≥ layer[r]`; `layer[r] > base[r]`
    /// while `mask[r]` has a bit, 0 when it has none.
    pub layer: [f32; H],
}

impl Tile {
    /// The lower bound of the pixel at row `r`, column `k` of the tile.
    #[inline(always)]
    pub fn bound_at(&self, r: usize, k: u32) -> f32 {
        if self.mask[r] >> k & 1 == 1 {
            self.layer[r]
        } else {
            self.base[r]
        }
    }

    /// The least bound of any of its pixels inside the viewport, and the greatest
    /// (rows wholly `outside` it, below the last pixel row, never get a bound and no
    /// rect reaches them).
    #[inline(always)]
    fn range(&self, outside: &[u32; H]) -> (f32, f32) {
        let (mut lo, mut hi) = (f32::INFINITY, 0.0f32);
        for ((&base, &layer), &out) in self.base.iter().zip(&self.layer).zip(outside) {
            if out != !0 {
                lo = lesser(lo, base);
                hi = greater(greater(hi, base), layer);
            }
        }
        (lo, hi)
    }
}

/// One pose's masked occlusion map; reused from pose to pose to keep its memory.
#[derive(Default)]
pub struct MaskedMap {
    pub width: u32,
    pub height: u32,
    /// Tiles across and down.
    tiles_x: u32,
    tiles_y: u32,
    tiles: Vec<Tile>,
    /// Per tile: the pixels any drawn triangle covers, and an upper bound on the `1/w`
    /// of every drawn fragment there (what lets the refinement find a visible fragment
    /// without the tile's exact depth).
    covered: Vec<[u32; H]>,
    upper: Vec<f32>,
    /// Per tile: the bits of its rows that lie outside the viewport (always "covered":
    /// no rect reaches them), so that an edge tile can be covered whole.
    outside: Vec<[u32; H]>,
    /// Pyramid over the tiles, levels 1 and up: per texel the least `base` and the
    /// greatest bound of the tiles under it (what [`MaskedMap::rect_hidden`] descends).
    dims: Vec<(u32, u32)>,
    offsets: Vec<usize>,
    far: Vec<f32>,
    near: Vec<f32>,
    /// The screen triangles drawn since the last reset, in order.
    tris: Vec<SpanTriangle>,
    exact: ExactTiles,
}

impl MaskedMap {
    /// Clears the map for a `width × height` viewport.
    pub fn reset(&mut self, width: u32, height: u32) {
        if (self.width, self.height) != (width, height) {
            self.width = width;
            self.height = height;
            self.tiles_x = width.div_ceil(TILE_W).max(1);
            self.tiles_y = height.div_ceil(TILE_H).max(1);
            let n = (self.tiles_x * self.tiles_y) as usize;
            self.tiles = vec![Tile::default(); n];
            self.covered = vec![[0; H]; n];
            self.upper = vec![0.0; n];
            self.outside = (0..n as u32)
                .map(|i| {
                    let (tx, ty) = (i % self.tiles_x, i / self.tiles_x);
                    let cols = width.saturating_sub(tx * TILE_W).min(TILE_W);
                    let col_out = if cols == TILE_W { 0 } else { !0u32 << cols };
                    std::array::from_fn(|r| {
                        if ty * TILE_H + r as u32 >= height {
                            !0
                        } else {
                            col_out
                        }
                    })
                })
                .collect();
            self.dims.clear();
            self.offsets.clear();
            let (mut w, mut h) = (self.tiles_x, self.tiles_y);
            let mut total = 0;
            while (w > 1 || h > 1) && self.dims.len() + 1 < MAX_LEVELS {
                w = w.div_ceil(2);
                h = h.div_ceil(2);
                self.dims.push((w, h));
                self.offsets.push(total);
                total += (w * h) as usize;
            }
            self.far = vec![0.0; total];
            self.near = vec![0.0; total];
            self.exact.resize(n);
        } else {
            self.tiles.fill(Tile::default());
            self.covered.fill([0; H]);
            self.upper.fill(0.0);
            self.far.fill(0.0);
            self.near.fill(0.0);
        }
        self.tris.clear();
        self.exact.reset();
    }

    /// The lower bound the map keeps for pixel `(x, y)`.
    pub fn bound_at(&self, x: u32, y: u32) -> f32 {
        let tile = &self.tiles[((y / TILE_H) * self.tiles_x + x / TILE_W) as usize];
        tile.bound_at((y % TILE_H) as usize, x % TILE_W)
    }

    /// Draws the front faces of occluders `ids` (nearest first). After each
    /// [`CHECKPOINTS`] share of them the pyramid is rebuilt, and a later occluder whose
    /// box the map already hides (the box test, margin included) is left out, as is
    /// any triangle (from the first on) whose every fragment lies behind it, tested
    /// against the tiles as they are and the pyramid as last built: each of its fragments would
    /// lie behind a bound the map already keeps, so no test of the map could change,
    /// and the per-pixel depth of every pixel is already nearer. Answers the number
    /// of occluders left out; the pyramid is built.
    pub fn draw_occluders(&mut self, scene: &Scene, cam: &Camera, ids: &[u32]) -> usize {
        let per = ids
            .len()
            .div_ceil(CHECKPOINTS)
            .max(MIN_PER_CHECKPOINT)
            .min(ids.len().max(1));
        let mut skipped = 0;
        for (k, part) in ids.chunks(per).enumerate() {
            skipped += draw_part(self, scene, cam, part, k > 0);
            self.build_pyramid();
        }
        if ids.is_empty() {
            self.build_pyramid();
        }
        skipped
    }

    /// Draws one screen triangle (no test first).
    pub fn draw_triangle(&mut self, t: &SpanTriangle) {
        raster(self, t);
        self.tris.push(*t);
    }

    /// Rebuilds the pyramid over the tiles (drawing does it at its checkpoints).
    pub fn build_pyramid(&mut self) {
        let (mut cw, mut ch) = (self.tiles_x, self.tiles_y);
        for l in 0..self.dims.len() {
            let (w, h) = self.dims[l];
            let o = self.offsets[l];
            for y in 0..h {
                for x in 0..w {
                    let (mut f, mut n) = (f32::INFINITY, 0.0f32);
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let (cx, cy) = (2 * x + dx, 2 * y + dy);
                        if cx < cw && cy < ch {
                            let (cf, cn) = if l == 0 {
                                let j = (cy * cw + cx) as usize;
                                self.tiles[j].range(&self.outside[j])
                            } else {
                                let j = self.offsets[l - 1] + (cy * cw + cx) as usize;
                                (self.far[j], self.near[j])
                            };
                            f = lesser(f, cf);
                            n = greater(n, cn);
                        }
                    }
                    let i = o + (y * w + x) as usize;
                    self.far[i] = f;
                    self.near[i] = n;
                }
            }
            (cw, ch) = (w, h);
        }
    }

    /// True if every pixel of `r` holds an occluder fragment at `1/w > t` by the
    /// map's bounds. The tiles are read as they are now; the pyramid above them may be
    /// older (module docs: that only makes it descend to the tiles more often).
    #[inline(always)]
    pub fn rect_hidden(&self, r: &ScreenRect, t: f32) -> bool {
        let tiles = (
            r.x0 / TILE_W,
            r.y0 / TILE_H,
            (r.x1 - 1) / TILE_W,
            (r.y1 - 1) / TILE_H,
        );
        // Level 0 is the tiles themselves, level l > 0 the pyramid's level l - 1.
        descent::rect_hidden(self, r, t, tiles, self.dims.len() + 1)
    }

    /// Whether every pixel of `r` in tile `(tx, ty)` holds a bound above `t`.
    #[inline(always)]
    fn tile_hidden(&self, r: &ScreenRect, tx: u32, ty: u32, t: f32) -> bool {
        let tile = &self.tiles[(ty * self.tiles_x + tx) as usize];
        let cols = span_mask(
            r.x0 as i32 - (tx * TILE_W) as i32,
            r.x1 as i32 - 1 - (tx * TILE_W) as i32,
        );
        let y0 = r.y0.max(ty * TILE_H) - ty * TILE_H;
        let y1 = r.y1.min((ty + 1) * TILE_H) - ty * TILE_H;
        let mut all = true;
        for row in 0..H {
            let inside = (row as u32) >= y0 && (row as u32) < y1;
            let by_base = tile.base[row] > t;
            let by_layer = tile.layer[row] > t && cols & !tile.mask[row] == 0;
            all &= !inside || by_base || by_layer;
        }
        all
    }

    /// True if the bounds show every fragment of `t` behind the map by the relative
    /// `margin` (its nearest `1/w`, at a vertex, below every pixel of its box).
    #[inline(always)]
    pub fn triangle_hidden(&self, t: &SpanTriangle, margin: f64) -> bool {
        let (r, nearest) = t.bounds();
        self.rect_hidden(&r, (nearest * (1.0 + margin)) as f32)
    }

    /// True if every fragment of `t` lies behind the map's occluders by the relative
    /// `margin`, tile by tile: a tile whose bounds lie in front of the triangle's
    /// nearest value there settles its pixels; a tile where the triangle covers a
    /// pixel no occluder covers, or lies in front of every occluder fragment, shows it;
    /// any other tile is read per pixel of its exact depth (drawn on first use).
    #[inline(always)]
    pub fn triangle_hidden_per_pixel(&mut self, t: &SpanTriangle, margin: f64) -> bool {
        let k = 1.0 + margin;
        let tiles_x = self.tiles_x;
        for_each_tile(t, tiles_x, |i, tx, ty, share| {
            let tile = &self.tiles[i];
            // Rows the bounds leave in doubt.
            let doubt: [bool; H] = std::array::from_fn(|r| {
                let need = share.greatest[r] * k;
                let by_base = tile.base[r] as f64 > need;
                let by_layer = tile.layer[r] as f64 > need && share.cov[r] & !tile.mask[r] == 0;
                share.cov[r] != 0 && !by_base && !by_layer
            });
            if doubt == [false; H] {
                return true;
            }
            let shows = |r: usize| {
                share.cov[r] & !self.covered[i][r] != 0
                    || share.least[r] * k >= self.upper[i] as f64
            };
            if (0..H).any(|r| doubt[r] && shows(r)) {
                return false;
            }
            let px = self.exact.tile(&self.tris, tiles_x, tx, ty);
            for r in (0..H).filter(|&r| doubt[r]) {
                let py = (ty * TILE_H + r as u32) as f64 + 0.5;
                let mut bits = share.cov[r];
                while bits != 0 {
                    let c = bits.trailing_zeros();
                    bits &= bits - 1;
                    let v = t.inv_w_at((tx * TILE_W + c) as f64 + 0.5, py);
                    // NaN fails: not hidden.
                    let m = px[r * TILE_W as usize + c as usize] as f64;
                    if m.partial_cmp(&(v * k)) != Some(std::cmp::Ordering::Greater) {
                        return false;
                    }
                }
            }
            true
        })
    }

    /// The exact per-pixel depth of the drawn triangles at `(x, y)` (the nearest `1/w`,
    /// 0 if none covers it), as the refinement reads it.
    pub fn exact_at(&mut self, x: u32, y: u32) -> f32 {
        let (tx, ty) = (x / TILE_W, y / TILE_H);
        let px = self.exact.tile(&self.tris, self.tiles_x, tx, ty);
        px[(y % TILE_H * TILE_W + x % TILE_W) as usize]
    }
}

impl TexelTest for MaskedMap {
    /// [`MaskedMap::rect_hidden`]'s answer for texel `(x, y)` of level `l`.
    #[inline(always)]
    fn texel(&self, r: &ScreenRect, t: f32, l: usize, x: u32, y: u32) -> Texel {
        if l == 0 {
            return if self.tile_hidden(r, x, y, t) {
                Texel::Hidden
            } else {
                Texel::Visible
            };
        }
        let i = self.offsets[l - 1] + (y * self.dims[l - 1].0 + x) as usize;
        descent::by_bounds(self.far[i], self.near[i], t)
    }
}

#[cfg(test)]
mod tests;
