//! Drawing a region map's occluders: per-cell depth bounds that hold over the whole
//! cell, and the leak edges (see `region::map` for what they are for).

use glam::{Vec3, Vec4Swizzles};

use crate::camera::Camera;

use super::spans::{EdgeTest, row_span};

/// Relative and absolute slack on depth comparisons (f32 arithmetic in the bounds).
pub(super) const DEPTH_SLACK_REL: f32 = 1e-5;
pub(super) const DEPTH_SLACK_ABS: f32 = 1e-5;

/// A triangle of the map in screen space: pixel coordinates and `1/depth`, which is
/// affine in them.
pub(super) struct ScreenTriangle {
    pub(super) p: [[f32; 2]; 3],
    pub(super) depth: [f32; 3],
    /// `1/depth = a·x + b·y + c` (f64: the terms are large beside their sum).
    plane: [f64; 3],
    /// Sign of its screen area: which way it faces the centre.
    pub(super) facing: bool,
}

/// Point `c` in `cam`'s pixels, with its view depth; `None` at or before the near
/// plane, beyond the far one, or off any finite pixel.
pub(super) fn project(cam: &Camera, c: Vec3) -> Option<([f32; 2], f32)> {
    let (w, h) = (cam.width as f32, cam.height as f32);
    let v = (cam.view * c.extend(1.0)).xyz();
    let d = -v.z;
    if !(d > cam.near && d <= cam.far) {
        return None;
    }
    let p = [
        (v.x * cam.scale[0] / d * 0.5 + 0.5) * w,
        (0.5 - v.y * cam.scale[1] / d * 0.5) * h,
    ];
    p.iter().all(|x| x.is_finite()).then_some((p, d))
}

/// `corners` as seen from `cam`, or `None` when the triangle is not drawn: a corner
/// at or before the near plane (it would need clipping, and a clipped triangle's new
/// edges are no edges of the scene) or no area on screen.
pub(super) fn screen_triangle(cam: &Camera, corners: [Vec3; 3]) -> Option<ScreenTriangle> {
    let mut p = [[0.0f32; 2]; 3];
    let mut depth = [0.0f32; 3];
    for (i, c) in corners.iter().enumerate() {
        (p[i], depth[i]) = project(cam, *c)?;
    }
    // 1/depth is affine in screen space: solve a·x + b·y + c = 1/d at the corners (f64).
    let [[x0, y0], [x1, y1], [x2, y2]] = p.map(|q| q.map(f64::from));
    let area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0);
    if area.abs() < 1e-9 {
        return None;
    }
    let iz = depth.map(|d| 1.0 / f64::from(d));
    let a = ((iz[1] - iz[0]) * (y2 - y0) - (iz[2] - iz[0]) * (y1 - y0)) / area;
    let b = ((x1 - x0) * (iz[2] - iz[0]) - (x2 - x0) * (iz[1] - iz[0])) / area;
    let c = iz[0] - a * x0 - b * y0;
    Some(ScreenTriangle {
        p,
        depth,
        plane: [a, b, c],
        facing: area > 0.0,
    })
}

/// `v.floor()`, inline: without SSE4.1 the standard one is a call into libm, and the
/// map's drawing floors a few numbers per edge step and per triangle.
#[inline(always)]
pub(super) fn floor(v: f32) -> f32 {
    if v.abs() < 2.0e9 {
        let t = v as i32 as f32;
        if t > v { t - 1.0 } else { t }
    } else {
        v.floor()
    }
}

/// The test of the cells a polygon covers whole: inside every edge by a margin.
const COVERS: EdgeTest = EdgeTest::Holds(1e-3);

/// Side of the square tiles over which [`Cells`] keeps the greatest `cover`: a
/// triangle behind a tile's greatest cover changes nothing in it and is skipped whole.
const TILE: usize = 8;

/// Whether depth `d` lies behind depth `cover` beyond the slack of f32 bounds.
fn behind(d: f32, cover: f32) -> bool {
    d * (1.0 - DEPTH_SLACK_REL) > cover * (1.0 + DEPTH_SLACK_REL) + DEPTH_SLACK_ABS
}

/// What the triangles touching each cell say of it while they are drawn: first the
/// covers ([`cover_triangle`], [`cover_pair`], nearest first), then the rest
/// ([`rasterize`]). A triangle whose every depth in a cell lies behind the cell's
/// cover is never the first surface there, so it is left out of the cell: that
/// keeps its depth range out of the cell's spread, and hidden triangles cost a
/// tile test instead of a pass over their cells.
pub(super) struct Cells {
    w: usize,
    h: usize,
    /// The least depth any of them has in the cell.
    lo: Vec<f32>,
    /// A bound on the first drawn depth at some point of the cell: the least of the
    /// depth at the cell's centre of the triangles that cover it, and the greatest
    /// depth in the cell of the triangles that surely meet it (∞: none for sure).
    anchor: Vec<f32>,
    /// The sum over them of the depth range each has in the cell.
    spread: Vec<f32>,
    /// The least, over triangles (or convex pairs of them) that cover the whole cell,
    /// of the greatest depth they have in it.
    cover: Vec<f32>,
    touched: Vec<bool>,
    /// The greatest `cover` of each tile's cells, tiles row by row.
    tile_cover: Vec<f32>,
    tiles_w: usize,
    /// Per row of the polygon drawn, its cells and its inner cells (`row_span`),
    /// kept between polygons.
    spans: Vec<[usize; 4]>,
}

impl Cells {
    pub(super) fn new(w: usize, h: usize) -> Self {
        let n = w * h;
        let tiles_w = w.div_ceil(TILE);
        Cells {
            w,
            h,
            lo: vec![f32::INFINITY; n],
            anchor: vec![f32::INFINITY; n],
            spread: vec![0.0; n],
            cover: vec![f32::INFINITY; n],
            touched: vec![false; n],
            tile_cover: vec![f32::INFINITY; tiles_w * h.div_ceil(TILE)],
            tiles_w,
            spans: Vec::new(),
        }
    }

    /// `(lo, hi, touched)` per cell. `hi` bounds the first drawn surface anywhere in
    /// a cell where that surface is continuous: from the anchor's point to any point
    /// of the cell a straight path crosses each triangle once, and each changes the
    /// depth by at most its range in the cell, so the surface stays within the
    /// anchor's depth plus the sum of the ranges (of the triangles that may be the
    /// first surface there: not those behind the cover). (Where it is not
    /// continuous a leak edge shows in the cell, and the box test refuses such cells
    /// anyway.) A surface that covers the whole cell bounds it too: the least such
    /// bound is taken.
    pub(super) fn bounds(self) -> (Vec<f32>, Vec<f32>, Vec<bool>) {
        let hi = self
            .anchor
            .iter()
            .zip(&self.spread)
            .zip(&self.cover)
            .map(|((&c, &s), &whole)| {
                (c + s).min(whole) * (1.0 + DEPTH_SLACK_REL) + DEPTH_SLACK_ABS
            })
            .collect();
        (self.lo, hi, self.touched)
    }

    /// The cells `[x0, x1] × [y0, y1]` (inclusive) that the bounding box of `p`
    /// touches on the map; `None` if none.
    fn rect<const N: usize>(&self, p: &[[f32; 2]; N]) -> Option<[usize; 4]> {
        let (mut x0, mut x1, mut y0, mut y1) = (f32::MAX, f32::MIN, f32::MAX, f32::MIN);
        for q in p {
            (x0, x1, y0, y1) = (x0.min(q[0]), x1.max(q[0]), y0.min(q[1]), y1.max(q[1]));
        }
        let cx1 = (floor(x1) as i64).min(self.w as i64 - 1);
        let cy1 = (floor(y1) as i64).min(self.h as i64 - 1);
        let (cx0, cy0) = (floor(x0).max(0.0) as usize, floor(y0).max(0.0) as usize);
        (cx1 >= 0 && cy1 >= 0 && cx0 <= cx1 as usize && cy0 <= cy1 as usize).then_some([
            cx0,
            cx1 as usize,
            cy0,
            cy1 as usize,
        ])
    }

    /// Calls `f` with each cell index of `rect` on which every one of `edges` passes
    /// `test` (row by row, [`row_span`]) and whose tile's greatest cover a depth of
    /// `dmin` does not lie behind, tile by tile, and with whether the cell passes
    /// `inner` too (false without one); then refreshes the greatest cover of the
    /// tiles where `f` said it lowered one.
    fn each_cell(
        &mut self,
        rect: [usize; 4],
        dmin: f32,
        (edges, test, inner): (&[[f32; 3]], EdgeTest, Option<EdgeTest>),
        mut f: impl FnMut(&mut Self, usize, bool) -> bool,
    ) {
        let [cx0, cx1, cy0, cy1] = rect;
        let mut spans = std::mem::take(&mut self.spans);
        for ty in cy0 / TILE..=cy1 / TILE {
            let open = |tx: usize| !behind(dmin, self.tile_cover[ty * self.tiles_w + tx]);
            if !(cx0 / TILE..=cx1 / TILE).any(open) {
                continue; // hidden on this band of tiles: no row to find
            }
            let rows = (ty * TILE).max(cy0)..((ty + 1) * TILE).min(cy1 + 1);
            spans.clear();
            spans.extend(rows.clone().map(|cy| {
                let Some((a, b)) = row_span(edges, test, cy, [cx0, cx1]) else {
                    return [1, 0, 1, 0];
                };
                let (ia, ib) = inner
                    .and_then(|inner| row_span(edges, inner, cy, [a, b]))
                    .unwrap_or((1, 0));
                [a, b, ia, ib]
            }));
            for tx in cx0 / TILE..=cx1 / TILE {
                let tile = ty * self.tiles_w + tx;
                if behind(dmin, self.tile_cover[tile]) {
                    continue;
                }
                let (ys, xs) = (ty * TILE..(ty + 1) * TILE, tx * TILE..(tx + 1) * TILE);
                let mut lowered = false;
                for cy in rows.clone() {
                    let [a, b, ia, ib] = spans[cy - rows.start];
                    for cx in xs.start.max(a)..xs.end.min(b + 1) {
                        lowered |= f(self, cy * self.w + cx, ia <= cx && cx <= ib);
                    }
                }
                if lowered {
                    let mut most = f32::NEG_INFINITY;
                    for cy in ys.start..ys.end.min(self.h) {
                        for cx in xs.start..xs.end.min(self.w) {
                            most = most.max(self.cover[cy * self.w + cx]);
                        }
                    }
                    self.tile_cover[tile] = most;
                }
            }
        }
        self.spans = spans;
    }

    /// Lowers cell `i`'s cover to `far`; whether it did.
    fn lower_cover(&mut self, i: usize, far: f32) -> bool {
        let lower = far < self.cover[i];
        if lower {
            self.cover[i] = far;
            self.touched[i] = true;
        }
        lower
    }

    /// The cell `[x0, x1] × [y0, y1]` of index `i`.
    fn cell(&self, i: usize) -> [f32; 4] {
        let (x, y) = ((i % self.w) as f32, (i / self.w) as f32);
        [x, x + 1.0, y, y + 1.0]
    }
}

/// Edge functions of a convex polygon, positive inside: `n·(q − a)` with `n` turned
/// towards the inside (the polygon's corners turn one way, `sign` saying which).
fn edge_functions<const N: usize>(p: &[[f32; 2]; N], sign: f32) -> [[f32; 3]; N] {
    std::array::from_fn(|i| {
        let (a, b) = (p[i], p[(i + 1) % N]);
        let (nx, ny) = ((a[1] - b[1]) * sign, (b[0] - a[0]) * sign);
        [nx, ny, -(nx * a[0] + ny * a[1])]
    })
}

/// Which way a triangle's corners turn on screen: `1` or `-1`.
fn turn_sign(p: &[[f32; 2]; 3]) -> f32 {
    let [a, b, c] = *p;
    let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    if area >= 0.0 { 1.0 } else { -1.0 }
}

/// The least and greatest `1/depth` of triangle `t`'s plane over the cell `[x0, x1]
/// × [y0, y1]`: at the corners its gradient picks (the plane is affine on screen).
fn inverse_depths(t: &ScreenTriangle, cell: [f32; 4]) -> (f64, f64) {
    let [x0, x1, y0, y1] = cell.map(f64::from);
    let [a, b, c] = t.plane;
    let (xl, xh) = if a >= 0.0 { (x0, x1) } else { (x1, x0) };
    let (yl, yh) = if b >= 0.0 { (y0, y1) } else { (y1, y0) };
    (a * xl + b * yl + c, a * xh + b * yh + c)
}

/// The greatest depth triangle `t` has in the cell: its plane's where that stays
/// in front over the cell, within its corners' depths.
fn far_in(t: &ScreenTriangle, cell: [f32; 4]) -> f32 {
    let dmax = t.depth[0].max(t.depth[1]).max(t.depth[2]);
    let (iz_lo, _) = inverse_depths(t, cell);
    if iz_lo > 0.0 {
        ((1.0 / iz_lo) as f32).min(dmax)
    } else {
        dmax
    }
}

/// The least and greatest depth triangle `t` has in the cell (as [`far_in`]).
fn depth_in(t: &ScreenTriangle, cell: [f32; 4]) -> (f32, f32) {
    let (iz_lo, iz_hi) = inverse_depths(t, cell);
    let dmin = t.depth[0].min(t.depth[1]).min(t.depth[2]);
    let dmax = t.depth[0].max(t.depth[1]).max(t.depth[2]);
    let far = if iz_lo > 0.0 {
        ((1.0 / iz_lo) as f32).min(dmax)
    } else {
        dmax
    };
    let near = if iz_hi > 0.0 {
        ((1.0 / iz_hi) as f32).max(dmin)
    } else {
        dmin
    };
    (near, far)
}

/// The least depth of a triangle.
fn nearest(t: &ScreenTriangle) -> f32 {
    t.depth[0].min(t.depth[1]).min(t.depth[2])
}

/// Folds the triangle into the covers of the cells it covers whole: its greatest
/// depth in each.
pub(super) fn cover_triangle(t: &ScreenTriangle, cells: &mut Cells) {
    let Some(rect) = cells.rect(&t.p) else {
        return;
    };
    let edges = edge_functions(&t.p, turn_sign(&t.p));
    cells.each_cell(rect, nearest(t), (&edges, COVERS, None), |cells, i, _| {
        let cell = cells.cell(i);
        cells.lower_cover(i, far_in(t, cell))
    });
}

/// Folds the triangle into the cells it touches where it may be the first surface
/// (exact separating-axis test of the triangle against each cell's closed square;
/// not behind the cell's cover): its least depth and its depth range inside the
/// cell, and a bound on the first surface somewhere in the cell where it covers the
/// cell's centre or surely meets the cell. The covers must be folded in first.
pub(super) fn rasterize(t: &ScreenTriangle, cells: &mut Cells) {
    let Some(rect) = cells.rect(&t.p) else {
        return;
    };
    let xs = t.p.map(|q| q[0]);
    let ys = t.p.map(|q| q[1]);
    let min = |v: [f32; 3]| v[0].min(v[1]).min(v[2]);
    let max = |v: [f32; 3]| v[0].max(v[1]).max(v[2]);
    let (dmin, dmax) = (min(t.depth), max(t.depth));
    let edges = edge_functions(&t.p, turn_sign(&t.p));
    let [pa, pb, pc] = t.plane;
    // Separated where some edge is negative at the cell corner it favours most
    // (with a little slack: touching more cells is conservative). The cells it
    // covers whole (`interior`) have their centres inside too (the edge tests are
    // monotone), and there the centre's depth, no more than the far one, bounds
    // the anchor without the test below.
    let touches = (&edges[..], EdgeTest::Meets(1e-3), Some(COVERS));
    cells.each_cell(rect, dmin, touches, |cells, i, interior| {
        let cell @ [x0, x1, y0, y1] = cells.cell(i);
        let (near, far) = depth_in(t, cell);
        if behind(near, cells.cover[i]) {
            return false; // never the first surface here
        }
        cells.lo[i] = cells.lo[i].min(near * (1.0 - DEPTH_SLACK_REL));
        cells.spread[i] += (far - near).max(0.0) * (1.0 + DEPTH_SLACK_REL);
        cells.touched[i] = true;
        // The centre counts as covered only inside every edge by a margin.
        let (mx, my) = (x0 + 0.5, y0 + 0.5);
        let inside = interior
            || edges
                .iter()
                .all(|&[nx, ny, k]| nx * mx + ny * my + k > 1e-3 * (nx.abs() + ny.abs()));
        if inside {
            let iz = pa * f64::from(mx) + pb * f64::from(my) + pc;
            if iz > 0.0 {
                let d = ((1.0 / iz) as f32).clamp(dmin, dmax);
                cells.anchor[i] = cells.anchor[i].min(d);
            }
        }
        // A triangle that surely meets the cell (no axis separates them even by a
        // margin) bounds the first surface at some point of it by its far depth:
        // what holds a cell whose centre lies on a seam of two triangles.
        let m = 1e-3;
        let meets = !interior
            && min(xs) < x1 - m
            && max(xs) > x0 + m
            && min(ys) < y1 - m
            && max(ys) > y0 + m
            && edges.iter().all(|&[nx, ny, k]| {
                let x = if nx >= 0.0 { x1 } else { x0 };
                let y = if ny >= 0.0 { y1 } else { y0 };
                nx * x + ny * y + k > m * (nx.abs() + ny.abs())
            });
        if meets {
            cells.anchor[i] = cells.anchor[i].min(far);
        }
        false
    });
}

/// Folds the quad of `t` and `n`, which share `t`'s edge `e`, into the covers of the
/// cells it covers whole, where it is convex: the greater of the two triangles'
/// greatest depths in the cell.
pub(super) fn cover_pair(t: &ScreenTriangle, e: usize, n: &ScreenTriangle, cells: &mut Cells) {
    let (a, b, c) = (t.p[e], t.p[(e + 1) % 3], t.p[(e + 2) % 3]);
    // The corner of `n` off the shared edge (welded corners project identically).
    let Some(&d) = n.p.iter().find(|&&q| q != a && q != b) else {
        return;
    };
    let quad = [a, d, b, c];
    let turn = |p: [f32; 2], q: [f32; 2], r: [f32; 2]| {
        (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])
    };
    let turns: [f32; 4] =
        std::array::from_fn(|i| turn(quad[i], quad[(i + 1) % 4], quad[(i + 2) % 4]));
    let sign = if turns[0] > 0.0 { 1.0 } else { -1.0 };
    if !turns.iter().all(|&x| x * sign > 1e-6) {
        return; // not strictly convex
    }
    let Some(rect) = cells.rect(&quad) else {
        return;
    };
    let edges = edge_functions(&quad, sign);
    let covers = (&edges[..], COVERS, None);
    cells.each_cell(rect, nearest(t).min(nearest(n)), covers, |cells, i, _| {
        let cell = cells.cell(i);
        cells.lower_cover(i, far_in(t, cell).max(far_in(n, cell)))
    });
}

/// The leak mask while its edges are drawn, with the greatest `hi` of each tile of
/// [`TILE`] cells: a run of an edge whose nearest depth lies behind every tile it
/// touches marks nothing and is passed over whole, and so is a hidden edge.
pub(super) struct LeakMask<'a> {
    w: usize,
    h: usize,
    hi: &'a [f32],
    tiles_w: usize,
    tile_hi: Vec<f32>,
    /// Per cell: whether a leak edge may show in it.
    pub(super) leak: Vec<bool>,
}

/// A point of an edge on the map: pixel position and view depth.
pub(super) type EdgePoint = ([f32; 2], f32);

/// Steps of [`LeakMask::draw`] tested against the tiles at once (4 pixels).
const CHUNK: usize = 8;

impl<'a> LeakMask<'a> {
    pub(super) fn new(w: usize, h: usize, hi: &'a [f32]) -> Self {
        let (tiles_w, tiles_h) = (w.div_ceil(TILE), h.div_ceil(TILE));
        let mut tile_hi = vec![f32::NEG_INFINITY; tiles_w * tiles_h];
        for y in 0..h {
            for x in 0..w {
                let t = &mut tile_hi[(y / TILE) * tiles_w + x / TILE];
                *t = t.max(hi[y * w + x]);
            }
        }
        LeakMask {
            w,
            h,
            hi,
            tiles_w,
            tile_hi,
            leak: vec![false; w * h],
        }
    }

    /// The cells `[x0, x1] × [y0, y1]` that the closed box of `a` and `b` touches
    /// (with a little slack), as floats; empty (`x0 > x1` or `y0 > y1`) off the map.
    fn box_cells(&self, a: [f32; 2], b: [f32; 2]) -> [f32; 4] {
        [
            floor(a[0].min(b[0]) - 1e-3).max(0.0),
            floor(a[0].max(b[0]) + 1e-3).min(self.w as f32 - 1.0),
            floor(a[1].min(b[1]) - 1e-3).max(0.0),
            floor(a[1].max(b[1]) + 1e-3).min(self.h as f32 - 1.0),
        ]
    }

    /// Whether depth `nearest` is behind every cell of the tiles that the box of
    /// `a` and `b` touches (so nothing there would be marked).
    fn behind_tiles(&self, a: [f32; 2], b: [f32; 2], nearest: f32) -> bool {
        let [x0, x1, y0, y1] = self.box_cells(a, b);
        if !(x0 <= x1 && y0 <= y1) {
            return true;
        }
        let (tx0, tx1) = (x0 as usize / TILE, x1 as usize / TILE);
        for ty in y0 as usize / TILE..=y1 as usize / TILE {
            for tx in tx0..=tx1 {
                if !behind_hi(nearest, self.tile_hi[ty * self.tiles_w + tx]) {
                    return false;
                }
            }
        }
        true
    }

    /// Whether the segment from `a` to `b` lies behind `hi` wherever it runs, with
    /// a pixel and a little depth to spare: its parts, projected again, are drawn
    /// only where it is not.
    pub(super) fn hidden(&self, a: EdgePoint, b: EdgePoint) -> bool {
        let lo = [a.0[0].min(b.0[0]) - 1.0, a.0[1].min(b.0[1]) - 1.0];
        let hi = [a.0[0].max(b.0[0]) + 1.0, a.0[1].max(b.0[1]) + 1.0];
        self.behind_tiles(lo, hi, a.1.min(b.1) * (1.0 - 1e-4))
    }

    /// Marks every cell that the edge from `a` to `b` passes through where its
    /// depth is not behind the cell's `hi`: in steps of at most half a pixel, each
    /// step's closed bounding box of cells.
    pub(super) fn draw(&mut self, a: EdgePoint, b: EdgePoint) {
        let (pa, pb) = (a.0, b.0);
        let length = (pb[0] - pa[0]).abs().max((pb[1] - pa[1]).abs());
        let steps = ((length / 0.5).ceil() as usize).clamp(1, 1 << 16);
        // 1/depth is affine along the projected edge.
        let (ia, ib) = (1.0 / a.1, 1.0 / b.1);
        let at = |k: usize| {
            let s = k as f32 / steps as f32;
            (
                [pa[0] + (pb[0] - pa[0]) * s, pa[1] + (pb[1] - pa[1]) * s],
                ia + (ib - ia) * s,
            )
        };
        for first in (0..steps).step_by(CHUNK) {
            let last = (first + CHUNK).min(steps);
            let (from, to) = (at(first), at(last));
            // The chunk's nearest depth is at one of its ends (1/depth affine), and
            // its steps' boxes lie in the box of its ends.
            if self.behind_tiles(from.0, to.0, 1.0 / from.1.max(to.1)) {
                continue;
            }
            let mut prev = from;
            for k in first + 1..=last {
                let next = at(k);
                // Nearest depth on this step: its larger 1/depth.
                let nearest = 1.0 / prev.1.max(next.1);
                let [x0, x1, y0, y1] = self.box_cells(prev.0, next.0);
                if x0 <= x1 && y0 <= y1 {
                    for y in y0 as usize..=y1 as usize {
                        for x in x0 as usize..=x1 as usize {
                            let i = y * self.w + x;
                            if !behind_hi(nearest, self.hi[i]) {
                                self.leak[i] = true;
                            }
                        }
                    }
                }
                prev = next;
            }
        }
    }
}

/// Whether depth `d` lies behind a cell's (or tile's) `hi` beyond the f32 slack.
fn behind_hi(d: f32, hi: f32) -> bool {
    // Not in front: also where either is not a number.
    (d.partial_cmp(&(hi * (1.0 + DEPTH_SLACK_REL) + DEPTH_SLACK_ABS)))
        .is_none_or(|o| o == std::cmp::Ordering::Greater)
}
