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

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{Scene, SceneBuilder};

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

/// An axis-aligned rectangle on the ground (x, z).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Rect {
    x0: f32,
    z0: f32,
    x1: f32,
    z1: f32,
}

impl Rect {
    fn from_spans(x: Span, z: Span) -> Self {
        Rect {
            x0: x.lo,
            z0: z.lo,
            x1: x.hi,
            z1: z.hi,
        }
    }

    fn shrunk(self, d: f32) -> Self {
        Rect {
            x0: self.x0 + d,
            z0: self.z0 + d,
            x1: self.x1 - d,
            z1: self.z1 - d,
        }
    }

    fn width(self) -> f32 {
        self.x1 - self.x0
    }

    fn depth(self) -> f32 {
        self.z1 - self.z0
    }

    fn overlaps(self, o: Rect) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.z0 < o.z1 && o.z0 < self.z1
    }

    /// The solid box standing on this rectangle from `y0` to `y1`.
    fn extruded(self, y0: f32, y1: f32) -> (Vec3, Vec3) {
        (
            Vec3::new(self.x0, y0, self.z0),
            Vec3::new(self.x1, y1, self.z1),
        )
    }

    /// A square of half side `r` around a point.
    fn around(x: f32, z: f32, r: f32) -> Self {
        Rect {
            x0: x - r,
            z0: z - r,
            x1: x + r,
            z1: z + r,
        }
    }
}

/// Vertices and a triangle list for one object, before it joins the scene.
#[derive(Debug, Default)]
struct Mesh {
    vertices: Vec<Vec3>,
    indices: Vec<u32>,
}

/// The faces of a box as corner quads (corner `i` takes max on axis `k` iff bit `k`
/// of `i` is set), each counter-clockwise seen from outside so normals point out.
const BOX_QUADS: [[u32; 4]; 6] = [
    [0, 4, 6, 2], // −x
    [1, 3, 7, 5], // +x
    [0, 1, 5, 4], // −y
    [2, 6, 7, 3], // +y
    [0, 2, 3, 1], // −z
    [4, 5, 7, 6], // +z
];

impl Mesh {
    /// A closed box: 8 corners, 12 outward-facing triangles.
    fn add_box(&mut self, min: Vec3, max: Vec3) {
        let base = self.vertices.len() as u32;
        self.vertices.extend((0..8).map(|i| {
            Vec3::new(
                if i & 1 == 0 { min.x } else { max.x },
                if i & 2 == 0 { min.y } else { max.y },
                if i & 4 == 0 { min.z } else { max.z },
            )
        }));
        for [a, b, c, d] in BOX_QUADS {
            self.indices
                .extend([a, b, c, a, c, d].map(|corner| base + corner));
        }
    }

    /// A closed octahedron (a cheap tree crown): 6 vertices, 8 outward triangles.
    fn add_octahedron(&mut self, centre: Vec3, radius: Vec3) {
        let base = self.vertices.len() as u32;
        // Vertex 2k is the −axis tip and 2k+1 the +axis tip of axis k.
        for axis in 0..3 {
            for sign in [-1.0, 1.0] {
                let mut offset = Vec3::ZERO;
                offset[axis] = sign * radius[axis];
                self.vertices.push(centre + offset);
            }
        }
        for octant in 0..8u32 {
            let tip = |axis: u32| base + 2 * axis + ((octant >> axis) & 1);
            let (x, y, z) = (tip(0), tip(1), tip(2));
            // (x, y, z) winds counter-clockwise seen from outside iff the octant has an
            // even number of negative axes; otherwise swap two corners.
            let negatives = 3 - octant.count_ones();
            if negatives % 2 == 0 {
                self.indices.extend([x, y, z]);
            } else {
                self.indices.extend([x, z, y]);
            }
        }
    }

    /// A flat ground tile at y = 0 facing up: 2 triangles.
    fn add_ground_quad(&mut self, r: Rect) {
        let base = self.vertices.len() as u32;
        self.vertices.extend([
            Vec3::new(r.x0, 0.0, r.z0),
            Vec3::new(r.x0, 0.0, r.z1),
            Vec3::new(r.x1, 0.0, r.z1),
            Vec3::new(r.x1, 0.0, r.z0),
        ]);
        self.indices.extend([0, 1, 2, 0, 2, 3].map(|i| base + i));
    }
}

/// The scene under construction plus running counters for prop names.
#[derive(Default)]
struct City {
    builder: SceneBuilder,
    cars: usize,
    trees: usize,
    benches: usize,
}

impl City {
    fn push(&mut self, name: String, mesh: &Mesh) {
        self.builder.push(name, &mesh.vertices, &mesh.indices, None);
    }

    /// A car of about 4.5 × 1.5 × 1.8 m: body plus cabin, long side along x or z.
    fn add_car(&mut self, x: f32, z: f32, along_x: bool) {
        let (half_long, half_wide) = if along_x { (2.25, 0.9) } else { (0.9, 2.25) };
        let (cabin_long, cabin_wide) = if along_x { (1.2, 0.8) } else { (0.8, 1.2) };
        let mut mesh = Mesh::default();
        mesh.add_box(
            Vec3::new(x - half_long, 0.0, z - half_wide),
            Vec3::new(x + half_long, 0.9, z + half_wide),
        );
        mesh.add_box(
            Vec3::new(x - cabin_long, 0.9, z - cabin_wide),
            Vec3::new(x + cabin_long, 1.5, z + cabin_wide),
        );
        self.push(format!("car_{}", self.cars), &mesh);
        self.cars += 1;
    }

    /// A tree: a trunk box and a crown (an octahedron or a box) in one object.
    /// Returns the radius of its crown.
    fn add_tree(&mut self, rng: &mut ChaCha8Rng, x: f32, z: f32, max_crown: f32) -> f32 {
        let trunk = between(rng, (2.2, 3.5));
        let crown = between(rng, (1.2, max_crown.max(1.3)));
        let mut mesh = Mesh::default();
        mesh.add_box(
            Vec3::new(x - 0.2, 0.0, z - 0.2),
            Vec3::new(x + 0.2, trunk, z + 0.2),
        );
        if rng.random_bool(0.5) {
            let centre = Vec3::new(x, trunk + crown * 0.9, z);
            mesh.add_octahedron(centre, Vec3::new(crown, crown * 1.2, crown));
        } else {
            let half = crown * 0.8;
            mesh.add_box(
                Vec3::new(x - half, trunk - 0.3, z - half),
                Vec3::new(x + half, trunk + crown * 1.6, z + half),
            );
        }
        self.push(format!("tree_{}", self.trees), &mesh);
        self.trees += 1;
        crown
    }

    /// A bench: seat and backrest boxes, 1.8 m long, along x or z.
    fn add_bench(&mut self, x: f32, z: f32, along_x: bool) {
        let (half_long, half_deep) = (0.9, 0.25);
        let mut mesh = Mesh::default();
        let (seat_min, seat_max, back_min, back_max) = if along_x {
            (
                Vec3::new(x - half_long, 0.0, z - half_deep),
                Vec3::new(x + half_long, 0.45, z + half_deep),
                Vec3::new(x - half_long, 0.45, z + half_deep - 0.08),
                Vec3::new(x + half_long, 0.9, z + half_deep),
            )
        } else {
            (
                Vec3::new(x - half_deep, 0.0, z - half_long),
                Vec3::new(x + half_deep, 0.45, z + half_long),
                Vec3::new(x + half_deep - 0.08, 0.45, z - half_long),
                Vec3::new(x + half_deep, 0.9, z + half_long),
            )
        };
        mesh.add_box(seat_min, seat_max);
        mesh.add_box(back_min, back_max);
        self.push(format!("bench_{}", self.benches), &mesh);
        self.benches += 1;
    }
}

/// Ground tiles: one quad per block, per street segment between crossings, and per
/// crossing, so the ground is many small objects rather than one box holding the city.
fn add_ground(city: &mut City, xs: &AxisLayout, zs: &AxisLayout) {
    let tile = |city: &mut City, name: String, x: Span, z: Span| {
        let mut mesh = Mesh::default();
        mesh.add_ground_quad(Rect::from_spans(x, z));
        city.push(name, &mesh);
    };
    for (bz, &z) in zs.blocks.iter().enumerate() {
        for (bx, &x) in xs.blocks.iter().enumerate() {
            tile(city, format!("ground_block_{bx}_{bz}"), x, z);
        }
    }
    // Streets running along x (one z span each), cut into segments by the blocks.
    for (row, &z) in zs.streets.iter().enumerate() {
        for (seg, &x) in xs.blocks.iter().enumerate() {
            tile(city, format!("ground_street_ew_{row}_{seg}"), x, z);
        }
    }
    // Streets running along z (one x span each).
    for (col, &x) in xs.streets.iter().enumerate() {
        for (seg, &z) in zs.blocks.iter().enumerate() {
            tile(city, format!("ground_street_ns_{col}_{seg}"), x, z);
        }
    }
    for (row, &z) in zs.streets.iter().enumerate() {
        for (col, &x) in xs.streets.iter().enumerate() {
            tile(city, format!("ground_crossing_{col}_{row}"), x, z);
        }
    }
}

/// One block: buildings along its streets, a courtyard behind them, props in both.
fn add_block(city: &mut City, rng: &mut ChaCha8Rng, (bx, bz): (usize, usize), block: Rect) {
    let inner = block.shrunk(SIDEWALK);
    let mut footprints = Vec::new();
    let mut letter = 0u8;
    for lot in split_into_lots(rng, inner) {
        let boxes = building_boxes(rng, &lot);
        if boxes.is_empty() {
            continue;
        }
        let mut mesh = Mesh::default();
        for (rect, height) in &boxes {
            let (min, max) = rect.extruded(0.0, *height);
            mesh.add_box(min, max);
            footprints.push(*rect);
        }
        let suffix = char::from(b'a' + letter % 26);
        city.push(format!("building_{bx}_{bz}_{suffix}"), &mesh);
        letter += 1;
    }
    add_sidewalk_props(city, rng, block);
    add_courtyard_props(city, rng, inner, &footprints);
}

/// A lot of a block and which of its sides face a street: `[−x, +x, −z, +z]`.
#[derive(Debug, Clone, Copy)]
struct Lot {
    rect: Rect,
    street_sides: [bool; 4],
}

/// Cuts the buildable part of a block into 2×2 to 3×3 lots with jittered borders.
fn split_into_lots(rng: &mut ChaCha8Rng, inner: Rect) -> Vec<Lot> {
    let nx = if rng.random_bool(0.5) { 2 } else { 3 };
    let nz = if rng.random_bool(0.5) { 2 } else { 3 };
    let xs = jittered_cuts(rng, inner.x0, inner.x1, nx);
    let zs = jittered_cuts(rng, inner.z0, inner.z1, nz);
    let mut lots = Vec::with_capacity(nx * nz);
    for j in 0..nz {
        for i in 0..nx {
            lots.push(Lot {
                rect: Rect {
                    x0: xs[i],
                    z0: zs[j],
                    x1: xs[i + 1],
                    z1: zs[j + 1],
                },
                street_sides: [i == 0, i == nx - 1, j == 0, j == nz - 1],
            });
        }
    }
    lots
}

/// `n + 1` increasing cut positions from `lo` to `hi`, inner ones jittered by ±8 %.
fn jittered_cuts(rng: &mut ChaCha8Rng, lo: f32, hi: f32, n: usize) -> Vec<f32> {
    let step = (hi - lo) / n as f32;
    (0..=n)
        .map(|i| match i {
            0 => lo,
            i if i == n => hi,
            i => lo + step * (i as f32 + between(rng, (-0.08, 0.08))),
        })
        .collect()
}

/// The boxes (footprint, height) of the building on one lot: it hugs the lot's street
/// sides, leaving the rest of the lot as yard. Inner lots stay empty courtyards.
fn building_boxes(rng: &mut ChaCha8Rng, lot: &Lot) -> Vec<(Rect, f32)> {
    let [west, east, north, south] = lot.street_sides;
    if !(west || east || north || south) {
        return Vec::new();
    }
    // Sides facing a neighbouring lot draw back a little so some alleys open up.
    let mut r = lot.rect;
    let mut alley = || between(rng, (0.0, 2.0));
    if !west {
        r.x0 += alley();
    }
    if !east {
        r.x1 -= alley();
    }
    if !north {
        r.z0 += alley();
    }
    if !south {
        r.z1 -= alley();
    }
    let height = building_height(rng);
    let depth_x = between(rng, BUILDING_DEPTH).min(r.width());
    let depth_z = between(rng, BUILDING_DEPTH).min(r.depth());
    // The band of the lot along each street side, `depth` deep.
    let along_x_side = |d: f32| {
        if north {
            Rect { z1: r.z0 + d, ..r }
        } else {
            Rect { z0: r.z1 - d, ..r }
        }
    };
    let along_z_side = |d: f32| {
        if west {
            Rect { x1: r.x0 + d, ..r }
        } else {
            Rect { x0: r.x1 - d, ..r }
        }
    };
    let on_x_street = north || south;
    let on_z_street = west || east;
    match (on_x_street, on_z_street) {
        (true, true) if rng.random_bool(L_SHAPE_CHANCE) => {
            // L-shape: one wing along the x-facing street, the other along the z-facing
            // street from where the first ends, lower or equal in height.
            let wing_a = along_x_side(depth_z);
            let wing_b = along_z_side(depth_x);
            let wing_b = if north {
                Rect {
                    z0: wing_a.z1,
                    ..wing_b
                }
            } else {
                Rect {
                    z1: wing_a.z0,
                    ..wing_b
                }
            };
            let height_b = height * between(rng, (0.6, 1.0));
            let mut boxes = vec![(wing_a, height)];
            if wing_b.depth() > 1.0 {
                boxes.push((wing_b, height_b.max(BUILDING_HEIGHT.0)));
            }
            boxes
        }
        (true, true) => {
            // Corner block: covers the corner, part of each street side.
            let corner = along_x_side(depth_z);
            let corner = if west {
                Rect {
                    x1: r.x0 + (r.width() * between(rng, (0.6, 1.0))),
                    ..corner
                }
            } else {
                Rect {
                    x0: r.x1 - (r.width() * between(rng, (0.6, 1.0))),
                    ..corner
                }
            };
            vec![(corner, height)]
        }
        (true, false) => vec![(along_x_side(depth_z), height)],
        _ => vec![(along_z_side(depth_x), height)],
    }
}

/// Mostly mid-rise, now and then a tower.
fn building_height(rng: &mut ChaCha8Rng) -> f32 {
    if rng.random_bool(TOWER_CHANCE) {
        between(rng, TOWER_HEIGHT)
    } else {
        between(rng, BUILDING_HEIGHT)
    }
}

/// Trees and the odd bench on the sidewalk strip around a block: out in the open.
fn add_sidewalk_props(city: &mut City, rng: &mut ChaCha8Rng, block: Rect) {
    let inset = SIDEWALK * 0.5;
    let edges = [
        // (start, end, along x?, fixed coordinate)
        (block.x0, block.x1, true, block.z0 + inset),
        (block.x0, block.x1, true, block.z1 - inset),
        (block.z0, block.z1, false, block.x0 + inset),
        (block.z0, block.z1, false, block.x1 - inset),
    ];
    for (start, end, along_x, fixed) in edges {
        let slots = ((end - start - SIDEWALK * 2.0) / SIDEWALK_SLOT)
            .floor()
            .max(0.0) as usize;
        for s in 0..slots {
            let t = start + SIDEWALK + SIDEWALK_SLOT * (s as f32 + 0.5);
            let (x, z) = if along_x { (t, fixed) } else { (fixed, t) };
            if rng.random_bool(SIDEWALK_TREE_CHANCE) {
                city.add_tree(rng, x, z, SIDEWALK * 0.5);
            } else if rng.random_bool(SIDEWALK_BENCH_CHANCE) {
                city.add_bench(x, z, along_x);
            }
        }
    }
}

/// Trees and benches in the yards behind the buildings, where only occlusion culling
/// (not the frustum) can remove them.
fn add_courtyard_props(city: &mut City, rng: &mut ChaCha8Rng, inner: Rect, footprints: &[Rect]) {
    let area = inner.shrunk(1.5);
    let mut taken: Vec<Rect> = footprints.iter().map(|f| f.shrunk(-1.0)).collect();
    let trees = rng.random_range(2..=5);
    let benches = rng.random_range(0..=2);
    for n in 0..trees + benches {
        let is_tree = n < trees;
        let radius = if is_tree { 2.5 } else { 1.2 };
        let Some((x, z)) = free_spot(rng, area, radius, &taken) else {
            continue;
        };
        if is_tree {
            city.add_tree(rng, x, z, radius);
        } else {
            city.add_bench(x, z, rng.random_bool(0.5));
        }
        taken.push(Rect::around(x, z, radius));
    }
}

/// A point of `area` whose square of half side `radius` misses every `taken` rect, if
/// one turns up within a few tries.
fn free_spot(rng: &mut ChaCha8Rng, area: Rect, radius: f32, taken: &[Rect]) -> Option<(f32, f32)> {
    let area = area.shrunk(radius);
    if area.width() <= 0.0 || area.depth() <= 0.0 {
        return None;
    }
    (0..30).find_map(|_| {
        let x = between(rng, (area.x0, area.x1));
        let z = between(rng, (area.z0, area.z1));
        let spot = Rect::around(x, z, radius);
        (!taken.iter().any(|t| t.overlaps(spot))).then_some((x, z))
    })
}

/// Cars parked along both curbs of every street segment, plus a few driving in the
/// lanes; the centre line of every street stays clear, and so does the grid centre.
fn add_street_cars(city: &mut City, rng: &mut ChaCha8Rng, xs: &AxisLayout, zs: &AxisLayout) {
    for &street in &zs.streets {
        for &segment in &xs.blocks {
            add_segment_cars(city, rng, street, segment, true);
        }
    }
    for &street in &xs.streets {
        for &segment in &zs.blocks {
            add_segment_cars(city, rng, street, segment, false);
        }
    }
}

/// Cars on one street segment. `street` is the span across the street, `segment` the
/// span along it; `along_x` says which way the street runs.
fn add_segment_cars(
    city: &mut City,
    rng: &mut ChaCha8Rng,
    street: Span,
    segment: Span,
    along_x: bool,
) {
    let half = street.len() * 0.5;
    // Lateral offsets from the centre line: parked at the curbs, driving in the lanes.
    let lanes = [
        (-(half - 1.5), PARKED_CHANCE),
        (half - 1.5, PARKED_CHANCE),
        (-2.0, DRIVING_CHANCE),
        (2.0, DRIVING_CHANCE),
    ];
    let slots = ((segment.len() - 4.0) / PARKING_SPACING).floor().max(0.0) as usize;
    for (offset, chance) in lanes {
        for s in 0..slots {
            let along = segment.lo + 2.0 + PARKING_SPACING * (s as f32 + 0.5);
            let across = street.mid() + offset;
            let (x, z) = if along_x {
                (along, across)
            } else {
                (across, along)
            };
            if !rng.random_bool(chance) || x.hypot(z) < CLEAR_CENTRE_RADIUS {
                continue;
            }
            city.add_car(x, z, along_x);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3Swizzles;

    fn layout() -> (AxisLayout, AxisLayout) {
        city_layout(&mut ChaCha8Rng::seed_from_u64(SEED), BLOCKS_PER_SIDE)
    }

    fn normal(v: &[Vec3], tri: &[u32]) -> Vec3 {
        let [a, b, c] = [0, 1, 2].map(|k| v[tri[k] as usize]);
        (b - a).cross(c - a)
    }

    #[test]
    fn deterministic() {
        let a = demo_city();
        let b = demo_city();
        assert_eq!(a.objects.len(), b.objects.len());
        assert_eq!(a.triangle_count(), b.triangle_count());
        for (oa, ob) in a.objects.iter().zip(&b.objects) {
            assert_eq!(oa.name, ob.name);
            assert_eq!(oa.aabb, ob.aabb);
        }
        assert_eq!(a.name, "demo");
    }

    #[test]
    fn size_is_in_budget() {
        let city = demo_city();
        let count = |prefix: &str| {
            city.objects
                .iter()
                .filter(|o| o.name.starts_with(prefix))
                .count()
        };
        eprintln!(
            "demo city: {} objects ({} buildings, {} ground tiles, {} cars, {} trees, {} benches), {} triangles",
            city.objects.len(),
            count("building_"),
            count("ground_"),
            count("car_"),
            count("tree_"),
            count("bench_"),
            city.triangle_count()
        );
        assert!((2_500..=5_000).contains(&city.objects.len()));
        assert!(city.triangle_count() < 150_000);
        assert!(count("building_") > 500 && count("car_") > 300 && count("tree_") > 500);
    }

    #[test]
    fn every_object_has_triangles_and_finite_bounds() {
        let city = demo_city();
        for o in &city.objects {
            assert!(o.triangles() >= 1, "{} has no triangle", o.name);
            assert!(!o.aabb.is_empty(), "{}", o.name);
            assert!(
                o.aabb.min.is_finite() && o.aabb.max.is_finite(),
                "{}",
                o.name
            );
        }
        let heights = city
            .objects
            .iter()
            .filter(|o| o.name.starts_with("building_"))
            .map(|o| o.aabb.max.y);
        assert!(
            heights
                .clone()
                .all(|h| (BUILDING_HEIGHT.0..=TOWER_HEIGHT.1).contains(&h))
        );
    }

    #[test]
    fn buildings_stay_off_street_centre_lines() {
        let city = demo_city();
        let (xs, zs) = layout();
        for o in city
            .objects
            .iter()
            .filter(|o| o.name.starts_with("building_"))
        {
            for s in &xs.streets {
                let x = s.mid();
                assert!(
                    !(o.aabb.min.x < x && x < o.aabb.max.x),
                    "{} crosses street x = {x}",
                    o.name
                );
            }
            for s in &zs.streets {
                let z = s.mid();
                assert!(
                    !(o.aabb.min.z < z && z < o.aabb.max.z),
                    "{} crosses street z = {z}",
                    o.name
                );
            }
            // Stronger: every building stands inside one block, back from the sidewalk.
            let inside_a_block = xs.blocks.iter().any(|bx| {
                zs.blocks.iter().any(|bz| {
                    let inner = Rect::from_spans(*bx, *bz).shrunk(SIDEWALK - 1e-3);
                    o.aabb.min.x >= inner.x0
                        && o.aabb.max.x <= inner.x1
                        && o.aabb.min.z >= inner.z0
                        && o.aabb.max.z <= inner.z1
                })
            });
            assert!(inside_a_block, "{} leaves its block", o.name);
        }
    }

    #[test]
    fn grid_centre_is_open_street() {
        let city = demo_city();
        let eye = Vec3::new(0.0, 1.7, 0.0);
        let blocking: Vec<_> = city
            .objects
            .iter()
            .filter(|o| !o.name.starts_with("ground_"))
            .filter(|o| {
                let nearest = eye.xz().clamp(o.aabb.min.xz(), o.aabb.max.xz());
                nearest.distance(eye.xz()) < 5.0
            })
            .map(|o| o.name.clone())
            .collect();
        assert!(blocking.is_empty(), "{blocking:?}");
    }

    #[test]
    fn closed_shapes_face_outward() {
        let mut mesh = Mesh::default();
        mesh.add_box(Vec3::new(1.0, 2.0, 3.0), Vec3::new(2.0, 4.0, 7.0));
        let centre = Vec3::new(1.5, 3.0, 5.0);
        let mut octa = Mesh::default();
        octa.add_octahedron(centre, Vec3::new(1.0, 2.0, 1.0));
        for m in [&mesh, &octa] {
            for tri in m.indices.chunks_exact(3) {
                let n = normal(&m.vertices, tri);
                let to_face = m.vertices[tri[0] as usize] - centre;
                assert!(n.dot(to_face) > 0.0, "inward triangle {tri:?}");
            }
        }
        assert_eq!(mesh.indices.len(), 36);
        assert_eq!(octa.indices.len(), 24);
        let mut ground = Mesh::default();
        ground.add_ground_quad(Rect::around(0.0, 0.0, 1.0));
        for tri in ground.indices.chunks_exact(3) {
            assert!(normal(&ground.vertices, tri).y > 0.0);
        }
    }
}

#[cfg(test)]
mod sized_tests {
    use super::*;

    #[test]
    fn sized_12_is_the_demo_city() {
        let (a, b) = (demo_city(), demo_city_sized(12));
        assert_eq!(a.objects.len(), b.objects.len());
        assert!(
            a.objects
                .iter()
                .zip(&b.objects)
                .all(|(x, y)| x.name == y.name && x.aabb == y.aabb)
        );
        assert!(demo_city_sized(2).objects.len() < a.objects.len());
    }
}
