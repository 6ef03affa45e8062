//! Drawing into the occlusion map: occluder triangles set up into screen triangles
//! (leaving out those the bounds already show hidden), then drawn band by band of
//! rows, each band's tiles bounded as it is finished, one band after another or the
//! bands of one pose in parallel.

use glam::Vec3;

use super::{OcclusionMap, TILE, TileRect, bound_tile_rows, front_facing};
use crate::camera::Camera;
use crate::cull::deb::DEPTH_MARGIN;
use crate::geom::Aabb;
use crate::native::span::{LANES, Span, SpanTriangle};
use crate::reference::raster::{ScreenTriangle, screen_polygon};
use crate::scene::Scene;

/// Triangles whose pixel box is at least this large are first tested against the
/// tile bounds when drawing into a bounded map: a test costs about as much as a few
/// rows of spans.
const SKIP_TEST_MIN_PIXELS: u32 = 64;

/// Rows of the map drawn together ([`draw_binned`]): a band of a 960-pixel-wide map
/// (120 KB) stays in a core's L2 cache while every triangle reaching it is drawn and
/// its tiles are bounded. A multiple of [`TILE`].
pub(super) const BAND: u32 = 32;

/// The screen triangles of `tris` for drawing into `map`. With `skip_hidden` (the map
/// is bounded and has only grown nearer since), a large triangle that the bounds show
/// behind the map everywhere in its box is left out, since each of its fragments
/// would lose to the pixel it falls on and the map ends the same. (Stale bounds only
/// make that test answer "not hidden" more often.)
#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
pub(super) fn setup_triangles<I: Iterator<Item = [Vec3; 3]>>(
    map: &OcclusionMap,
    cam: &Camera,
    tris: I,
    skip_hidden: bool,
    out: &mut Vec<SpanTriangle>,
) {
    for tri in tris {
        push_unhidden(map, cam, tri, skip_hidden, out);
    }
}

/// Appends the screen triangles of `tri` to `out`, but (with `skip_hidden`) the large
/// ones the bounds show hidden ([`setup_triangles`]).
#[inline(always)]
fn push_unhidden(
    map: &OcclusionMap,
    cam: &Camera,
    tri: [Vec3; 3],
    skip_hidden: bool,
    out: &mut Vec<SpanTriangle>,
) {
    // The loop of `span_triangles` written out: through its closure, this body was
    // left out of line, compiled without the caller's AVX2.
    for t in screen_polygon(cam, tri).fan() {
        let Some(t) = ScreenTriangle::new(cam.width, cam.height, t) else {
            continue;
        };
        let t = SpanTriangle::new(t);
        // A plane past f32's range would write NaN or infinite lanes; leaving the
        // triangle out leaves the map farther, never nearer (such slopes take f64
        // coordinates no triangle covering a pixel centre has).
        let hidden = !t.plane_is_bounded()
            || skip_hidden
                && t.box_pixels() >= SKIP_TEST_MIN_PIXELS
                && map.triangle_hidden(&t, 0.0);
        if !hidden {
            out.push(t);
        }
    }
}

/// The screen triangles of the front faces of occluders `ids` for drawing into `map`,
/// as [`setup_triangles`]; with `skip_hidden`, an occluder whose box the bounded map
/// already hides (the box test, margin included) is left out whole ([`OcclusionMap::draw_occluders`]).
/// Answers the number left out. Loops over the objects' index ranges directly: an
/// iterator chain over them (flat-map, filter) cost a tenth of the draw.
#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
pub(super) fn setup_occluders(
    map: &OcclusionMap,
    scene: &Scene,
    cam: &Camera,
    ids: &[u32],
    skip_hidden: bool,
    out: &mut Vec<SpanTriangle>,
) -> usize {
    let eye = cam.position;
    let p = &scene.positions;
    let mut skipped = 0;
    // The box projection in AVX lanes where this clone runs with AVX (the same rect).
    let project = |b: &Aabb| {
        multiversion::target::match_target! {
            "x86_64+avx2+fma" => cam.project_box_avx(b),
            _ => cam.project_box(b),
        }
    };
    for &id in ids {
        let o = &scene.objects[id as usize];
        if skip_hidden
            && project(&o.aabb).is_none_or(|r| map.rect_hidden(&r, (1.0 + DEPTH_MARGIN) / r.near))
        {
            skipped += 1;
            continue;
        }
        for t in scene.triangles_of(o).chunks_exact(3) {
            let tri = [p[t[0] as usize], p[t[1] as usize], p[t[2] as usize]];
            if front_facing(eye, &tri) {
                push_unhidden(map, cam, tri, skip_hidden, out);
            }
        }
    }
    skipped
}

/// One band's share of [`draw_binned`]'s work: its index, its rows of the map, of the
/// finest `far` and `near` bounds, the triangles reaching it, and its dirty flag.
type BandSlices<'a> = (
    usize,
    (
        (
            ((&'a mut [f32], &'a mut [f32]), &'a mut [f32]),
            ((&'a Vec<u32>, &'a usize), &'a (u32, u32)),
        ),
        &'a mut bool,
    ),
);

/// Draws the map's screen triangles from `from` on (those set up since the last draw)
/// band by band ([`BAND`] rows): the triangles are binned by the bands they reach
/// (appended to the bins of the draws before), then each band's pixels are written by
/// every new triangle in its bin and the tiles they reach bounded, while they are in
/// cache (on a map bounded before, the other tiles keep their bounds; on a fresh one
/// they are 0); the coarser bounds follow over the tiles drawn on. Each
/// band works on its own rows of the map and of the finest bounds (disjoint slices; a
/// span's last chunk that would run past the band's last row is cut there), so the
/// bands of one pose can be drawn in parallel on rayon's pool
/// ([`OcclusionMap::bands_in_parallel`]). The map keeps the largest `1/w` per pixel,
/// which depends neither on the order of drawing nor on the split.
pub(super) fn draw_binned(map: &mut OcclusionMap, from: usize) {
    use rayon::prelude::*;
    let (w, h) = (map.width as usize, map.height);
    let bands = h.div_ceil(BAND) as usize;
    map.dirty.resize(bands, false);
    let mut bins = std::mem::take(&mut map.bins);
    bins.resize_with(bands, Vec::new);
    let mut bins_from = std::mem::take(&mut map.bins_from);
    bins_from.clear();
    bins_from.extend(bins.iter().map(Vec::len));
    let mut band_cols = std::mem::take(&mut map.band_cols);
    band_cols.clear();
    band_cols.resize(bands, (u32::MAX, 0));
    let tris = &map.setup;
    for (i, t) in tris.iter().enumerate().skip(from) {
        let reached = (t.tri.y0 / BAND) as usize..=(t.tri.y1 / BAND) as usize;
        let cols = (t.tri.x0 / TILE, t.tri.x1 / TILE);
        for (band, c) in bins[reached.clone()]
            .iter_mut()
            .zip(&mut band_cols[reached])
        {
            band.push(i as u32);
            *c = (c.0.min(cols.0), c.1.max(cols.1));
        }
    }
    // The finest tiles drawn on: the upper levels are bounded over them.
    let mut drawn = TileRect {
        x0: u32::MAX,
        y0: u32::MAX,
        x1: 0,
        y1: 0,
    };
    let tiles_per_band = BAND / TILE;
    for (band, &(c0, c1)) in band_cols.iter().enumerate() {
        if c0 <= c1 {
            let b = band as u32;
            drawn.x0 = drawn.x0.min(c0);
            drawn.x1 = drawn.x1.max(c1);
            drawn.y0 = drawn.y0.min(b * tiles_per_band);
            drawn.y1 = drawn.y1.max(b * tiles_per_band + tiles_per_band - 1);
        }
    }
    let tile_rows = (BAND / TILE) as usize * map.dims[0].0 as usize;
    let level0 = map.dims[0].0 as usize * map.dims[0].1 as usize;
    let bounded = map.bounded;
    let band_rows = BAND as usize * w;
    let pixels = &mut map.inv_w[..w * h as usize];
    let (far, near) = (&mut map.far[..level0], &mut map.near[..level0]);
    let draw = |(band, ((((px, far), near), ((list, &from), &cols)), dirty)): BandSlices| {
        let list = &list[from..];
        if !list.is_empty() {
            // Bounded, the tiles no triangle reached keep their bounds; else they
            // are 0, as their pixels are.
            let cols = if bounded {
                cols.0 as usize..cols.1 as usize + 1
            } else {
                0..w.div_ceil(TILE as usize)
            };
            draw_band(px, far, near, w, band as u32 * BAND, tris, list, cols);
            *dirty = true;
        } else if !bounded {
            // The first draw since a reset, which left every band clean: each pixel
            // is 0, so is each bound, without reading them.
            debug_assert!(!*dirty, "a reset clears every dirty band");
            far.fill(0.0);
            near.fill(0.0);
        }
        // (Else the band's pixels, and so its bounds, are as they were.)
    };
    let mut dirty = std::mem::take(&mut map.dirty);
    if map.bands_in_parallel && rayon::current_num_threads() > 1 {
        pixels
            .par_chunks_mut(band_rows)
            .zip(far.par_chunks_mut(tile_rows))
            .zip(near.par_chunks_mut(tile_rows))
            .zip(bins.par_iter().zip(&bins_from).zip(&band_cols))
            .zip(&mut dirty)
            .enumerate()
            .for_each(draw);
    } else {
        pixels
            .chunks_mut(band_rows)
            .zip(far.chunks_mut(tile_rows))
            .zip(near.chunks_mut(tile_rows))
            .zip(bins.iter().zip(&bins_from).zip(&band_cols))
            .zip(&mut dirty)
            .enumerate()
            .for_each(draw);
    }
    map.dirty = dirty;
    map.bins = bins;
    map.bins_from = bins_from;
    map.band_cols = band_cols;
    let rect = if bounded { drawn } else { map.all_tiles() };
    // (The last band's tile rows may run past the map's: each level clamps its rect.)
    if rect.x0 <= rect.x1 {
        map.bound_upper_levels(rect);
    }
    map.bounded = true;
}

/// One band of [`draw_binned`]: `px` are its rows from `y0`, `far`/`near` its tile
/// rows' finest bounds, `list` the triangles reaching it, `cols` the tile columns
/// whose bounds it builds (those the triangles reach, on a bounded map).
#[allow(clippy::too_many_arguments)]
#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
fn draw_band(
    px: &mut [f32],
    far: &mut [f32],
    near: &mut [f32],
    w: usize,
    y0: u32,
    tris: &[SpanTriangle],
    list: &[u32],
    cols: std::ops::Range<usize>,
) {
    let y1 = y0 + (px.len() / w) as u32 - 1;
    for &i in list {
        tris[i as usize].spans((y0, y1), |y, s| {
            let at = (y - y0) as usize * w + s.x0 as usize;
            let end = (at + s.lanes_len()).min(px.len());
            keep_nearest(&mut px[at..end], &s);
            true
        });
    }
    bound_tile_rows(px, w, cols, far, near);
}

/// `dst[i] = max(dst[i], 1/w of the span's pixel i)`: the nearest fragment wins.
/// `dst` runs on to the span's [`Span::lanes_len`]; in the last chunk, lanes past the
/// span are set to 0 ([`TAIL_KEEP`]), which leaves a pixel (never below 0) unchanged.
#[inline(always)]
fn keep_nearest(dst: &mut [f32], s: &Span) {
    let pixels = s.pixels();
    let (full, left) = (pixels / LANES, pixels % LANES);
    let mut chunks = dst.chunks_exact_mut(LANES);
    let mut lanes = s.lanes_from(0);
    for c in (&mut chunks).take(full) {
        keep_larger(c, &lanes.next_chunk());
    }
    if left == 0 {
        return;
    }
    let mut tail = lanes.next_chunk();
    for (v, &keep) in tail.iter_mut().zip(&TAIL_KEEP[left]) {
        *v = f32::from_bits(v.to_bits() & keep);
    }
    if let Some(c) = chunks.next() {
        keep_larger(c, &tail);
    } else {
        // `dst` ends inside the last chunk (the last row of a band): the span's
        // pixels there are all in it.
        for (c, &v) in chunks.into_remainder().iter_mut().zip(&tail) {
            keep_larger_one(c, v);
        }
    }
}

/// `TAIL_KEEP[n]`: all bits set in the first `n` lanes, none in the others. A span's
/// last chunk is masked with it (one `and` per lane, where a blend by arithmetic took
/// six operations).
const TAIL_KEEP: [[u32; LANES]; LANES] = {
    let mut m = [[0; LANES]; LANES];
    let mut n = 0;
    while n < LANES {
        let mut k = 0;
        while k < n {
            m[n][k] = !0;
            k += 1;
        }
        n += 1;
    }
    m
};

/// `c[k] = max(c[k], v[k])` for `1/w` values: compared as the integers of their bits,
/// which order non-negative floats as the floats do (a negative `v` never wins, and
/// the map holds no negative value). One integer `max` per lane, where `f32::max`
/// adds NaN handling (and a compare and select becomes a masked store). No lane is a
/// NaN or infinite (whose bits would win): only triangles whose plane is bounded in
/// f32 over their box are drawn ([`SpanTriangle::plane_is_bounded`], checked at setup).
#[inline(always)]
fn keep_larger(c: &mut [f32], v: &[f32; LANES]) {
    for k in 0..LANES {
        keep_larger_one(&mut c[k], v[k]);
    }
}

/// One lane of [`keep_larger`].
#[inline(always)]
fn keep_larger_one(c: &mut f32, v: f32) {
    let larger = (c.to_bits() as i32).max(v.to_bits() as i32);
    *c = f32::from_bits(larger as u32);
}

/// Zeroes the bands of `map` a draw wrote to since they were last cleared, and marks
/// every band clean: at street level the upper bands (sky) are never drawn, and
/// clearing the whole map was a memory-bound pass over all of it per pose.
pub(super) fn clear_dirty_bands(map: &mut OcclusionMap) {
    let band_rows = BAND as usize * map.width as usize;
    let pixels = (map.width * map.height) as usize;
    for (band, dirty) in map.dirty.iter_mut().enumerate() {
        if std::mem::take(dirty) {
            let start = band * band_rows;
            map.inv_w[start..(start + band_rows).min(pixels)].fill(0.0);
        }
    }
}
