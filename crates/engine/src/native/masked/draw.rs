//! Drawing into the masked map: a triangle's exact coverage of each tile it reaches
//! and its plane's range there ([`for_each_tile`]), folded into the tile's two
//! bounds ([`merge`]); occluders drawn nearest first, those the map already hides
//! left out ([`draw_part`]).

use super::{BOUND_ROUNDING, H, MaskedMap, SKIP_TEST_MIN_PIXELS, TILE_H, TILE_W, Tile};
use crate::camera::Camera;
use crate::cull::deb::DEPTH_MARGIN;
use crate::native::map::front_facing;
use crate::native::span::{SpanTriangle, span_triangles};
use crate::scene::Scene;

/// The bits `a..=b` of a tile row (clamped to `0..TILE_W`; none if `a > b`).
#[inline(always)]
pub fn span_mask(a: i32, b: i32) -> u32 {
    let lo = a.clamp(0, TILE_W as i32) as u64;
    let hi = (b + 1).clamp(0, TILE_W as i32) as u64;
    let hi = hi.max(lo);
    (((1u64 << hi) - 1) & !((1u64 << lo) - 1)) as u32
}

/// The lesser of two values by one comparison (`f32::min`/`f64::min` add NaN fix-ups
/// that cost a fifth of a draw): with a NaN it answers `b`, which every caller makes
/// a bound that holds (a vertex's `1/w`) or drops.
#[inline(always)]
pub(super) fn lesser<T: PartialOrd>(a: T, b: T) -> T {
    if a < b { a } else { b }
}

/// The greater of two values by one comparison (see [`lesser`]).
#[inline(always)]
pub(super) fn greater<T: PartialOrd>(a: T, b: T) -> T {
    if a > b { a } else { b }
}

/// Folds a triangle's coverage `cov` of one tile row, whose fragments there all lie at
/// `1/w ≥ z`, into the row's mask and bounds, keeping its two statements true
/// (module docs); `outside` are the row's pixels past the viewport.
#[inline(always)]
pub fn merge_row(mask: &mut u32, base: &mut f32, layer: &mut f32, cov: u32, z: f32, outside: u32) {
    if z <= *base || cov == 0 {
        return; // says nothing the base does not
    }
    if cov | outside == !0 {
        // The whole row (the common case): a new base, above which the layer may stay.
        *base = z;
        if *layer <= z {
            (*mask, *layer) = (0, 0.0);
        }
        return;
    }
    let merged = *mask | cov;
    if *layer == 0.0 {
        (*mask, *layer) = (cov, z);
    } else if merged | outside == !0 {
        // The two together cover the row: the farther bound is the new base, and the
        // nearer one stays the layer over its own pixels.
        let nearer = if *layer >= z {
            (*mask, *layer)
        } else {
            (cov, z)
        };
        *base = lesser(*layer, z);
        (*mask, *layer) = nearer;
    } else if z >= *layer {
        *mask = merged; // the layer's bound holds for the triangle's pixels too
    } else {
        // Farther than the layer: lowering the layer to z over both, or keeping it as
        // it is, whichever keeps the larger sum of bounds over the row's pixels.
        let keep = (*layer - *base) * mask.count_ones() as f32;
        let lower = (z - *base) * merged.count_ones() as f32;
        if lower > keep {
            (*mask, *layer) = (merged, z);
        }
    }
    if *mask | outside == !0 {
        (*base, *mask, *layer) = (*layer, 0, 0.0);
    }
    if *layer <= *base || *mask == 0 {
        (*mask, *layer) = (0, 0.0);
    }
}

/// [`merge_row`] for each row of a tile: `z[r]` bounds the triangle's fragments in row
/// `r`.
#[inline(always)]
pub fn merge(tile: &mut Tile, cov: &[u32; H], z: &[f32; H], outside: &[u32; H]) {
    for r in 0..H {
        merge_row(
            &mut tile.mask[r],
            &mut tile.base[r],
            &mut tile.layer[r],
            cov[r],
            z[r],
            outside[r],
        );
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

/// One tile's share of a triangle ([`for_each_tile`]): per row, its covered pixels
/// (exactly its spans') and the least and greatest `1/w` of its plane over them (at
/// the row's first and last covered pixel, within the vertices' range); rows it does
/// not cover have no pixels and bounds of 0.
pub(super) struct TileShare {
    pub cov: [u32; H],
    pub least: [f64; H],
    pub greatest: [f64; H],
}

/// Calls `f(i, tx, ty, share)` for each tile `(tx, ty)` (index `i`) whose pixels `t`
/// covers. Stops, answering false, when `f` does.
#[inline(always)]
pub(super) fn for_each_tile(
    t: &SpanTriangle,
    tiles_x: u32,
    mut f: impl FnMut(usize, u32, u32, &TileShare) -> bool,
) -> bool {
    let (sx, _) = t.inv_w_slopes();
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
        // The plane at each row's first pixel, and its step along the row.
        let mut at_first = [0.0; H];
        for (r, v) in at_first.iter_mut().enumerate() {
            let py = (ty * TILE_H + r as u32) as f64 + 0.5;
            *v = t.inv_w_at(first[r] as f64 + 0.5, py);
        }
        for tx in xa as u32 / TILE_W..=xb as u32 / TILE_W {
            let x0 = (tx * TILE_W) as i32;
            let mut share = TileShare {
                cov: [0; H],
                least: [0.0; H],
                greatest: [0.0; H],
            };
            let mut any = 0;
            for r in 0..H {
                // An empty row's ends may hold anything: b is kept at a - 1 or above,
                // so that no difference below overflows.
                let a = first[r].max(x0);
                let b = last[r].min(x0 + TILE_W as i32 - 1).max(a - 1);
                share.cov[r] = span_mask(a - x0, b - x0);
                any |= share.cov[r];
                let va = at_first[r] + sx * (a - first[r]) as f64;
                let vb = at_first[r] + sx * (b - first[r]) as f64;
                let covered = a <= b;
                share.least[r] = if covered {
                    greater(lesser(va, vb), farthest)
                } else {
                    0.0
                };
                share.greatest[r] = if covered {
                    lesser(greater(va, vb), nearest)
                } else {
                    0.0
                };
            }
            if any == 0 {
                continue; // the rows' spans pass by this tile
            }
            if !f((ty * tiles_x + tx) as usize, tx, ty, &share) {
                return false;
            }
        }
    }
    true
}

/// Draws one screen triangle into the tiles it covers.
#[inline(always)]
pub(super) fn raster(map: &mut MaskedMap, t: &SpanTriangle) {
    let index = map.tris.len() as u32;
    for_each_tile(t, map.tiles_x, |i, _, _, share| {
        // The upper bound and the coverage first: they hold wherever it is drawn.
        let greatest = share.greatest.iter().fold(0.0f64, |a, &b| greater(a, b));
        let up = (greatest * (1.0 + BOUND_ROUNDING)) as f32;
        map.upper[i] = map.upper[i].max(if up < f32::INFINITY { up } else { f32::MAX });
        for (c, &m) in map.covered[i].iter_mut().zip(&share.cov) {
            *c |= m;
        }
        map.exact.hit(i as u32, index);
        let z = share.least.map(|least| {
            let v = (least * (1.0 - BOUND_ROUNDING)) as f32;
            // (Else no bound worth keeping, or not a number: the row is left alone.)
            if v > 0.0 && v < f32::INFINITY { v } else { 0.0 }
        });
        merge(&mut map.tiles[i], &share.cov, &z, &map.outside[i]);
        true
    });
}
