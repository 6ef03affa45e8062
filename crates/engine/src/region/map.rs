//! The map a region is culled against: the occluders drawn from the region's centre,
//! with bounds that hold over each whole pixel cell and a mask of the cells where the
//! first drawn surface may end (see the module above for why these suffice).
//!
//! Per cell: `lo`, the least view depth any occluder triangle touching the cell has
//! inside it; `hi`, a bound on the first drawn surface anywhere in the cell (the
//! farthest depth of a triangle, or convex pair of them across a shared edge, that
//! covers the cell whole, or the centre's first depth plus the depth ranges of the
//! triangles touching the cell, whichever is less); whether any triangle touches it;
//! and whether a
//! *leak edge* may show in it: an edge of a drawn triangle that no drawn triangle
//! facing the same way shares, drawn wherever its depth is not behind `hi`. A box is
//! hidden when its image's cells lie behind `hi`, and its image dilated by the
//! region's parallax holds no leak, no untouched cell and nothing nearer than the
//! depth the dilation was computed for. Counts come from summed-area tables (exact),
//! depth bounds from min/max pyramids (blocks covering the rect: conservative).

use glam::{Vec3, Vec4Swizzles};

use crate::camera::{Camera, Region};
use crate::cull::PreparedScene;
use crate::geom::Aabb;
use crate::scene::edges::{Hold, held};

use super::clip::{Piece, Source, pieces};
use super::raster::{
    Cells, DEPTH_SLACK_ABS, DEPTH_SLACK_REL, LeakMask, ScreenTriangle, cover_pair, cover_triangle,
    floor, project, rasterize,
};

/// No piece: a triangle not drawn.
const NONE: u32 = u32::MAX;

/// A drawn map, ready to test boxes.
pub struct RegionMap {
    cam: Camera,
    radius: f32,
    /// Bounds on an eye's offset from the centre along the map's x, y and view axes
    /// (a box region's extents turned into the map's frame; a ball's radius).
    reach: Vec3,
    /// The nearest view depth a blocking point may have (see [`RegionMap::hides`]).
    min_depth: f32,
    w: usize,
    h: usize,
    /// `lo` and `hi` pyramids, level 0 first (each level half the one before).
    lo: Vec<Level>,
    hi: Vec<Level>,
    /// Summed-area tables of untouched and of leaking cells, `(w + 1) × (h + 1)`.
    untouched: Vec<u32>,
    leaks: Vec<u32>,
    /// Occluder objects and triangles drawn.
    pub occluders: u32,
    pub triangles: u32,
}

/// `a > b`, false where either is not a number.
fn beyond(a: f32, b: f32) -> bool {
    a.partial_cmp(&b) == Some(std::cmp::Ordering::Greater)
}

/// What the box test of [`RegionMap::judge`] found, in the order it looks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Verdict {
    /// No eye of the ball sees the box.
    Hidden,
    /// A corner of the box is not beyond the depth a blocking point needs.
    Near,
    /// The box's image, or that image dilated, leaves the map.
    OffMap,
    /// The box is not behind the first drawn surface over its image.
    NotBehind,
    /// An occluder in the dilated image is too near the ball.
    NearOccluder,
    /// A cell of the dilated image holds no occluder.
    Uncovered,
    /// A leak edge shows in the dilated image.
    Leak,
}

struct Level {
    w: usize,
    h: usize,
    v: Vec<f32>,
}

impl RegionMap {
    /// Draws the occluder objects `ids` from `cam` (at the region's centre) for the
    /// eyes of `region` whose views see rays up to `off_axis` radians from their
    /// axes.
    pub fn draw(
        prep: &PreparedScene,
        cam: &Camera,
        region: &Region,
        off_axis: f32,
        ids: &[u32],
    ) -> Self {
        let scene = &prep.scene;
        let (w, h) = (cam.width as usize, cam.height as usize);
        let radius = region.radius;
        // The box's half extents on the map's axes: each view axis's reach over the
        // box's corners (the rotation's absolute rows), never more than the ball.
        let e = region.half_extent;
        let axis = |k: usize| cam.view.row(k).truncate().abs().dot(e);
        let reach = Vec3::new(axis(0), axis(1), axis(2)).min(Vec3::splat(radius));
        // z_lo lies beyond every eye, and far enough beyond it that the blocking
        // point is beyond the near plane of every eye that looks at the box.
        let min_depth = reach.z + cam.near / off_axis.min(85f32.to_radians()).cos() + 1e-3;
        let neighbours = prep.edge_neighbours();
        // The drawn pieces, and for each drawn triangle (global index) its first
        // piece (`NONE`: not drawn).
        let mut drawn = vec![NONE; scene.indices.len() / 3];
        let mut screen: Vec<Piece> = Vec::new();
        let mut triangles = 0u32;
        let clip = 0.5 * (cam.near + min_depth);
        for &id in ids {
            let o = &scene.objects[id as usize];
            let first = o.first_index / 3;
            for (k, corners) in scene.corners_of(o).enumerate() {
                let tri = first + k as u32;
                let parts = pieces(cam, tri, corners, clip);
                if parts.is_empty() {
                    continue;
                }
                triangles += 1;
                drawn[tri as usize] = screen.len() as u32;
                screen.extend(parts);
            }
        }
        let piece = |tri: u32| -> Option<&Piece> {
            let &i = drawn.get(tri as usize)?;
            (i != NONE).then(|| &screen[i as usize])
        };
        // Covers first, nearest pieces first, so that what they hide is skipped in
        // both passes. Pairs across a shared edge that form a convex quad cover cells
        // whole that neither triangle covers alone (the diagonal of every quad
        // face); likewise the two halves of a clipped quad. A pair is folded in when
        // its farther piece is.
        let mut order: Vec<u32> = (0..screen.len() as u32).collect();
        order.sort_by(|&a, &b| {
            let d = |i: u32| {
                screen[i as usize]
                    .t
                    .depth
                    .into_iter()
                    .fold(f32::MAX, f32::min)
            };
            d(a).total_cmp(&d(b))
        });
        let mut cells = Cells::new(w, h);
        let mut folded = vec![false; screen.len()];
        for &at in &order {
            let at = at as usize;
            let p = &screen[at];
            cover_triangle(&p.t, &mut cells);
            folded[at] = true;
            if p.whole {
                for e in 0..3 {
                    let Some(&n) = neighbours.of(p.tri, e).and_then(|s| drawn.get(s as usize))
                    else {
                        continue;
                    };
                    if n == NONE || !folded[n as usize] {
                        continue;
                    }
                    let n = &screen[n as usize];
                    if n.whole && n.t.facing == p.t.facing {
                        cover_pair(&p.t, e, &n.t, &mut cells);
                    }
                }
            } else {
                let first = drawn[p.tri as usize] as usize;
                let other = if at == first { at + 1 } else { first };
                let halves = screen.get(other).is_some_and(|n| n.tri == p.tri);
                if halves && folded[other] {
                    let (one, two) = (&screen[first], &screen[first + 1]);
                    cover_pair(&one.t, 2, &two.t, &mut cells);
                }
            }
        }
        for p in &screen {
            rasterize(&p.t, &mut cells);
        }
        let (lo, hi, touched) = cells.bounds();
        // Leak edges: the parts of edges where the first drawn surface may end (no
        // neighbour, no drawn triangle holding them), drawn where they are not behind
        // the surface. Cuts need none (see `clip`).
        let mut mask = LeakMask::new(w, h, &hi);
        for p in &screen {
            let corners = scene.triangle(p.tri);
            for (k, source) in p.edges.iter().enumerate() {
                let Source::Edge { e, t0, t1 } = *source else {
                    continue;
                };
                let shared = neighbours
                    .of(p.tri, e)
                    .and_then(piece)
                    .is_some_and(|n| n.t.facing == p.t.facing);
                let ends = (
                    (p.t.p[k], p.t.depth[k]),
                    (p.t.p[(k + 1) % 3], p.t.depth[(k + 1) % 3]),
                );
                if shared || mask.hidden(ends.0, ends.1) {
                    continue;
                }
                let (a, b) = (corners[e], corners[(e + 1) % 3]);
                let held_parts: Vec<(f32, f32)> = neighbours
                    .holders(p.tri, e)
                    .iter()
                    .filter_map(|&s| {
                        let other = piece(s)?;
                        let (h0, h1, how) = held(a, b, scene.triangle(s))?;
                        let holds = match how {
                            Hold::Inside => true,
                            Hold::Along(_) => opposite_sides(&p.t, k, &other.t),
                        };
                        holds.then_some((h0, h1))
                    })
                    .collect();
                for (s0, s1) in open_parts(t0, t1, held_parts) {
                    let part = match (project(cam, a.lerp(b, s0)), project(cam, a.lerp(b, s1))) {
                        (Some(pa), Some(pb)) => (pa, pb),
                        // Not expected on a drawn piece's edge: then all of that.
                        _ => ends,
                    };
                    mask.draw(part.0, part.1);
                }
            }
        }
        let leaks = summed(w, h, mask.leak.into_iter());
        RegionMap {
            min_depth,
            radius,
            reach,
            w,
            h,
            lo: pyramid(w, h, lo, f32::min),
            hi: pyramid(w, h, hi, f32::max),
            untouched: summed(w, h, touched.iter().map(|&t| !t)),
            leaks,
            occluders: ids.len() as u32,
            triangles,
            cam: cam.clone(),
        }
    }

    /// The map as an RGB image (`w`, `h`, pixels), for diagnostics: leak cells red,
    /// untouched dark blue, cells without a bound on the surface yellow, the rest
    /// grey by `hi` (white near, black at 200 m and beyond); the images of `boxes`
    /// outlined in green.
    pub fn debug_rgb(&self, boxes: &[Aabb]) -> (usize, usize, Vec<u8>) {
        let (w, h) = (self.w, self.h);
        let mut rgb = vec![0u8; w * h * 3];
        for y in 0..h {
            for x in 0..w {
                let hi = self.hi[0].v[y * w + x];
                let g = (255.0 * (1.0 - (hi / 200.0).min(1.0))) as u8;
                let px = if self.count(&self.leaks, [x, x, y, y]) != 0 {
                    [255, 0, 0]
                } else if self.count(&self.untouched, [x, x, y, y]) != 0 {
                    [0, 0, 80]
                } else if !hi.is_finite() {
                    [255, 255, 0]
                } else {
                    [g, g, g]
                };
                rgb[(y * w + x) * 3..][..3].copy_from_slice(&px);
            }
        }
        for b in boxes {
            let m = &self.cam.view;
            let (mut x0, mut x1, mut y0, mut y1) = (f32::MAX, f32::MIN, f32::MAX, f32::MIN);
            for c in b.corners() {
                let v = (*m * c.extend(1.0)).xyz();
                let (sx, sy) = self.to_pixels(v.x / -v.z, v.y / -v.z);
                (x0, x1, y0, y1) = (x0.min(sx), x1.max(sx), y0.min(sy), y1.max(sy));
            }
            let clamp = |v: f32, n: usize| (v.max(0.0) as usize).min(n - 1);
            let (x0, x1, y0, y1) = (clamp(x0, w), clamp(x1, w), clamp(y0, h), clamp(y1, h));
            for x in x0..=x1 {
                for y in [y0, y1] {
                    rgb[(y * w + x) * 3..][..3].copy_from_slice(&[0, 200, 0]);
                }
            }
            for y in y0..=y1 {
                for x in [x0, x1] {
                    rgb[(y * w + x) * 3..][..3].copy_from_slice(&[0, 200, 0]);
                }
            }
        }
        (w, h, rgb)
    }

    /// Why `b` is hidden or not ([`Verdict`]).
    pub fn judge(&self, b: &Aabb) -> Verdict {
        if b.is_empty() {
            return Verdict::Hidden;
        }
        let m = &self.cam.view;
        let (mut x0, mut x1, mut y0, mut y1) = (f32::MAX, f32::MIN, f32::MAX, f32::MIN);
        let mut nearest = f32::INFINITY;
        for c in b.corners() {
            let v = (*m * c.extend(1.0)).xyz();
            let d = -v.z;
            if !beyond(d, self.min_depth) {
                return Verdict::Near; // too near the ball, behind it or not a number
            }
            let (sx, sy) = self.to_pixels(v.x / d, v.y / d);
            (x0, x1, y0, y1) = (x0.min(sx), x1.max(sx), y0.min(sy), y1.max(sy));
            nearest = nearest.min(d);
        }
        // The box's own image: every cell it touches, behind the surface.
        let Some(own) = self.cells(x0, x1, y0, y1, 0.0, 0.0) else {
            return Verdict::OffMap;
        };
        let far = self.query(&self.hi, own, f32::NEG_INFINITY, f32::max);
        if !beyond(nearest, far * (1.0 + DEPTH_SLACK_REL) + DEPTH_SLACK_ABS) {
            return Verdict::NotBehind;
        }
        // z_lo: a depth that the whole dilated image lies beyond.
        let mut z_lo = self.query(&self.lo, own, f32::INFINITY, f32::min);
        for _ in 0..6 {
            if !beyond(z_lo, self.min_depth) {
                return Verdict::NearOccluder;
            }
            let (kx, ky) = self.dilation(z_lo, [x0, x1, y0, y1]);
            let Some(n) = self.cells(x0, x1, y0, y1, kx, ky) else {
                return Verdict::OffMap; // the dilated image leaves the map
            };
            let least = self.query(&self.lo, n, f32::INFINITY, f32::min);
            if least >= z_lo {
                return if self.count(&self.untouched, n) != 0 {
                    Verdict::Uncovered
                } else if self.count(&self.leaks, n) != 0 {
                    Verdict::Leak
                } else {
                    Verdict::Hidden
                };
            }
            z_lo = least * (1.0 - DEPTH_SLACK_REL) - DEPTH_SLACK_ABS;
        }
        Verdict::NearOccluder
    }

    /// Pixel coordinates of view tangents `(x/d, y/d)`.
    fn to_pixels(&self, tx: f32, ty: f32) -> (f32, f32) {
        let (w, h) = (self.w as f32, self.h as f32);
        (
            (tx * self.cam.scale[0] * 0.5 + 0.5) * w,
            (0.5 - ty * self.cam.scale[1] * 0.5) * h,
        )
    }

    /// The dilation in pixels `(x, y)` of a box's image `[x0, x1] × [y0, y1]` (pixels)
    /// that holds every direction of a segment from an eye of the ball to the box, past
    /// view depth `z_lo`: `r·√(1 + t²)/z_lo` in tangent units on each axis, `t` the
    /// largest tangent of the box's image on it. (A point within `r` of a ray point at
    /// tangent `t`, beyond `z_lo`, has a tangent within that of `t`: `(ΔX − t·ΔZ)/Z'`
    /// with `|(ΔX, ΔZ)| ≤ r` and `Z' ≥ z_lo`; the rays to the box have the tangents
    /// of its image.)
    fn dilation(&self, z_lo: f32, [x0, x1, y0, y1]: [f32; 4]) -> (f32, f32) {
        let per_x = self.cam.scale[0] * 0.5 * self.w as f32;
        let per_y = self.cam.scale[1] * 0.5 * self.h as f32;
        // Pixels back to tangents (`to_pixels` inverted), the larger magnitude.
        let tx = ((x0 / self.w as f32 - 0.5).abs()).max((x1 / self.w as f32 - 0.5).abs()) * 2.0
            / self.cam.scale[0];
        let ty = ((0.5 - y0 / self.h as f32).abs()).max((0.5 - y1 / self.h as f32).abs()) * 2.0
            / self.cam.scale[1];
        // The ball's bound, or the box's: `(|ΔX| + t·|ΔZ|)/Z'` with each offset
        // within the box's reach on that axis, whichever is less.
        let r = self.radius;
        let (e, ez) = (self.reach, self.reach.z);
        let bx = (r * (1.0 + tx * tx).sqrt()).min(e.x + tx * ez);
        let by = (r * (1.0 + ty * ty).sqrt()).min(e.y + ty * ez);
        // A little more for the f32 round trip through pixels.
        let slack = 1.0 + 1e-4;
        (bx / z_lo * per_x * slack, by / z_lo * per_y * slack)
    }

    /// The cells `[x0, x1] × [y0, y1]` (inclusive) that the closed pixel rect touches,
    /// dilated by `(kx, ky)` and one cell more; `None` if that leaves the map.
    fn cells(&self, x0: f32, x1: f32, y0: f32, y1: f32, kx: f32, ky: f32) -> Option<[usize; 4]> {
        let lo_x = floor(x0 - kx) - 1.0;
        let hi_x = floor(x1 + kx) + 1.0;
        let lo_y = floor(y0 - ky) - 1.0;
        let hi_y = floor(y1 + ky) + 1.0;
        let inside = lo_x >= 0.0
            && lo_y >= 0.0
            && hi_x < self.w as f32
            && hi_y < self.h as f32
            && (lo_x <= hi_x && lo_y <= hi_y);
        inside.then_some([lo_x as usize, hi_x as usize, lo_y as usize, hi_y as usize])
    }

    /// Cells flagged in a summed-area table within `[x0, x1] × [y0, y1]`.
    fn count(&self, sat: &[u32], [x0, x1, y0, y1]: [usize; 4]) -> u32 {
        let row = self.w + 1;
        let at = |x: usize, y: usize| sat[y * row + x];
        at(x1 + 1, y1 + 1) + at(x0, y0) - at(x0, y1 + 1) - at(x1 + 1, y0)
    }

    /// The min (or max) of a pyramid over blocks that cover `[x0, x1] × [y0, y1]`: at
    /// the level where the rect spans at most two blocks a side.
    fn query(
        &self,
        levels: &[Level],
        [x0, x1, y0, y1]: [usize; 4],
        init: f32,
        f: fn(f32, f32) -> f32,
    ) -> f32 {
        let span = (x1 - x0 + 1).max(y1 - y0 + 1);
        let mut k = 0;
        while k + 1 < levels.len() && (span >> (k + 1)) >= 2 {
            k += 1;
        }
        let l = &levels[k];
        let mut v = init;
        for y in (y0 >> k)..=((y1 >> k).min(l.h - 1)) {
            for x in (x0 >> k)..=((x1 >> k).min(l.w - 1)) {
                v = f(v, l.v[y * l.w + x]);
            }
        }
        v
    }
}

/// Whether piece `n`, which has an edge along edge `k` of piece `t`, lies on the other
/// side of that edge from `t` on the map: then the two meet there like the halves of
/// one surface. Each side is told by the corner farthest from the edge's line; false
/// where either is too thin to tell.
fn opposite_sides(t: &ScreenTriangle, k: usize, n: &ScreenTriangle) -> bool {
    let (a, b) = (t.p[k], t.p[(k + 1) % 3]);
    let side = |q: [f32; 2]| (b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0]);
    let farthest = |s: &ScreenTriangle| {
        s.p.iter()
            .map(|&q| side(q))
            .max_by(|x, y| x.abs().total_cmp(&y.abs()))
            .unwrap_or(0.0)
    };
    let length2 = (b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2);
    let (st, sn) = (farthest(t), farthest(n));
    let thin = 1e-6 * length2;
    (st > thin && sn < -thin) || (st < -thin && sn > thin)
}

/// The parts of `[t0, t1]` outside every interval of `held`, in order.
fn open_parts(t0: f32, t1: f32, mut held: Vec<(f32, f32)>) -> Vec<(f32, f32)> {
    held.sort_unstable_by(|x, y| x.0.total_cmp(&y.0));
    let mut open = Vec::new();
    let mut at = t0;
    for (h0, h1) in held {
        if h0 > at {
            open.push((at, h0.min(t1)));
        }
        at = at.max(h1);
        if at >= t1 {
            break;
        }
    }
    if at < t1 {
        open.push((at, t1));
    }
    open.retain(|(a, b)| b > a);
    open
}

/// Min or max pyramid of a `w × h` grid, level 0 the grid itself.
fn pyramid(w: usize, h: usize, v: Vec<f32>, f: fn(f32, f32) -> f32) -> Vec<Level> {
    let mut levels = vec![Level { w, h, v }];
    while levels.last().is_some_and(|l| l.w > 1 || l.h > 1) {
        let l = levels.last().unwrap();
        let (nw, nh) = (l.w.div_ceil(2), l.h.div_ceil(2));
        let mut next = Vec::with_capacity(nw * nh);
        for y in 0..nh {
            for x in 0..nw {
                let mut m = l.v[(2 * y) * l.w + 2 * x];
                for (dx, dy) in [(1, 0), (0, 1), (1, 1)] {
                    let (sx, sy) = (2 * x + dx, 2 * y + dy);
                    if sx < l.w && sy < l.h {
                        m = f(m, l.v[sy * l.w + sx]);
                    }
                }
                next.push(m);
            }
        }
        levels.push(Level {
            w: nw,
            h: nh,
            v: next,
        });
    }
    levels
}

/// Summed-area table of flags over a `w × h` grid: entry `(x, y)` counts the flags in
/// `[0, x) × [0, y)`.
fn summed(w: usize, h: usize, flags: impl Iterator<Item = bool>) -> Vec<u32> {
    let row = w + 1;
    let mut sat = vec![0u32; row * (h + 1)];
    let flags: Vec<bool> = flags.collect();
    for y in 0..h {
        let mut run = 0u32;
        for x in 0..w {
            run += flags[y * w + x] as u32;
            sat[(y + 1) * row + x + 1] = sat[y * row + x + 1] + run;
        }
    }
    sat
}
