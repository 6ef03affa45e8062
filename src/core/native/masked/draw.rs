//! Drawing into the masked map: a triangle's exact coverage of each tile it reaches
//! and its plane's range there ([`for_each_tile`]), folded into the tile's two
//! bounds ([`merge`]); occluders drawn nearest first, those the map already hides
//! left out ([`draw_part`]).

use super::{BOUND_ROUNDING, H, MaskedMap, SKIP_TEST_MIN_PIXELS, TILE_H, TILE_W, Tile};
use crate::core::camera::Camera;
use crate::core::cull::deb::DEPTH_MARGIN;
use crate::core::native::map::front_facing;
use crate::core::native::span::{SpanTriangle, span_triangles};
use crate::core::scene::Scene;

/// The bits `a..=b` of a tile row (clamped to `0..TILE_W`; none if `a > b`).
#[inline(always)]
pub fn span_mask(a: i32, b: i32) -> u32 {
    let lo = a.clamp(0, TILE_W as i32) as u64;
    let hi = (b + 1).clamp(0, TILE_W as i32) as u64;
    let hi = hi.max(lo);
    (((1u64 << hi) - 1) & !((1u64 << lo) - 1)) as u32
}

/// Whether `mask` (with the tile's outside bits) covers the whole tile.
#[inline(always)]
fn full(mask: &[u32; H], outside: &[u32; H]) -> bool {
    let mut all = !0u32;
    for r in 0..H {
        all &= mask[r] | outside[r];
    }
    all == !0
}

#[inline(always)]
fn count(mask: &[u32; H]) -> u32 {
    mask.iter().map(|m| m.count_ones()).sum()
}

/// Folds a triangle's coverage `cov` of a tile, whose fragments there all lie at
/// `1/w ≥ z`, into the tile, keeping its two statements true (module docs).
#[inline(always)]
pub fn merge(tile: &mut Tile, cov: &[u32; H], z: f32, outside: &[u32; H]) {
    if z <= tile.base {
        return; // says nothing the base does not
    }
    let mut merged = [0u32; H];
    for r in 0..H {
        merged[r] = tile.mask[r] | cov[r];
    }
    if tile.layer == 0.0 {
        (tile.mask, tile.layer) = (*cov, z);
    } else if full(&merged, outside) {
        // The two together cover the tile: the farther bound is the new base, and the
        // nearer one stays the layer over its own pixels.
        let nearer = if tile.layer >= z {
            (tile.mask, tile.layer)
        } else {
            (*cov, z)
        };
        tile.base = tile.layer.min(z);
        (tile.mask, tile.layer) = nearer;
    } else if z >= tile.layer {
        tile.mask = merged; // the layer's bound holds for the triangle's pixels too
    } else {
        // Farther than the layer: lowering the layer to z over both, or keeping it as
        // it is, whichever keeps the larger sum of bounds over the tile's pixels.
        let keep = (tile.layer - tile.base) as f64 * count(&tile.mask) as f64;
        let lower = (z - tile.base) as f64 * count(&merged) as f64;
        if lower > keep {
            (tile.mask, tile.layer) = (merged, z);
        }
    }
    if full(&tile.mask, outside) {
        (tile.base, tile.mask, tile.layer) = (tile.layer, [0; H], 0.0);
    }
    if tile.layer <= tile.base || tile.mask == [0; H] {
        (tile.mask, tile.layer) = ([0; H], 0.0);
    }
}

/// Draws occluders `ids` into `map`; with `skip_hidden`, leaves out those (and the
/// triangles) the map already hides ([`MaskedMap::draw_occluders`]).
#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
pub(super) fn draw_part(
    map: &mut MaskedMap,
    scene: &Scene,
    cam: &Camera,
    ids: &[u32],
    skip_hidden: bool,
) -> usize {
    let eye = cam.position;
    let p = &scene.positions;
    let mut skipped = 0;
    for &id in ids {
        let o = &scene.objects[id as usize];
        if skip_hidden
            && cam
                .project_box(&o.aabb)
                .is_none_or(|r| map.rect_hidden(&r, (1.0 + DEPTH_MARGIN) / r.near))
        {
            skipped += 1;
            continue;
        }
        for t in scene.triangles_of(o).chunks_exact(3) {
            let tri = [p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]];
            if !front_facing(eye, &tri) {
                continue;
            }
            span_triangles(cam, tri, |t| {
                let hidden = t.box_pixels() >= SKIP_TEST_MIN_PIXELS && map.triangle_hidden(t, 0.0);
                if !hidden {
                    raster(map, t);
                    map.tris.push(*t);
                }
                true
            });
        }
    }
    skipped
}

/// The covered pixels of the tile rows of `t`: for the [`TILE_H`] rows from `y`, the
/// first and last covered pixel (first > last: none), exactly as its spans.
#[inline(always)]
pub fn tile_rows(t: &SpanTriangle, y: u32) -> ([i32; H], [i32; H]) {
    let within = (t.tri.y0.max(y), t.tri.y1.min(y + TILE_H - 1));
    let (f0, l0) = t.row_block(y, within);
    let (f1, l1) = t.row_block(y + 4, within);
    let mut first = [0; H];
    let mut last = [0; H];
    first[..4].copy_from_slice(&f0);
    first[4..].copy_from_slice(&f1);
    last[..4].copy_from_slice(&l0);
    last[4..].copy_from_slice(&l1);
    (first, last)
}

/// Calls `f(i, tx, ty, cov, least, greatest)` for each tile `(tx, ty)` (index `i`)
/// whose pixels `t` covers: `cov` its covered pixels there (exactly its spans'),
/// `least` and `greatest` the least and greatest `1/w` of its plane over the rows and
/// columns of `cov` (at corners of that rectangle), within its vertices' range. Stops,
/// answering false, when `f` does.
#[inline(always)]
pub(super) fn for_each_tile(
    t: &SpanTriangle,
    tiles_x: u32,
    mut f: impl FnMut(usize, u32, u32, &[u32; H], f64, f64) -> bool,
) -> bool {
    let (sx, sy) = t.inv_w_slopes();
    let farthest = t.farthest_inv_w();
    let nearest = t.bounds().1;
    for ty in t.tri.y0 / TILE_H..=t.tri.y1 / TILE_H {
        let (first, last) = tile_rows(t, ty * TILE_H);
        let (mut xa, mut xb) = (i32::MAX, -1);
        for r in 0..H {
            if first[r] <= last[r] {
                xa = xa.min(first[r]);
                xb = xb.max(last[r]);
            }
        }
        if xb < 0 {
            continue;
        }
        let py = (ty * TILE_H) as f64 + 0.5;
        for tx in xa as u32 / TILE_W..=xb as u32 / TILE_W {
            let base = (tx * TILE_W) as i32;
            let mut cov = [0u32; H];
            let mut any = 0;
            for r in 0..H {
                cov[r] = span_mask(first[r] - base, last[r] - base);
                any |= cov[r];
            }
            if any == 0 {
                continue; // the rows' spans pass by this tile
            }
            let ra = cov.iter().position(|&m| m != 0).unwrap_or(0);
            let rb = H - 1 - cov.iter().rev().position(|&m| m != 0).unwrap_or(0);
            let a = base + any.trailing_zeros() as i32;
            let b = base + (TILE_W - 1 - any.leading_zeros()) as i32;
            let corner = t.inv_w_at(a as f64 + 0.5, py + ra as f64);
            let (dx, dy) = (sx * (b - a) as f64, sy * (rb - ra) as f64);
            let least = (corner + dx.min(0.0) + dy.min(0.0)).max(farthest);
            let greatest = (corner + dx.max(0.0) + dy.max(0.0)).min(nearest);
            if !f((ty * tiles_x + tx) as usize, tx, ty, &cov, least, greatest) {
                return false;
            }
        }
    }
    true
}

/// Whether every bit of `part` is in `whole`.
#[inline(always)]
pub(super) fn within(part: &[u32; H], whole: &[u32; H]) -> bool {
    let mut missing = 0;
    for r in 0..H {
        missing |= part[r] & !whole[r];
    }
    missing == 0
}

/// Draws one screen triangle into the tiles it covers.
#[inline(always)]
pub(super) fn raster(map: &mut MaskedMap, t: &SpanTriangle) {
    let index = map.tris.len() as u32;
    for_each_tile(t, map.tiles_x, |i, _, _, cov, least, greatest| {
        // The upper bound and the coverage first: they hold wherever it is drawn.
        let up = (greatest * (1.0 + BOUND_ROUNDING)) as f32;
        map.upper[i] = map.upper[i].max(if up < f32::INFINITY { up } else { f32::MAX });
        for (c, &m) in map.covered[i].iter_mut().zip(cov) {
            *c |= m;
        }
        map.exact.hit(i as u32, index);
        let z = (least * (1.0 - BOUND_ROUNDING)) as f32;
        // (Else no bound worth keeping, or not a number.)
        if z > 0.0 && z < f32::INFINITY {
            merge(&mut map.tiles[i], cov, z, &map.outside[i]);
        }
        true
    });
}
