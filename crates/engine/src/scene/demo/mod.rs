//! The built-in demo scene: a procedural city that needs no file.
//!
//! Culling is only interesting where things hide each other, and a test or a first
//! `homcull serve` should not depend on downloading a scene. So this module grows a
//! city from a fixed seed: a street grid of blocks whose buildings line the streets,
//! courtyards and backyards behind them, and small props (cars, trees, benches) both
//! out on the streets and hidden in the courtyards. A walk at street level therefore
//! sees a few facades and the street in front while most of the city is occluded,
//! which is the situation HOM is built for.
//!
//! Everything is deterministic: the same build always yields the same objects, in the
//! same order, with the same names and coordinates, so object IDs are stable.
//! The grid is centred so that the origin lies on an open street crossing.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

mod blocks;
mod mesh;
#[cfg(test)]
mod tests;

use blocks::{add_block, add_ground, add_street_cars};
use mesh::{City, Rect};

use super::Scene;

/// The seed every build uses; changing it changes every object of the demo city.
const SEED: u64 = 0x00C1_7E5E_ED00_0001;
/// Blocks along each axis.
const BLOCKS_PER_SIDE: usize = 12;
/// Block side lengths (metres), drawn per grid column and row.
const BLOCK_SIZE: (f32, f32) = (50.0, 70.0);
/// Street widths (metres), drawn per street.
const STREET_WIDTH: (f32, f32) = (12.0, 16.0);
/// Sidewalk inside each block's edge: buildings stand back this far from the street.
const SIDEWALK: f32 = 4.0;
/// Ordinary building heights (metres).
const BUILDING_HEIGHT: (f32, f32) = (8.0, 28.0);
/// Tower heights (metres) and how often a building is a tower.
const TOWER_HEIGHT: (f32, f32) = (30.0, 60.0);
const TOWER_CHANCE: f64 = 0.12;
/// How far a building reaches from its street side into the block (metres).
const BUILDING_DEPTH: (f32, f32) = (10.0, 22.0);
/// Chance that a corner building is L-shaped (two boxes in one object).
const L_SHAPE_CHANCE: f64 = 0.35;
/// No street props within this distance of the origin, so the grid centre stays a
/// clear place to stand and walk.
const CLEAR_CENTRE_RADIUS: f32 = 25.0;
/// Spacing of parking slots along a street and the chance each is taken.
const PARKING_SPACING: f32 = 6.5;
const PARKED_CHANCE: f64 = 0.2;
/// Chance that a lane slot holds a driving car (still clear of the centre line).
const DRIVING_CHANCE: f64 = 0.03;
/// Spacing of sidewalk tree slots and the chance each holds a tree or a bench.
const SIDEWALK_SLOT: f32 = 11.0;
const SIDEWALK_TREE_CHANCE: f64 = 0.35;
const SIDEWALK_BENCH_CHANCE: f64 = 0.08;

/// The demo city, named "demo". A few thousand objects, under 150k triangles.
pub fn demo_city() -> Scene {
    build_city(BLOCKS_PER_SIDE, "demo".into())
}

/// A demo city with `blocks_per_side` × `blocks_per_side` blocks (at least 1), named
/// `demo_N`, for object-count scaling: about 29 objects per block. It draws from the
/// same seed and generator as [`demo_city`]; `demo_city_sized(12)` builds the same
/// objects as `demo_city()`.
pub fn demo_city_sized(blocks_per_side: usize) -> Scene {
    let n = blocks_per_side.max(1);
    build_city(n, format!("demo_{n}"))
}

fn build_city(n: usize, name: String) -> Scene {
    let mut rng = ChaCha8Rng::seed_from_u64(SEED);
    let (xs, zs) = city_layout(&mut rng, n);
    let mut city = City::default();
    add_ground(&mut city, &xs, &zs);
    for bz in 0..n {
        for bx in 0..n {
            let block = Rect::from_spans(xs.blocks[bx], zs.blocks[bz]);
            add_block(&mut city, &mut rng, (bx, bz), block);
        }
    }
    add_street_cars(&mut city, &mut rng, &xs, &zs);
    city.builder.build(name)
}

/// A closed interval along one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Span {
    lo: f32,
    hi: f32,
}

impl Span {
    fn mid(self) -> f32 {
        (self.lo + self.hi) * 0.5
    }

    fn len(self) -> f32 {
        self.hi - self.lo
    }
}

/// Streets and blocks along one axis, alternating street, block, …, street.
#[derive(Debug, Clone, PartialEq)]
struct AxisLayout {
    /// `n + 1` streets for `n` blocks, the outermost ones bordering the city.
    streets: Vec<Span>,
    blocks: Vec<Span>,
}

/// Draws the x and z layouts (in that order) from the first random numbers of `rng`.
fn city_layout(rng: &mut ChaCha8Rng, n: usize) -> (AxisLayout, AxisLayout) {
    let xs = axis_layout(rng, n);
    let zs = axis_layout(rng, n);
    (xs, zs)
}

/// One axis of the grid, shifted so the middle street is centred on 0: the origin is
/// then the middle of an open crossing.
fn axis_layout(rng: &mut ChaCha8Rng, n: usize) -> AxisLayout {
    let mut streets = Vec::with_capacity(n + 1);
    let mut blocks = Vec::with_capacity(n);
    let mut at = 0.0;
    for i in 0..=n {
        let width = between(rng, STREET_WIDTH);
        streets.push(Span {
            lo: at,
            hi: at + width,
        });
        at += width;
        if i < n {
            let size = between(rng, BLOCK_SIZE);
            blocks.push(Span {
                lo: at,
                hi: at + size,
            });
            at += size;
        }
    }
    let shift = streets[n / 2].mid();
    let shifted = |s: &Span| Span {
        lo: s.lo - shift,
        hi: s.hi - shift,
    };
    AxisLayout {
        streets: streets.iter().map(shifted).collect(),
        blocks: blocks.iter().map(shifted).collect(),
    }
}

/// A uniform draw from `[lo, hi)`; unlike `random_range` it cannot panic on an empty range.
fn between(rng: &mut ChaCha8Rng, (lo, hi): (f32, f32)) -> f32 {
    lo + (hi - lo) * rng.random::<f32>()
}
