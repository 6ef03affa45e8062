//! Triangles as runs of pixels: the exact covered span of each row, and its depth.
//!
//! Coverage is the reference rasterizer's, bit for bit: a pixel is covered when the
//! three f64 edge functions of [`ScreenTriangle`] put its centre inside (top-left rule
//! on ties). Along a row an edge function, as computed, is monotone in the pixel's x
//! (`px - a.x` rounds monotonically, and a product with a constant and a difference
//! from a constant keep that), so each edge's inside set is one ray of the row and
//! their intersection one span. [`SpanTriangle::row`] finds each ray's end from the analytic
//! crossing and then steps with the exact predicate until it holds on one side and
//! fails on the other: a few f64 evaluations per row and edge, however wide the row,
//! and no pixel's coverage differs from the reference's.
//!
//! Depth is kept as `1/w` (the inverse view depth, linear in screen space; 0 means
//! nothing is there, which is also "infinitely far"). A span's value at its first
//! pixel is the reference's f64 interpolation; along the span it is evaluated in f32
//! from an f64 base every [`LANES`] pixels, so its relative error stays near f32's
//! rounding (~1e-7), far below the 1e-4 depth margin every comparison keeps
//! (`cull::deb::DEPTH_MARGIN`).

use glam::Vec3;

use crate::camera::{Camera, ScreenRect};
use crate::reference::raster::{ScreenTriangle, ScreenVertex, edge, screen_polygon};

/// Pixels evaluated together along a span (one AVX2 register of f32).
pub const LANES: usize = 8;

/// Rows whose span ends are computed together (one AVX2 register of f64).
pub const ROWS: usize = 4;

/// A relative bound on how far [`Span::lanes`] (f32 from an f64 base at most
/// `LANES - 1` pixels back) can exceed the exact `1/w` plane: a few f32 roundings,
/// generously (the tests measure under 2e-6 against the reference's depths).
pub const LANE_SLACK: f64 = 4e-6;

/// The lane offsets `0, 1, …, LANES-1`.
pub const RAMP: [f32; LANES] = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0];

/// One edge `a → b` of a screen triangle, set up for its rows.
#[derive(Clone, Copy)]
struct EdgeSetup {
    a: ScreenVertex,
    b: ScreenVertex,
    /// `b.y - a.y`: 0 for a horizontal edge, negative when inside is `x > c`.
    q: f64,
    /// `(b.x - a.x) / q`: the crossing's x per row.
    slope: f64,
}

impl EdgeSetup {
    /// Where the edge crosses the row through `py`, in pixel-index units: pixel `x`
    /// lies on the inner side iff `x > c` (or `x < c`, as the edge leans), up to the
    /// rounding that [`tie_band`] bounds.
    #[inline(always)]
    fn crossing(&self, py: f64) -> f64 {
        self.a.x + self.slope * (py - self.a.y) - 0.5
    }

    /// Whether no pixel index lies within the tie band of crossing `c`, whose floor is
    /// `below`, nor is `c` NaN or huge: then `below` settles the side of every pixel
    /// of the row and no edge function needs evaluating.
    #[inline(always)]
    fn clear_of_ties(&self, c: f64, below: f64) -> bool {
        let frac = c - below;
        let band = tie_band(self.a.x, c);
        // NaN fails every comparison.
        frac > band && frac < 1.0 - band && c.abs() < 1e15
    }
}

/// A screen triangle with what its spans need: coverage setup and `1/w` gradient.
#[derive(Clone, Copy)]
pub struct SpanTriangle {
    pub tri: ScreenTriangle,
    edges: [EdgeSetup; 3],
    /// d(1/w)/dx and d(1/w)/dy: `1/w` is a plane in screen space, taken from `v[0]`.
    slope: f64,
    slope_y: f64,
}

impl SpanTriangle {
    #[inline(always)]
    pub fn new(tri: ScreenTriangle) -> Self {
        let v = &tri.v;
        let edges = [0, 1, 2].map(|k| {
            let (a, b) = (v[(k + 1) % 3], v[(k + 2) % 3]);
            let q = b.y - a.y;
            EdgeSetup {
                a,
                b,
                q,
                slope: (b.x - a.x) / q,
            }
        });
        let inv_area = 1.0 / tri.area;
        // Edge function k is (b.x - a.x)(py - a.y) - (b.y - a.y)(px - a.x), and
        // 1/w = Σ e_k · (1/w)_k / area.
        let slope = -(edges[0].q * v[0].inv_w + edges[1].q * v[1].inv_w + edges[2].q * v[2].inv_w)
            * inv_area;
        let dx = |k: usize| edges[k].b.x - edges[k].a.x;
        let slope_y = (dx(0) * v[0].inv_w + dx(1) * v[1].inv_w + dx(2) * v[2].inv_w) * inv_area;
        SpanTriangle {
            tri,
            edges,
            slope,
            slope_y,
        }
    }

    /// The triangle's pixel box (exclusive ends) and a bound on the `1/w` of every
    /// fragment it has: `1/w` is a plane in screen space, so its largest value over
    /// the triangle is at a vertex; the bound adds [`LANE_SLACK`] for the f32 lane
    /// evaluation ([`Span::lanes`]), so no fragment's computed `1/w` exceeds it.
    #[inline]
    pub fn bounds(&self) -> (ScreenRect, f64) {
        let v = &self.tri.v;
        let nearest = v[0].inv_w.max(v[1].inv_w).max(v[2].inv_w);
        let r = ScreenRect {
            x0: self.tri.x0,
            y0: self.tri.y0,
            x1: self.tri.x1 + 1,
            y1: self.tri.y1 + 1,
            near: (1.0 / nearest) as f32,
            far: f32::INFINITY,
        };
        (r, nearest * (1.0 + LANE_SLACK))
    }

    /// The `1/w` plane at the point `(px, py)` (pixel centres at `x + 0.5`): the same
    /// f64 arithmetic as a span's first pixel.
    #[inline(always)]
    pub fn inv_w_at(&self, px: f64, py: f64) -> f64 {
        let v0 = self.tri.v[0];
        v0.inv_w + self.slope * (px - v0.x) + self.slope_y * (py - v0.y)
    }

    /// The `1/w` plane's slopes along x and y, per pixel.
    #[inline(always)]
    pub fn inv_w_slopes(&self) -> (f64, f64) {
        (self.slope, self.slope_y)
    }

    /// The smallest `1/w` of the three vertices: no fragment of the triangle lies
    /// farther (`1/w` is a plane over it).
    #[inline(always)]
    pub fn farthest_inv_w(&self) -> f64 {
        let v = &self.tri.v;
        v[0].inv_w.min(v[1].inv_w).min(v[2].inv_w)
    }

    /// Whether the `1/w` plane stays far inside f32's range (below 1e30 in size)
    /// over the triangle's box widened by two chunks of [`LANES`] pixels along x and a
    /// row along y: then every lane a span kernel computes there, its f32 slope
    /// times a lane offset included, is a finite number (never NaN or infinite).
    #[inline]
    pub fn plane_is_bounded(&self) -> bool {
        let (t, v0) = (&self.tri, self.tri.v[0]);
        let reach = 2.0 * LANES as f64;
        let dx = (t.x0 as f64 - v0.x)
            .abs()
            .max((t.x1 as f64 + reach - v0.x).abs());
        let dy = (t.y0 as f64 - v0.y)
            .abs()
            .max((t.y1 as f64 + 1.0 - v0.y).abs());
        let size = v0.inv_w.abs() + self.slope.abs() * dx + self.slope_y.abs() * dy;
        // NaN fails the comparison.
        size < 1e30
    }

    /// Pixels in the triangle's box.
    #[inline]
    pub fn box_pixels(&self) -> u32 {
        (self.tri.x1 - self.tri.x0 + 1) * (self.tri.y1 - self.tri.y0 + 1)
    }

    /// The span of pixels `x0..=x1` of row `y` (pixels the triangle covers there).
    #[inline(always)]
    pub fn span(&self, y: u32, x0: u32, x1: u32) -> Span {
        Span {
            x0,
            x1,
            start: self.inv_w_at(x0 as f64 + 0.5, y as f64 + 0.5),
            slope: self.slope,
        }
    }

    /// A bound on the `1/w` of every fragment the triangle has in the pixel rect
    /// `x0..=x1` × `y0..=y1`, as [`SpanTriangle::bounds`]' over the whole triangle:
    /// the plane's largest value at a pixel centre of the rect (a plane is largest at
    /// a corner), widened by [`LANE_SLACK`], and never above the whole triangle's.
    #[inline(always)]
    pub fn nearest_in(&self, (x0, x1): (u32, u32), (y0, y1): (u32, u32)) -> f64 {
        let v0 = self.tri.v[0];
        let larger = |slope: f64, a: u32, b: u32, from: f64| {
            let (a, b) = (
                slope * (a as f64 + 0.5 - from),
                slope * (b as f64 + 0.5 - from),
            );
            if a > b { a } else { b }
        };
        let m = v0.inv_w + larger(self.slope, x0, x1, v0.x) + larger(self.slope_y, y0, y1, v0.y);
        let rect = m + m.abs() * LANE_SLACK;
        let whole = self.bounds().1;
        if rect < whole { rect } else { whole }
    }

    /// Calls `f(y, span)` for every row in `rows` (inclusive) the triangle covers;
    /// stops, answering false, when `f` does.
    #[inline(always)]
    pub fn spans(&self, rows: (u32, u32), f: impl FnMut(u32, Span) -> bool) -> bool {
        self.spans_unsettled(rows, |_, _| false, f)
    }

    /// [`SpanTriangle::spans`], asking `settled(y, ends)` first of each block of
    /// [`ROWS`] rows from `y` (its [`SpanTriangle::row_block`] ends): a block it
    /// answers true for is passed over without its spans.
    #[inline(always)]
    pub fn spans_unsettled(
        &self,
        rows: (u32, u32),
        mut settled: impl FnMut(u32, ([i32; ROWS], [i32; ROWS])) -> bool,
        mut f: impl FnMut(u32, Span) -> bool,
    ) -> bool {
        let y0 = self.tri.y0.max(rows.0);
        let y1 = self.tri.y1.min(rows.1);
        if y0 > y1 {
            return true;
        }
        // Blocks start at multiples of ROWS, so that a triangle drawn band by band
        // (`map/draw.rs`) computes each of its rows once.
        for block in (y0 - y0 % ROWS as u32..=y1).step_by(ROWS) {
            let ends = self.row_block(block, (y0, y1));
            if settled(block, ends) {
                continue;
            }
            let (lo, hi) = ends;
            for r in 0..ROWS {
                if lo[r] > hi[r] {
                    continue;
                }
                let y = block + r as u32;
                if !f(y, self.span(y, lo[r] as u32, hi[r] as u32)) {
                    return false;
                }
            }
        }
        true
    }

    /// [`SpanTriangle::row`] for the [`ROWS`] rows from `y`, computed lane-wise: each
    /// edge's crossing, its floor and the near-tie check for all rows at once (one
    /// AVX2 register of f64), with the same arithmetic as `row`. A row where any edge
    /// is in doubt (a near tie, a NaN or a huge crossing) is answered by `row` itself,
    /// so every answer is `row`'s. Answers each row's first and last pixel, first >
    /// last where the row is empty; rows outside `within` (inclusive) are empty.
    /// (Plain arrays, not `Option`s: building those per row stalled on store
    /// forwarding.)
    #[inline(always)]
    pub fn row_block(&self, y: u32, within: (u32, u32)) -> ([i32; ROWS], [i32; ROWS]) {
        let t = &self.tri;
        let mut py = [0.0; ROWS];
        for (r, py) in py.iter_mut().enumerate() {
            *py = (y + r as u32) as f64 + 0.5;
        }
        let mut lo = [t.x0 as f64; ROWS];
        let mut hi = [t.x1 as f64; ROWS];
        let mut doubt = [false; ROWS];
        for (k, e) in self.edges.iter().enumerate() {
            if e.q == 0.0 {
                // A horizontal edge: its edge function is constant along each row.
                for r in 0..ROWS {
                    if !t.inside_edge(k, edge(e.a, e.b, lo[r] + 0.5, py[r])) {
                        hi[r] = -1.0;
                    }
                }
                continue;
            }
            let mut below = [0.0; ROWS];
            for r in 0..ROWS {
                let c = e.crossing(py[r]);
                below[r] = c.floor();
                doubt[r] |= !e.clear_of_ties(c, below[r]);
            }
            // Compare and select, not `f64::max`/`min` with their NaN fix-ups: a NaN
            // crossing puts its row in doubt, and the row is answered by `row`.
            if e.q < 0.0 {
                for r in 0..ROWS {
                    let b = below[r] + 1.0;
                    lo[r] = if b > lo[r] { b } else { lo[r] };
                }
            } else {
                for r in 0..ROWS {
                    hi[r] = if below[r] < hi[r] { below[r] } else { hi[r] };
                }
            }
        }
        // Every row lane-wise first, without a branch (a branch per row, with its
        // arrays built on the stack, was a sixth of a draw): `as i32` saturates, so a
        // row left empty by its edges stays first > last; rows outside `within` get
        // last = -1 (first is never negative: lo starts at x0 ≥ 0).
        let (mut first, mut last) = ([0; ROWS], [0; ROWS]);
        let mut any_doubt = false;
        // Clamped to the box widened by one pixel each way (a NaN to its left end):
        // every value is then a finite integer in i32's range.
        let (left, right) = (t.x0 as f64 - 1.0, t.x1 as f64 + 1.0);
        let clamp = |v: f64| {
            let v = if v > left { v } else { left };
            if v < right { v } else { right }
        };
        for r in 0..ROWS {
            let row = y + r as u32;
            let wanted = row >= within.0 && row <= within.1;
            // SAFETY: `clamp` answers a finite integer-valued f64 in `x0-1..=x1+1`,
            // within i32 (pixel indices are below 2^20), which is what
            // `to_int_unchecked` requires; the saturating `as` adds NaN and range
            // fix-ups per lane.
            let (a, b) = unsafe {
                (
                    clamp(lo[r]).to_int_unchecked::<i32>(),
                    clamp(hi[r]).to_int_unchecked::<i32>(),
                )
            };
            first[r] = a;
            last[r] = if wanted { b } else { -1 };
            doubt[r] &= wanted;
            any_doubt |= doubt[r];
        }
        if any_doubt {
            // A near tie (rare): those rows from the reference predicate.
            for r in 0..ROWS {
                if doubt[r] {
                    let row = y + r as u32;
                    (first[r], last[r]) = match self.row(row) {
                        Some((a, b)) => (a as i32, b as i32),
                        None => (0, -1),
                    };
                }
            }
        }
        (first, last)
    }

    /// Inclusive x-range of the pixel centres of row `y` the triangle covers (exactly
    /// the pixels the reference rasterizer's per-pixel test accepts), or None.
    ///
    /// Each edge's end of the span comes from its crossing `c` of the row (in
    /// pixel-index units: pixel x lies on the inner side iff `x > c`, or `x < c`, as
    /// the edge leans). The reference's f64 edge function, and `c` itself, are off
    /// from the exact line by at most a few units of rounding of the coordinates
    /// involved, so for every pixel farther than [`tie_band`] from `c` the side is
    /// certain and no edge function needs evaluating; only a pixel within the band (a
    /// near tie) is decided by the reference's own predicate ([`row_span_stepping`]
    /// does that for every pixel it looks at, and is this one's test oracle).
    #[inline(always)]
    pub fn row(&self, y: u32) -> Option<(u32, u32)> {
        let t = &self.tri;
        let py = y as f64 + 0.5;
        // Pixel indices as f64 (exact below 2^53): one conversion per row, not per edge.
        let (mut lo, mut hi) = (t.x0 as f64, t.x1 as f64);
        for (k, e) in self.edges.iter().enumerate() {
            let inside = |x: f64| t.inside_edge(k, edge(e.a, e.b, x + 0.5, py));
            if e.q == 0.0 {
                // The edge function does not change along the row.
                if !inside(lo) {
                    return None;
                }
                continue;
            }
            let c = e.crossing(py);
            if c.is_nan() || c.abs() >= 1e15 {
                return row_span_stepping(t, y);
            }
            let below = c.floor();
            if e.clear_of_ties(c, below) {
                // No pixel index is near c: inside is exactly x > c (or x < c).
                if e.q < 0.0 {
                    lo = lo.max(below + 1.0);
                } else {
                    hi = hi.min(below);
                }
            } else {
                // A near tie at the nearest index n: the reference's predicate decides n.
                let n = if c - below < 0.5 { below } else { below + 1.0 };
                if e.q < 0.0 {
                    lo = lo.max(if inside(n) { n } else { n + 1.0 });
                } else {
                    hi = hi.min(if inside(n) { n } else { n - 1.0 });
                }
            }
            if lo > hi {
                return None;
            }
        }
        Some((lo as u32, hi as u32))
    }
}

/// The covered pixels `x0..=x1` of one row and their `1/w`.
#[derive(Clone, Copy, Debug)]
pub struct Span {
    pub x0: u32,
    pub x1: u32,
    start: f64,
    slope: f64,
}

impl Span {
    /// Pixels in the span.
    pub fn pixels(&self) -> usize {
        (self.x1 - self.x0 + 1) as usize
    }

    /// The span's pixels rounded up to whole [`LANES`]: what the kernels read and
    /// write from its first pixel. Buffers they run on keep `LANES - 1` pixels of
    /// padding past their last row ([`padded_len`]), and a kernel leaves the pixels
    /// past the span unchanged with a lane blend ([`Span::lanes_or`]) or a bit mask
    /// (the map draw's `TAIL_KEEP`: lanes of 0, which never win), never a masked
    /// load or store (microcoded on some CPUs, and the costliest part of a short span).
    pub fn lanes_len(&self) -> usize {
        self.pixels().next_multiple_of(LANES)
    }

    /// [`Span::lanes`] with the lanes past the span set to `outside` (lane `k` of the
    /// chunk at `i` lies in the span iff `k < pixels - i`). Blended arithmetically
    /// (`v·m + outside·(1 - m)` with `m` 1 or 0, both exact), which LLVM vectorizes;
    /// a lane-wise `if` stays a branch per lane.
    #[inline(always)]
    pub fn lanes_or(&self, i: usize, outside: f32) -> [f32; LANES] {
        let left = (self.pixels() - i) as f32;
        let mut v = self.lanes(i);
        for k in 0..LANES {
            let m = (left - RAMP[k]).clamp(0.0, 1.0);
            v[k] = v[k] * m + outside * (1.0 - m);
        }
        v
    }

    /// `1/w` of pixels `x0 + i + k` for `k` in `0..LANES`, each evaluated in f64 and
    /// rounded once to f32 (so within f32's rounding, 2^-24 of itself, of the f64
    /// plane, where [`Span::lanes`] may stray by [`LANE_SLACK`]), lanes past the span
    /// set to `outside`. The exact ID buffer's depths: its near ties are decided as
    /// finely as the reference's.
    #[inline(always)]
    pub fn lanes_exact_or(&self, i: usize, outside: f32) -> [f32; LANES] {
        let left = self.pixels() - i;
        let mut v = [0.0; LANES];
        for (k, v) in v.iter_mut().enumerate() {
            let exact = (self.start + self.slope * (i + k) as f64) as f32;
            *v = if k < left { exact } else { outside };
        }
        v
    }

    /// [`Span::lanes`] of the chunks from pixel `x0 + i` on, one chunk after another:
    /// the f64 base steps by `LANES` pixels with an addition (its rounding, ~1e-16 of
    /// the base per chunk, stays far below f32's) where `lanes` multiplies anew.
    #[inline(always)]
    pub fn lanes_from(&self, i: usize) -> ChunkLanes {
        ChunkLanes {
            base: self.start + self.slope * i as f64,
            step: self.slope * LANES as f64,
            slope: self.slope as f32,
        }
    }

    /// `1/w` of pixels `x0 + i + k` for `k` in `0..LANES`, from an f64 base at `x0 + i`.
    #[inline(always)]
    pub fn lanes(&self, i: usize) -> [f32; LANES] {
        let base = (self.start + self.slope * i as f64) as f32;
        let s = self.slope as f32;
        // A plain loop: `RAMP.map` compiles to a spilled per-lane loop.
        let mut v = [0.0; LANES];
        for k in 0..LANES {
            v[k] = base + s * RAMP[k];
        }
        v
    }
}

/// The chunks of a span's `1/w`, [`LANES`] pixels at a time ([`Span::lanes_from`]).
pub struct ChunkLanes {
    base: f64,
    step: f64,
    slope: f32,
}

impl ChunkLanes {
    /// The next chunk's `1/w`, as [`Span::lanes`] computes them from its base.
    #[inline(always)]
    pub fn next_chunk(&mut self) -> [f32; LANES] {
        let base = self.base as f32;
        self.base += self.step;
        let mut v = [0.0; LANES];
        for k in 0..LANES {
            v[k] = base + self.slope * RAMP[k];
        }
        v
    }
}

/// Length of a buffer of `pixels` that span kernels run on: [`LANES`]` - 1` pixels of
/// padding, so that a row's last chunk stays inside it ([`Span::lanes_len`]).
pub fn padded_len(pixels: usize) -> usize {
    pixels + LANES - 1
}

/// The screen triangles of a world triangle (after near/far clipping), each ready to
/// be cut into spans. Most triangles give one; a clipped one up to three.
#[inline(always)]
pub fn span_triangles(
    cam: &Camera,
    tri: [Vec3; 3],
    mut f: impl FnMut(&SpanTriangle) -> bool,
) -> bool {
    for t in screen_polygon(cam, tri).fan() {
        if let Some(t) = ScreenTriangle::new(cam.width, cam.height, t) {
            if !f(&SpanTriangle::new(t)) {
                return false;
            }
        }
    }
    true
}

/// How close to the crossing `c` a pixel index may lie before its side is in doubt: a
/// generous bound (a thousand times the rounding of f64 sums and products of the
/// coordinates) on how far the computed crossing and the reference's computed edge
/// function can stray from the exact line, in pixels.
#[inline(always)]
fn tie_band(ax: f64, c: f64) -> f64 {
    1e-12 * (ax.abs() + c.abs() + 1024.0)
}

/// [`SpanTriangle::row`] by the reference predicate alone: each ray's end is found by stepping
/// from the crossing until the predicate holds on one side and fails on the other
/// (it is monotone along a row: `px - a.x` rounds monotonically, and a product with a
/// constant and a difference from a constant keep that).
pub fn row_span_stepping(t: &ScreenTriangle, y: u32) -> Option<(u32, u32)> {
    let py = y as f64 + 0.5;
    let (mut lo, mut hi) = (t.x0 as i64, t.x1 as i64);
    for k in 0..3 {
        let (a, b): (ScreenVertex, ScreenVertex) = (t.v[(k + 1) % 3], t.v[(k + 2) % 3]);
        let inside = |x: i64| t.inside_edge(k, edge(a, b, x as f64 + 0.5, py));
        let q = b.y - a.y;
        if q == 0.0 {
            if !inside(lo) {
                return None;
            }
            continue;
        }
        let crossing = a.x + (b.x - a.x) * (py - a.y) / q - 0.5;
        if q < 0.0 {
            let mut x = guess(crossing, lo, hi + 1);
            while x > lo && inside(x - 1) {
                x -= 1;
            }
            while x <= hi && !inside(x) {
                x += 1;
            }
            lo = x;
        } else {
            let mut x = guess(crossing, lo - 1, hi);
            while x < hi && inside(x + 1) {
                x += 1;
            }
            while x >= lo && !inside(x) {
                x -= 1;
            }
            hi = x;
        }
        if lo > hi {
            return None;
        }
    }
    Some((lo as u32, hi as u32))
}

/// The crossing rounded to a pixel and clamped to `lo..=hi` (NaN gives `lo`).
fn guess(crossing: f64, lo: i64, hi: i64) -> i64 {
    if crossing.is_nan() {
        return lo;
    }
    crossing.clamp(lo as f64, hi as f64) as i64
}

#[cfg(test)]
mod tests;
