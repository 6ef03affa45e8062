//! Drawing a region map's occluders: per-cell depth bounds that hold over the whole
//! cell, and the leak edges (see `region::map` for what they are for).

use glam::{Vec3, Vec4Swizzles};

use crate::camera::Camera;

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

/// What the triangles touching each cell say of it while they are drawn.
pub(super) struct Cells {
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
}

impl Cells {
    pub(super) fn new(n: usize) -> Self {
        Cells {
            lo: vec![f32::INFINITY; n],
            anchor: vec![f32::INFINITY; n],
            spread: vec![0.0; n],
            cover: vec![f32::INFINITY; n],
            touched: vec![false; n],
        }
    }

    /// `(lo, hi, touched)` per cell. `hi` bounds the first drawn surface anywhere in
    /// a cell where that surface is continuous: from the anchor's point to any point
    /// of the cell a straight path crosses each triangle once, and each changes the
    /// depth by at most its range in the cell, so the surface stays within the
    /// anchor's depth plus the sum of the ranges. (Where it is not continuous a leak
    /// edge shows in the cell, and the box test refuses such cells anyway.)
    /// A surface that covers the whole cell bounds it too: the least such bound is
    /// taken.
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
}

/// Folds the triangle into the cells it touches (exact separating-axis test of the
/// triangle against each cell's closed square): its least depth and its depth range
/// inside the cell, bounded by its corners' depths and by its plane at the cell's
/// corners, and a bound on the first surface somewhere in the cell where it
/// covers the cell's centre or surely meets the cell.
pub(super) fn rasterize(t: &ScreenTriangle, w: usize, h: usize, cells: &mut Cells) {
    let xs = t.p.map(|q| q[0]);
    let ys = t.p.map(|q| q[1]);
    let min = |v: [f32; 3]| v[0].min(v[1]).min(v[2]);
    let max = |v: [f32; 3]| v[0].max(v[1]).max(v[2]);
    let cx0 = min(xs).floor().max(0.0) as usize;
    let cy0 = min(ys).floor().max(0.0) as usize;
    let cx1 = (max(xs).floor() as i64).min(w as i64 - 1);
    let cy1 = (max(ys).floor() as i64).min(h as i64 - 1);
    if cx1 < 0 || cy1 < 0 || cx0 >= w || cy0 >= h {
        return;
    }
    let (cx1, cy1) = (cx1 as usize, cy1 as usize);
    let (dmin, dmax) = (min(t.depth), max(t.depth));
    // Edge functions, positive inside: n·(q − a) with n turned towards the third corner.
    let edges: [[f32; 3]; 3] = std::array::from_fn(|e| {
        let (a, b, c) = (t.p[e], t.p[(e + 1) % 3], t.p[(e + 2) % 3]);
        let (nx, ny) = (a[1] - b[1], b[0] - a[0]);
        let k = -(nx * a[0] + ny * a[1]);
        let s = if nx * c[0] + ny * c[1] + k >= 0.0 {
            1.0
        } else {
            -1.0
        };
        [nx * s, ny * s, k * s]
    });
    let [pa, pb, pc] = t.plane;
    for cy in cy0..=cy1 {
        let (y0, y1) = (cy as f32, cy as f32 + 1.0);
        let (fy0, fy1) = (f64::from(y0), f64::from(y1));
        for cx in cx0..=cx1 {
            let (x0, x1) = (cx as f32, cx as f32 + 1.0);
            let (fx0, fx1) = (f64::from(x0), f64::from(x1));
            // Separated if some edge is negative at the cell corner it favours most
            // (with a little slack: touching more cells is conservative).
            let apart = edges.iter().any(|&[nx, ny, k]| {
                let x = if nx >= 0.0 { x1 } else { x0 };
                let y = if ny >= 0.0 { y1 } else { y0 };
                nx * x + ny * y + k < -1e-3 * (nx.abs() + ny.abs())
            });
            if apart {
                continue;
            }
            let corners = [
                pa * fx0 + pb * fy0 + pc,
                pa * fx1 + pb * fy0 + pc,
                pa * fx0 + pb * fy1 + pc,
                pa * fx1 + pb * fy1 + pc,
            ];
            let (iz_lo, iz_hi) = (
                corners.iter().copied().fold(f64::INFINITY, f64::min),
                corners.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            );
            // Farthest: the plane's least 1/d over the cell, where it stays in front.
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
            let i = cy * w + cx;
            let whole = edges.iter().all(|&[nx, ny, k]| {
                let x = if nx >= 0.0 { x0 } else { x1 };
                let y = if ny >= 0.0 { y0 } else { y1 };
                nx * x + ny * y + k > 1e-3 * (nx.abs() + ny.abs())
            });
            if whole {
                cells.cover[i] = cells.cover[i].min(far);
            }
            cells.lo[i] = cells.lo[i].min(near * (1.0 - DEPTH_SLACK_REL));
            cells.spread[i] += (far - near).max(0.0) * (1.0 + DEPTH_SLACK_REL);
            cells.touched[i] = true;
            // The centre counts as covered only inside every edge by a margin.
            let (mx, my) = (x0 + 0.5, y0 + 0.5);
            let inside = edges
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
            let meets = min(xs) < x1 - m
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
        }
    }
}

/// The greatest depth triangle `t` has in the cell `[x0, x1] × [y0, y1]`: its plane
/// at the cell's corners where it stays in front there, and its farthest corner.
fn far_in(t: &ScreenTriangle, [x0, x1, y0, y1]: [f64; 4]) -> f32 {
    let [a, b, c] = t.plane;
    let iz = [
        a * x0 + b * y0,
        a * x1 + b * y0,
        a * x0 + b * y1,
        a * x1 + b * y1,
    ]
    .map(|v| v + c)
    .into_iter()
    .fold(f64::INFINITY, f64::min);
    let dmax = t.depth[0].max(t.depth[1]).max(t.depth[2]);
    if iz > 0.0 {
        ((1.0 / iz) as f32).min(dmax)
    } else {
        dmax
    }
}

/// Folds the quad of `t` and `n`, which share `t`'s edge `e`, into the cells it
/// covers whole, where it is convex: their `cover` takes the greater of the two
/// triangles' greatest depths in the cell.
pub(super) fn cover_pair(
    t: &ScreenTriangle,
    e: usize,
    n: &ScreenTriangle,
    w: usize,
    h: usize,
    cells: &mut Cells,
) {
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
    // Edge functions, positive inside.
    let edges: [[f32; 3]; 4] = std::array::from_fn(|i| {
        let (p, q) = (quad[i], quad[(i + 1) % 4]);
        let (nx, ny) = ((p[1] - q[1]) * sign, (q[0] - p[0]) * sign);
        [nx, ny, -(nx * p[0] + ny * p[1])]
    });
    let xs = quad.map(|q| q[0]);
    let ys = quad.map(|q| q[1]);
    let lo = |v: [f32; 4]| v.into_iter().fold(f32::INFINITY, f32::min);
    let hi = |v: [f32; 4]| v.into_iter().fold(f32::NEG_INFINITY, f32::max);
    let cx0 = lo(xs).floor().max(0.0) as usize;
    let cy0 = lo(ys).floor().max(0.0) as usize;
    let cx1 = (hi(xs).floor() as i64).min(w as i64 - 1);
    let cy1 = (hi(ys).floor() as i64).min(h as i64 - 1);
    if cx1 < 0 || cy1 < 0 {
        return;
    }
    for cy in cy0..=cy1 as usize {
        let (y0, y1) = (cy as f32, cy as f32 + 1.0);
        for cx in cx0..=cx1 as usize {
            let (x0, x1) = (cx as f32, cx as f32 + 1.0);
            let whole = edges.iter().all(|&[nx, ny, k]| {
                let x = if nx >= 0.0 { x0 } else { x1 };
                let y = if ny >= 0.0 { y0 } else { y1 };
                nx * x + ny * y + k > 1e-3 * (nx.abs() + ny.abs())
            });
            if whole {
                let box4 = [x0, x1, y0, y1].map(f64::from);
                let far = far_in(t, box4).max(far_in(n, box4));
                let i = cy * w + cx;
                cells.cover[i] = cells.cover[i].min(far);
            }
        }
    }
}

/// Marks every cell that the edge from `a` to `b` (pixel position, view depth) passes
/// through where its depth is not behind the cell's `hi`: in steps of at most half a
/// pixel, each step's closed bounding box of cells.
pub(super) fn draw_edge(
    a: ([f32; 2], f32),
    b: ([f32; 2], f32),
    w: usize,
    h: usize,
    hi: &[f32],
    leak: &mut [bool],
) {
    let (pa, pb) = (a.0, b.0);
    let length = (pb[0] - pa[0]).abs().max((pb[1] - pa[1]).abs());
    let steps = ((length / 0.5).ceil() as usize).clamp(1, 1 << 16);
    // 1/depth is affine along the projected edge.
    let (ia, ib) = (1.0 / a.1, 1.0 / b.1);
    let at = |s: f32| {
        (
            [pa[0] + (pb[0] - pa[0]) * s, pa[1] + (pb[1] - pa[1]) * s],
            ia + (ib - ia) * s,
        )
    };
    let mut prev = at(0.0);
    for k in 1..=steps {
        let next = at(k as f32 / steps as f32);
        // Nearest depth on this step: its larger 1/depth.
        let nearest = 1.0 / prev.1.max(next.1);
        let x0 = (prev.0[0].min(next.0[0]) - 1e-3).floor().max(0.0);
        let x1 = (prev.0[0].max(next.0[0]) + 1e-3)
            .floor()
            .min(w as f32 - 1.0);
        let y0 = (prev.0[1].min(next.0[1]) - 1e-3).floor().max(0.0);
        let y1 = (prev.0[1].max(next.0[1]) + 1e-3)
            .floor()
            .min(h as f32 - 1.0);
        if x0 <= x1 && y0 <= y1 {
            for y in y0 as usize..=y1 as usize {
                for x in x0 as usize..=x1 as usize {
                    let i = y * w + x;
                    if nearest <= hi[i] * (1.0 + DEPTH_SLACK_REL) + DEPTH_SLACK_ABS {
                        leak[i] = true;
                    }
                }
            }
        }
        prev = next;
    }
}
