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
//!
//! Drawing is in two steps: the triangles are set up (clipped, projected, their edges
//! prepared) into a list, then drawn band by band (`draw::BAND` rows), so that a band's
//! pixels stay in cache while every triangle reaching it writes them and its tiles
//! are bounded. The map is bounded after every draw.

use glam::Vec3;

mod draw;

use super::descent::{self, Texel, TexelTest};
use super::span::{ROWS, SpanTriangle, padded_len};
use crate::camera::{Camera, ScreenRect};
use crate::scene::Scene;
use draw::{clear_dirty_bands, draw_binned, setup_occluders, setup_triangles};

/// Side of the pyramid's finest texels, in pixels.
pub const TILE: u32 = 8;
// A block of span rows (`span::ROWS`, from a multiple of it) lies in one row of tiles.
const _: () = assert!(TILE.is_multiple_of(ROWS as u32));

/// [`OcclusionMap::draw_occluders`] draws the occluders in parts of growing size and
/// bounds the map after each: the nearest [`FIRST_PART`], then parts each ending at
/// [`PART_GROWTH`] times the count drawn before it (with 2, each part is as large as
/// all before it). A later occluder is tested against bounds that are at most one
/// part old: on the shared scenes, parts of 8, 8, 16, 32, … drew 10–40 % faster
/// than a first quarter and the rest (the nearest quarter of a city's occluders
/// holds most of its hidden ones, drawn before any bound could skip them).
const FIRST_PART: usize = 8;
const PART_GROWTH: usize = 2;

/// Most levels of the tile pyramid (a 2^20-pixel side).
const MAX_LEVELS: usize = 18;
const _: () = assert!(MAX_LEVELS <= descent::MAX_DESCENT_LEVELS);

/// One pose's occlusion map; reused from pose to pose to keep its memory.
#[derive(Default)]
pub struct OcclusionMap {
    pub width: u32,
    pub height: u32,
    /// Nearest occluder `1/w` per pixel, row-major (0 = uncovered), padded for the
    /// span kernels (`span::padded_len`); [`OcclusionMap::pixels`] is the image.
    inv_w: Vec<f32>,
    dims: Vec<(u32, u32)>,
    offsets: Vec<usize>,
    /// Smallest `1/w` under each texel, all levels.
    far: Vec<f32>,
    /// Largest `1/w` under each texel, all levels.
    near: Vec<f32>,
    /// The screen triangles of every draw since the last reset, in the order drawn.
    /// The refinement looks up which of them cover a pixel it must decide finely
    /// ([`OcclusionMap::drawn_nearer`]).
    setup: Vec<SpanTriangle>,
    /// Whether every tile's bounds were built since the last reset (then a draw
    /// re-bounds only the bands it wrote to).
    bounded: bool,
    /// Draw the bands of one pose in parallel on rayon's pool (for a pose that has
    /// the cores to itself); the map ends the same either way.
    pub bands_in_parallel: bool,
    /// The triangles reaching each band of rows (indices into `setup`), of every draw
    /// since the last reset, and per band where the last draw's begin.
    bins: Vec<Vec<u32>>,
    bins_from: Vec<usize>,
    /// Per band of rows, the tile columns the last draw's triangles reach there.
    band_cols: Vec<(u32, u32)>,
    /// Per band of rows, whether a draw may have left a pixel there nonzero since it
    /// was last cleared ([`OcclusionMap::reset`] clears only those).
    dirty: Vec<bool>,
}

impl OcclusionMap {
    /// The nearest occluder `1/w` of each pixel, row-major (0 = uncovered).
    pub fn pixels(&self) -> &[f32] {
        &self.inv_w[..(self.width * self.height) as usize]
    }

    /// The pixels and the padding after them, for the span kernels.
    pub(super) fn pixels_with_padding(&self) -> &[f32] {
        &self.inv_w
    }

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
            self.inv_w = vec![0.0; padded_len(n)];
            self.dirty.clear();
        } else {
            clear_dirty_bands(self);
        }
        self.setup.clear();
        self.bins.iter_mut().for_each(Vec::clear);
        self.bounded = false;
    }

    /// Draws the front faces of occluders `ids` (nearest first), leaving out those
    /// already hidden: they are drawn in parts of growing size ([`FIRST_PART`],
    /// [`PART_GROWTH`]), each leaving the map bounded, and each occluder after the
    /// first part whose box the map already hides (the box test, margin included) is
    /// skipped. Its fragments all lie behind what the map holds there, which only
    /// grows nearer, so skipping it leaves the final map exactly as drawing it would.
    /// Answers the number skipped; the map is bounded.
    pub fn draw_occluders(&mut self, scene: &Scene, cam: &Camera, ids: &[u32]) -> usize {
        let mut skipped = 0;
        let (mut start, mut end) = (0, ids.len().min(FIRST_PART));
        loop {
            // The first part is drawn even without occluders: it bounds the cleared
            // map, so that no bounds of an earlier pose remain.
            let from = self.setup.len();
            let mut setup = std::mem::take(&mut self.setup);
            skipped += setup_occluders(self, scene, cam, &ids[start..end], start > 0, &mut setup);
            self.setup = setup;
            draw_binned(self, from);
            if end == ids.len() {
                return skipped;
            }
            start = end;
            end = (end * PART_GROWTH).min(ids.len());
        }
    }

    /// Draws triangles into the map (the nearest fragment wins each pixel) and bounds
    /// it.
    pub fn draw(&mut self, cam: &Camera, tris: impl Iterator<Item = [Vec3; 3]>) {
        let from = self.setup.len();
        let mut setup = std::mem::take(&mut self.setup);
        setup_triangles(self, cam, tris, false, &mut setup);
        self.setup = setup;
        draw_binned(self, from);
    }

    /// Whether a triangle drawn since the reset (all of
    /// [`OcclusionMap::draw_occluders`]' triangles, but those it left out as hidden)
    /// covers pixel `(x, y)` with its f64 `1/w` plane above `bound` there: the
    /// coverage of [`SpanTriangle::row`] (the oracle's) and the plane the oracle
    /// interpolates, without the f32 lanes' error. The triangles reaching the pixel's
    /// band of rows are asked, `hint` (the last one that answered yes: the pixels
    /// asked about one object mostly lie along the edge of one occluder) first.
    pub fn drawn_nearer(&self, x: u32, y: u32, bound: f64, hint: &mut Option<u32>) -> bool {
        let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
        let covers = |i: u32| {
            let t = &self.setup[i as usize];
            let b = &t.tri;
            (b.x0..=b.x1).contains(&x)
                && (b.y0..=b.y1).contains(&y)
                && t.inv_w_at(px, py) > bound
                && t.row(y).is_some_and(|(a, z)| (a..=z).contains(&x))
        };
        if hint.is_some_and(covers) {
            return true;
        }
        let band = (y / draw::BAND) as usize;
        let Some(list) = self.bins.get(band) else {
            return false;
        };
        if let Some(&i) = list.iter().find(|&&i| covers(i)) {
            *hint = Some(i);
            return true;
        }
        false
    }

    /// Builds the tile bounds from the pixels (drawing does it as it goes).
    pub fn build_bounds(&mut self) {
        let w = self.width as usize;
        let level0 = self.dims[0].0 as usize * self.dims[0].1 as usize;
        bound_tile_rows(
            &self.inv_w[..w * self.height as usize],
            w,
            0..self.dims[0].0 as usize,
            &mut self.far[..level0],
            &mut self.near[..level0],
        );
        self.bound_upper_levels(self.all_tiles());
        self.bounded = true;
    }

    /// Every finest tile, as a rect of tiles (inclusive).
    fn all_tiles(&self) -> TileRect {
        let (w, h) = self.dims[0];
        TileRect {
            x0: 0,
            y0: 0,
            x1: w - 1,
            y1: h - 1,
        }
    }

    /// The coarser levels of the bounds over the finest tiles of `rect` (the rest
    /// are as they were).
    fn bound_upper_levels(&mut self, mut rect: TileRect) {
        let far = &mut self.far;
        let near = &mut self.near;
        for l in 1..self.dims.len() {
            let (w, h) = self.dims[l];
            let (cw, ch) = self.dims[l - 1];
            let (o, co) = (self.offsets[l], self.offsets[l - 1]);
            rect = TileRect {
                x0: rect.x0 / 2,
                y0: rect.y0 / 2,
                x1: (rect.x1 / 2).min(w - 1),
                y1: (rect.y1 / 2).min(h - 1),
            };
            // A texel's children are rows 2y and 2y+1 and columns 2x and 2x+1, the
            // last row or column repeated where the child level has an odd count
            // (a min or max with itself changes nothing).
            let (far_below, far_level) = far.split_at_mut(o);
            let (near_below, near_level) = near.split_at_mut(o);
            for y in rect.y0..=rect.y1 {
                let rows = [2 * y, (2 * y + 1).min(ch - 1)].map(|cy| co + (cy * cw) as usize);
                let out = (y * w) as usize;
                for x in rect.x0..=rect.x1 {
                    let cols = [2 * x, (2 * x + 1).min(cw - 1)].map(|cx| cx as usize);
                    // As integers of the bits, as in `tile_band_bounds`.
                    let (mut f, mut n) = (u32::MAX, 0u32);
                    for r in rows {
                        for c in cols {
                            f = f.min(far_below[r + c].to_bits());
                            n = n.max(near_below[r + c].to_bits());
                        }
                    }
                    far_level[out + x as usize] = f32::from_bits(f);
                    near_level[out + x as usize] = f32::from_bits(n);
                }
            }
        }
    }

    /// True if the tile bounds show every fragment of `t` behind the map by the
    /// relative `margin`: its largest `1/w` (at a vertex, `1/w` being a plane over the
    /// triangle; [`SpanTriangle::bounds`]) times `1 + margin` lies below every pixel
    /// of its box. Stale bounds of a map that has only grown nearer since are fine:
    /// they can only answer false more often.
    #[inline(always)]
    pub fn triangle_hidden(&self, t: &SpanTriangle, margin: f64) -> bool {
        let (r, nearest) = t.bounds();
        self.rect_hidden(&r, (nearest * (1.0 + margin)) as f32)
    }

    /// True if the finest tile bounds show the spans `first[r]..=last[r]` of the
    /// [`ROWS`] rows from `y` (first > last: none), all in one row of tiles, of
    /// triangle `t` hidden by the relative `margin`: every tile they reach lies in
    /// front of the largest `1/w` the triangle has over those pixels
    /// ([`SpanTriangle::nearest_in`]) by it. Answers false for a block of no span.
    #[inline(always)]
    pub fn rows_hidden(
        &self,
        t: &SpanTriangle,
        y: u32,
        (first, last): ([i32; ROWS], [i32; ROWS]),
        margin: f64,
    ) -> bool {
        let (mut a, mut b) = (i32::MAX, -1);
        for r in 0..ROWS {
            if first[r] <= last[r] {
                a = a.min(first[r]);
                b = b.max(last[r]);
            }
        }
        if a > b {
            return false;
        }
        let (a, b) = (a as u32, b as u32);
        let nearest = t.nearest_in((a, b), (y, y + ROWS as u32 - 1));
        let threshold = (nearest * (1.0 + margin)) as f32;
        let row = (y / TILE * self.dims[0].0) as usize;
        let tiles = &self.far[row + (a / TILE) as usize..=row + (b / TILE) as usize];
        // NaN fails every comparison.
        tiles.iter().fold(true, |all, &f| all & (f > threshold))
    }

    /// True if every pixel of `r` holds a `1/w` above `t` (the map was bounded by
    /// [`OcclusionMap::build_bounds`]). `t = (1 + margin) / near` asks whether
    /// occluders lie in front of depth `near` everywhere; `t = 0` whether they cover.
    #[inline(always)]
    pub fn rect_hidden(&self, r: &ScreenRect, t: f32) -> bool {
        let tiles = (
            r.x0 / TILE,
            r.y0 / TILE,
            (r.x1 - 1) / TILE,
            (r.y1 - 1) / TILE,
        );
        descent::rect_hidden(self, r, t, tiles, self.dims.len())
    }

    /// Whether every pixel of `r` inside tile `(tx, ty)` holds a `1/w` above `t`.
    #[inline(always)]
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

/// A rect of tiles of one level, ends inclusive.
#[derive(Clone, Copy, Debug)]
struct TileRect {
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
}

impl TexelTest for OcclusionMap {
    /// [`OcclusionMap::rect_hidden`]'s answer for texel `(x, y)` of level `l`: from its
    /// bounds, and at the tiles those leave in doubt from their pixels.
    #[inline(always)]
    fn texel(&self, r: &ScreenRect, t: f32, l: usize, x: u32, y: u32) -> Texel {
        let i = self.offsets[l] + (y * self.dims[l].0 + x) as usize;
        match descent::by_bounds(self.far[i], self.near[i], t) {
            Texel::Split if l == 0 => {
                if self.pixels_hidden(r, x, y, t) {
                    Texel::Hidden
                } else {
                    Texel::Visible
                }
            }
            answer @ (Texel::Hidden | Texel::Visible | Texel::Split) => answer,
        }
    }

    /// The far bounds of the (at most 2×2) block, all above `t`: four loads and one
    /// branch (the corners repeat where the block is one texel wide or high).
    #[inline(always)]
    fn block_hidden(&self, t: f32, l: usize, (x0, y0, x1, y1): (u32, u32, u32, u32)) -> bool {
        let w = self.dims[l].0;
        let at = |x: u32, y: u32| self.far[self.offsets[l] + (y * w + x) as usize];
        (at(x0, y0) > t) & (at(x1, y0) > t) & (at(x0, y1) > t) & (at(x1, y1) > t)
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

/// The finest bounds of tile columns `cols` of every tile row of `px` (whole rows of
/// width `w`, starting at a tile row) into `far`/`near` (those tile rows' bounds,
/// row-major).
fn bound_tile_rows(
    px: &[f32],
    w: usize,
    cols: std::ops::Range<usize>,
    far: &mut [f32],
    near: &mut [f32],
) {
    let t = TILE as usize;
    let tw = w.div_ceil(t);
    for (k, rows) in px.chunks(t * w).enumerate() {
        let tiles = k * tw..(k + 1) * tw;
        tile_band_bounds(
            rows,
            w,
            cols.clone(),
            &mut far[tiles.clone()],
            &mut near[tiles],
        );
    }
}

/// The bounds of tile columns `cols` of one band of tiles (up to [`TILE`] pixel rows
/// of width `w`): per tile, the smallest and largest `1/w` under it. Compared as the
/// integers of their bits, which order the map's values (non-negative, finite or
/// +inf, never NaN: `draw::keep_larger`) as the floats do; integer min and max are
/// associative, so each tile folds its rows lane-wise and then its lanes as a tree,
/// where `f32::min` (with its NaN rule) reduced them one after another.
#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
fn tile_band_bounds(
    rows: &[f32],
    w: usize,
    cols: std::ops::Range<usize>,
    far: &mut [f32],
    near: &mut [f32],
) {
    const T: usize = TILE as usize;
    let bits = |v: f32| v.to_bits() as i32;
    // Tiles start at +inf (what `f32::min` folds from), never at bits that are a NaN.
    let inf = bits(f32::INFINITY);
    let full = w / T;
    for tx in cols.start..cols.end.min(full) {
        let (mut lo, mut hi) = ([inf; T], [0i32; T]);
        for row in rows.chunks_exact(w) {
            let px: &[f32; T] = row[tx * T..tx * T + T].try_into().expect("a tile row");
            for k in 0..T {
                lo[k] = lo[k].min(bits(px[k]));
                hi[k] = hi[k].max(bits(px[k]));
            }
        }
        far[tx] = f32::from_bits(lo.into_iter().fold(inf, i32::min) as u32);
        near[tx] = f32::from_bits(hi.into_iter().fold(0, i32::max) as u32);
    }
    if full < far.len() && cols.contains(&full) {
        let (mut lo, mut hi) = (inf, 0i32);
        for row in rows.chunks_exact(w) {
            for &v in &row[full * T..] {
                lo = lo.min(bits(v));
                hi = hi.max(bits(v));
            }
        }
        far[full] = f32::from_bits(lo as u32);
        near[full] = f32::from_bits(hi as u32);
    }
}

#[cfg(test)]
mod tests;
