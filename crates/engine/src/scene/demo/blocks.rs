//! What fills the demo city: the ground and streets, each block's lots and buildings
//! (courtyards behind them), and the props on sidewalks, in courtyards and on streets.

use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::mesh::{City, Mesh, Rect};
use super::*;

/// Ground tiles: one quad per block, per street segment between crossings, and per
/// crossing, so the ground is many small objects rather than one box holding the city.
pub(super) fn add_ground(city: &mut City, xs: &AxisLayout, zs: &AxisLayout) {
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
pub(super) fn add_block(
    city: &mut City,
    rng: &mut ChaCha8Rng,
    (bx, bz): (usize, usize),
    block: Rect,
) {
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
pub(super) struct Lot {
    pub(super) rect: Rect,
    pub(super) street_sides: [bool; 4],
}

/// Cuts the buildable part of a block into 2×2 to 3×3 lots with jittered borders.
pub(super) fn split_into_lots(rng: &mut ChaCha8Rng, inner: Rect) -> Vec<Lot> {
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
pub(super) fn jittered_cuts(rng: &mut ChaCha8Rng, lo: f32, hi: f32, n: usize) -> Vec<f32> {
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
pub(super) fn building_boxes(rng: &mut ChaCha8Rng, lot: &Lot) -> Vec<(Rect, f32)> {
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
pub(super) fn building_height(rng: &mut ChaCha8Rng) -> f32 {
    if rng.random_bool(TOWER_CHANCE) {
        between(rng, TOWER_HEIGHT)
    } else {
        between(rng, BUILDING_HEIGHT)
    }
}

/// Trees and the odd bench on the sidewalk strip around a block: out in the open.
pub(super) fn add_sidewalk_props(city: &mut City, rng: &mut ChaCha8Rng, block: Rect) {
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
pub(super) fn add_courtyard_props(
    city: &mut City,
    rng: &mut ChaCha8Rng,
    inner: Rect,
    footprints: &[Rect],
) {
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
pub(super) fn free_spot(
    rng: &mut ChaCha8Rng,
    area: Rect,
    radius: f32,
    taken: &[Rect],
) -> Option<(f32, f32)> {
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
pub(super) fn add_street_cars(
    city: &mut City,
    rng: &mut ChaCha8Rng,
    xs: &AxisLayout,
    zs: &AxisLayout,
) {
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
pub(super) fn add_segment_cars(
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
