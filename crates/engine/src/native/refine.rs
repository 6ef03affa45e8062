//! Per-pixel work on whole objects: the refinement of the box test's survivors, and
//! the exact ID-buffer cull.
//!
//! The refinement re-rasterizes a surviving object's own triangles with the same
//! spans as the occluders and the oracle (`span.rs`) and compares each fragment with
//! the occlusion map, stopping at the first fragment that is not hidden: a visible
//! object usually costs one span, a hidden one is proven hidden only by all of its
//! fragments, or, a triangle at a time, by the map's tile bounds lying in front of
//! the triangle's nearest vertex by the margin (`1/w` is a plane over the triangle,
//! so no fragment is nearer than its nearest vertex). A fragment is hidden when the
//! map lies in front of it by the depth margin ([`REFINE_MARGIN`], compared as
//! `1/w`): the map and the fragment come
//! from one rasterizer's arithmetic but not from the oracle's, and the margin is what
//! keeps a tie, or a difference in the last bits, from ever culling. A fragment
//! within the margin of the map but not level with it (a near tie: where an object
//! meets a wall just in front of it, the last pixels between it and a cull) is looked
//! at again in f64: the drawn occluder triangles reaching its pixel are asked whether
//! one covers it in front by [`RESOLVE_MARGIN`] ([`OcclusionMap::drawn_nearer`]).
//!
//! The exact ID buffer here evaluates each pixel's `1/w` in f64 and rounds it once to
//! f32, as the CPU oracle twin does with its depth, so that its near ties fall as the
//! twin's do and the refinement's f64 decisions agree with it.

use super::map::OcclusionMap;
use super::span::{LANES, Span, SpanTriangle, padded_len, span_triangles};
use crate::camera::Camera;
use crate::cull::{empty_mask, set_bit};
use crate::scene::Scene;

/// Relative depth margin of the per-pixel comparison: a fragment at `1/w = v` is
/// hidden where the map holds more than `v · (1 + REFINE_MARGIN)`. Map and fragment
/// are both the reference's f64 plane of `1/w`, evaluated in f32 from an f64 base at
/// most 7 pixels away, within ~1e-6 of the reference's depths (tested at 2e-6), so
/// 1e-5 keeps every pixel the oracle gives to an object; the box test's 1e-4
/// (`cull::deb::DEPTH_MARGIN`) also covers box depths computed apart from any
/// raster, which the refinement does not use. What the smaller margin buys is
/// surfaces a hair behind an occluder (flush trims, decals, floors under floors).
pub const REFINE_MARGIN: f32 = 1e-5;

/// Relative margin of the fine decision of a near tie ([`hidden_per_pixel`]): a
/// fragment whose f64 `1/w` is `v` is hidden there when a drawn occluder triangle
/// covers the pixel with an f64 `1/w` above `v · (1 + RESOLVE_MARGIN)`. Every CPU
/// oracle rounds each fragment's depth once to f32 from the same f64 plane (2^-24 of
/// itself, ~6e-8) and keeps the strictly nearer, so a gap of 1e-6 is one no oracle's
/// rounding closes: there the occluder's fragment beats the object's in the oracle too.
pub const RESOLVE_MARGIN: f64 = 1e-6;

/// How far behind the object's fragment the map's f32 value may lie for the pixel to
/// be a near tie worth deciding finely: the map's and the fragment's lanes each stray
/// from their f64 planes by at most `span::LANE_SLACK` (4e-6), so below this no
/// occluder can be nearer by [`RESOLVE_MARGIN`]. (A pixel outside the band is
/// visible; the band only decides which pixels are looked at again.)
const NEAR_TIE_BAND: f32 = 1e-5;

/// A map value this close to the fragment's own lanes is taken for the object's own
/// fragment (an occluder finds itself in the map, through the same lanes up to the
/// last bits): visible, without a fine decision, which would find no triangle nearer.
/// (Conservative: a near tie left undecided keeps the object.)
const OWN_FRAGMENT: f32 = 5e-7;

/// True if every pixel centre object `id` covers lies behind the map: by the margin
/// of the f32 lanes, or, at a near tie (a fragment within [`NEAR_TIE_BAND`] of the
/// map, such as where an object meets the wall in front of it), behind a drawn
/// occluder triangle covering the pixel by [`RESOLVE_MARGIN`] in f64
/// ([`OcclusionMap::drawn_nearer`]).
/// (Compiled per SIMD level, like every loop here that cuts triangles into spans.)
#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
pub fn hidden_per_pixel(map: &OcclusionMap, scene: &Scene, cam: &Camera, id: u32) -> bool {
    let w = cam.width as usize;
    let o = &scene.objects[id as usize];
    let mut hint = None;
    scene.corners_of(o).all(|tri| {
        span_triangles(cam, tri, |t| {
            // A triangle the tile bounds show hidden by the margin needs no spans:
            // every fragment would pass the per-pixel test below.
            if map.triangle_hidden(t, REFINE_MARGIN as f64) {
                return true;
            }
            spans_hidden(map, t, w, &mut hint)
        })
    })
}

/// Whether every fragment of `t` lies behind the map ([`hidden_per_pixel`]), its rows
/// [`ROWS`](super::span::ROWS) at a time: a block the finest tile bounds show hidden by the margin
/// ([`OcclusionMap::rows_hidden`]) is settled without its pixels, the others span by
/// span. The answer is the per-pixel one: bounds in front of a block's nearest
/// fragment by the margin put every pixel under them in front of each fragment.
#[inline(always)]
fn spans_hidden(map: &OcclusionMap, t: &SpanTriangle, w: usize, hint: &mut Option<u32>) -> bool {
    let rows = (t.tri.y0, t.tri.y1);
    let settled = |y, ends| map.rows_hidden(t, y, ends, REFINE_MARGIN as f64);
    t.spans_unsettled(rows, settled, |y, s| {
        let at = y as usize * w + s.x0 as usize;
        let occ = &map.pixels_with_padding()[at..at + s.lanes_len()];
        span_hidden(occ, &s) || near_ties_hidden(map, occ, &s, t, y, hint)
    })
}

/// The slow path of a span [`span_hidden`] did not show hidden: true if each of its
/// fragments the map does not hide by the margin is a near tie that a drawn occluder
/// triangle hides in f64 ([`OcclusionMap::drawn_nearer`]).
#[cold]
#[inline(never)]
fn near_ties_hidden(
    map: &OcclusionMap,
    occ: &[f32],
    s: &Span,
    t: &SpanTriangle,
    y: u32,
    hint: &mut Option<u32>,
) -> bool {
    let k = 1.0 + REFINE_MARGIN;
    let band = 1.0 - NEAR_TIE_BAND;
    let py = y as f64 + 0.5;
    for (n, c) in occ.chunks_exact(LANES).enumerate() {
        let v = s.lanes_or(n * LANES, -1.0);
        for j in 0..LANES {
            if c[j] > k * v[j] {
                continue;
            }
            if c[j] <= band * v[j] || (c[j] - v[j]).abs() <= OWN_FRAGMENT * v[j] {
                return false;
            }
            let x = s.x0 + (n * LANES + j) as u32;
            let fragment = t.inv_w_at(x as f64 + 0.5, py);
            if !map.drawn_nearer(x, y, fragment * (1.0 + RESOLVE_MARGIN), hint) {
                return false;
            }
        }
    }
    true
}

/// Whether the map lies in front of every fragment of the span by the margin (`occ`
/// runs on to the span's [`Span::lanes_len`]; lanes past the span count as hidden).
/// The lanes are the map draw's own ([`Span::lanes_from`]: an f64 base stepped chunk
/// by chunk), so an occluder meets its own fragments in the map bit for bit; only the
/// last chunk looks at how many of its lanes are in the span.
#[inline(always)]
fn span_hidden(occ: &[f32], s: &Span) -> bool {
    let k = 1.0 + REFINE_MARGIN;
    let pixels = s.pixels();
    let (full, left) = (pixels / LANES, pixels % LANES);
    let mut lanes = s.lanes_from(0);
    let mut chunks = occ.chunks_exact(LANES);
    // Plain loops: as `chunks_exact(..).enumerate().all(..)` this was left to an
    // out-of-line `try_fold`, compiled without the caller's AVX2 (a tenth of a pose).
    for c in (&mut chunks).take(full) {
        let v = lanes.next_chunk();
        let mut all = true;
        for j in 0..LANES {
            all &= c[j] > k * v[j];
        }
        if !all {
            return false;
        }
    }
    if left == 0 {
        return true;
    }
    let v = lanes.next_chunk();
    let Some(c) = chunks.next() else {
        return false; // (never: `occ` runs on to whole chunks)
    };
    let mut all = true;
    for j in 0..LANES {
        // Past the span every lane counts as hidden; a NaN lane inside it never does.
        all &= (j >= left) | (c[j] > k * v[j]);
    }
    all
}

/// Scratch buffers of the ID-buffer cull, kept from pose to pose.
#[derive(Default)]
pub struct IdBuffer {
    inv_w: Vec<f32>,
    ids: Vec<u32>,
}

/// The exact cull: every candidate's triangles into an ID buffer with a depth test
/// (nearest wins, the first on ties, as the reference oracle); an object is visible
/// when it owns a pixel.
pub fn exact(buf: &mut IdBuffer, scene: &Scene, cam: &Camera, candidates: &[u32]) -> Vec<u32> {
    let n = (cam.width * cam.height) as usize;
    buf.inv_w.clear();
    buf.inv_w.resize(padded_len(n), 0.0);
    buf.ids.clear();
    buf.ids.resize(padded_len(n), u32::MAX);
    draw_ids(buf, scene, cam, candidates);
    let mut mask = empty_mask(scene.objects.len());
    for &id in buf.ids[..n].iter().filter(|&&id| id != u32::MAX) {
        set_bit(&mut mask, id);
    }
    mask
}

/// The ID buffer of [`exact`].
#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
fn draw_ids(buf: &mut IdBuffer, scene: &Scene, cam: &Camera, candidates: &[u32]) {
    let rows = (0, cam.height - 1);
    let w = cam.width as usize;
    for &id in candidates {
        for tri in scene.corners_of(&scene.objects[id as usize]) {
            span_triangles(cam, tri, |t| {
                t.spans(rows, |y, s| {
                    let at = y as usize * w + s.x0 as usize;
                    let end = at + s.lanes_len();
                    nearest_id(&mut buf.inv_w[at..end], &mut buf.ids[at..end], &s, id);
                    true
                })
            });
        }
    }
}

/// Depth-tested write of `id` over the span's pixels (the buffers run on to the
/// span's [`Span::lanes_len`]; lanes past the span are left as they are).
#[inline(always)]
fn nearest_id(inv_w: &mut [f32], ids: &mut [u32], s: &Span, id: u32) {
    for (n, (dc, oc)) in inv_w
        .chunks_exact_mut(LANES)
        .zip(ids.chunks_exact_mut(LANES))
        .enumerate()
    {
        // Past the span, -1: no map value (never below 0) lies behind it.
        let v = s.lanes_exact_or(n * LANES, -1.0);
        // Blended in registers and stored whole (a select of the loaded value
        // written back in place becomes a masked store).
        let (mut depth, mut owner) = ([0.0; LANES], [0; LANES]);
        for j in 0..LANES {
            let wins = v[j] > dc[j];
            depth[j] = if wins { v[j] } else { dc[j] };
            owner[j] = if wins { id } else { oc[j] };
        }
        dc.copy_from_slice(&depth);
        oc.copy_from_slice(&owner);
    }
}
