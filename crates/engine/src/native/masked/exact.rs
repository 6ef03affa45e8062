//! Per-pixel depth of single tiles, drawn when the refinement first reads them.
//!
//! A tile's pixels are the nearest `1/w` of the triangles the map drew (each the
//! triangle's f64 plane at the start of a chunk of [`LANES`] pixels, stepped in f32
//! along it, within `span::LANE_SLACK` of the plane), over exactly the pixels
//! their spans cover; a pixel no triangle covers holds 0. Triangles the map left out
//! as hidden are not needed: each of their fragments lies behind a bound the map
//! keeps there, and so behind a drawn fragment. Drawing lists the tiles each triangle
//! covers pixels of; the lists are gathered per tile on the first tile read in a pose,
//! and a tile is drawn at most once per pose (a generation count per tile, so a new
//! pose clears nothing).

use super::{H, TILE_H, TILE_W, tile_rows};
use crate::native::span::{LANES, RAMP, SpanTriangle};

const PIXELS: usize = (TILE_W * TILE_H) as usize;

#[derive(Default)]
pub(super) struct ExactTiles {
    /// Tile-major: tile `i`'s pixels are `px[i * PIXELS..]`, row-major inside it.
    px: Vec<f32>,
    /// The generation each tile was last drawn in.
    drawn: Vec<u32>,
    generation: u32,
    /// `(tile, triangle)` for every tile a drawn triangle covers pixels of, in the
    /// order drawn; gathered per tile on first use in a pose (`starts`, `lists`).
    hits: Vec<(u32, u32)>,
    starts: Vec<u32>,
    lists: Vec<u32>,
    binned: bool,
}

impl ExactTiles {
    /// Room for `tiles` tiles; none drawn.
    pub(super) fn resize(&mut self, tiles: usize) {
        self.px = vec![0.0; tiles * PIXELS];
        self.drawn = vec![0; tiles];
        self.starts = vec![0; tiles + 1];
        self.generation = 0;
    }

    /// A new pose: no tile drawn, no triangle listed.
    pub(super) fn reset(&mut self) {
        self.generation = self.generation.wrapping_add(1);
        if self.generation == 0 {
            self.drawn.fill(0);
            self.generation = 1;
        }
        self.hits.clear();
        self.binned = false;
    }

    /// Triangle `tri` covers pixels of tile `tile`.
    #[inline(always)]
    pub(super) fn hit(&mut self, tile: u32, tri: u32) {
        self.hits.push((tile, tri));
    }

    /// The pixels of tile `(tx, ty)` (row-major, [`TILE_W`] per row), drawn from
    /// `tris` if this pose has not drawn it yet.
    pub(super) fn tile(&mut self, tris: &[SpanTriangle], tiles_x: u32, tx: u32, ty: u32) -> &[f32] {
        self.gather();
        let i = (ty * tiles_x + tx) as usize;
        let px = &mut self.px[i * PIXELS..(i + 1) * PIXELS];
        if self.drawn[i] != self.generation {
            self.drawn[i] = self.generation;
            let list = &self.lists[self.starts[i] as usize..self.starts[i + 1] as usize];
            draw_tile(px, tris, list, tx, ty);
        }
        px
    }

    /// Gathers the hits per tile (a counting sort), once per pose.
    fn gather(&mut self) {
        if self.binned {
            return;
        }
        self.starts.fill(0);
        for &(tile, _) in &self.hits {
            self.starts[tile as usize + 1] += 1;
        }
        for i in 1..self.starts.len() {
            self.starts[i] += self.starts[i - 1];
        }
        self.lists.resize(self.hits.len(), 0);
        let mut next = self.starts.clone();
        for &(tile, tri) in &self.hits {
            self.lists[next[tile as usize] as usize] = tri;
            next[tile as usize] += 1;
        }
        self.binned = true;
    }
}

/// The nearest `1/w` of the listed triangles over one tile's pixels: per row of
/// each, its span's pixels in the tile, [`LANES`] at a time from the plane's f64
/// value at the chunk's first pixel (f32 steps from there, within [`LANE_SLACK`]).
#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
fn draw_tile(px: &mut [f32], tris: &[SpanTriangle], list: &[u32], tx: u32, ty: u32) {
    px.fill(0.0);
    let x0 = (tx * TILE_W) as i32;
    for &i in list {
        let t = &tris[i as usize];
        let (slope, _) = t.inv_w_slopes();
        let slope = slope as f32;
        let (first, last) = tile_rows(t, ty * TILE_H);
        for r in 0..H {
            let (a, b) = (first[r].max(x0), last[r].min(x0 + TILE_W as i32 - 1));
            if a > b {
                continue;
            }
            let py = (ty * TILE_H + r as u32) as f64 + 0.5;
            let row: &mut [f32; TILE_W as usize] = (&mut px[r * TILE_W as usize..]
                [..TILE_W as usize])
                .try_into()
                .expect("a tile row");
            // Chunks of the row the span reaches; lanes outside it are left alone.
            for c in (a - x0) as usize / LANES..=(b - x0) as usize / LANES {
                let from = c * LANES;
                let start = t.inv_w_at((x0 + from as i32) as f64 + 0.5, py) as f32;
                for k in 0..LANES {
                    let x = (from + k) as i32 + x0;
                    let v = start + slope * RAMP[k];
                    let inside = x >= a && x <= b && v < f32::INFINITY;
                    let p = &mut row[from + k];
                    // A value that is not a finite number is dropped (the pixel stays
                    // as it was, never nearer).
                    *p = if inside && v > *p { v } else { *p };
                }
            }
        }
    }
}
