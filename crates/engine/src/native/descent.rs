//! The quadtree descent both occlusion maps answer a screen rect with: from the
//! coarsest level whose texels the rect's tiles span at most 2×2 of, each texel the
//! rect overlaps is settled by its bounds (every pixel under it hides, or none does)
//! or split into its children the rect overlaps, down to the finest level, where the
//! map settles a texel by itself. The rect is hidden when every texel it reaches is.
//!
//! The pending texels live in a fixed stack of packed words: a descent leaves at most
//! three siblings per level behind it, plus the four it starts from. Packed, the stack
//! is 232 bytes whose zeroing is a few vector stores; as `(u8, u32, u32)` tuples it was
//! 700 bytes zeroed byte by byte, a sixth of a box test.

use crate::camera::{MAX_VIEWPORT_SIDE, ScreenRect};

/// What a map answers for one texel of the descent.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Texel {
    /// Every pixel of the rect under the texel hides.
    Hidden,
    /// Some pixel of the rect under the texel does not (or may not).
    Visible,
    /// The bounds do not settle it: test its children (never answered at level 0).
    Split,
}

/// A map's answer per texel for a rect ([`rect_hidden`]), implemented by each map. A
/// trait rather than a closure: its method is inlined wherever the descent is, so that
/// it runs at the caller's SIMD level (a closure was left out of line, compiled for
/// the baseline CPU).
pub trait TexelTest {
    /// The answer for texel `(x, y)` of level `l`: whether every pixel of `r` under it
    /// holds a `1/w` above `t`.
    fn texel(&self, r: &ScreenRect, t: f32, l: usize, x: u32, y: u32) -> Texel;

    /// Whether the bounds alone hide every texel `x0..=x1 × y0..=y1` of level `l` (at
    /// most 2×2): one branch for the common case of a block hidden whole, before its
    /// texels are visited one by one. `false` whenever unsure (the default).
    #[inline(always)]
    fn block_hidden(&self, _t: f32, _l: usize, _block: (u32, u32, u32, u32)) -> bool {
        false
    }
}

/// Most levels a descent may have (a map's finest level and the quadtree over it).
pub const MAX_DESCENT_LEVELS: usize = 20;

/// Bits of a packed texel coordinate: tile indices stay below the largest viewport.
const COORD_BITS: u32 = 13;
const _: () = assert!(MAX_VIEWPORT_SIDE <= 1 << COORD_BITS);
const _: () = assert!(MAX_DESCENT_LEVELS < 1 << (32 - 2 * COORD_BITS));
const COORD_MASK: u32 = (1 << COORD_BITS) - 1;

#[inline(always)]
fn pack(level: usize, x: u32, y: u32) -> u32 {
    (level as u32) << (2 * COORD_BITS) | y << COORD_BITS | x
}

#[inline(always)]
fn unpack(v: u32) -> (usize, u32, u32) {
    (
        (v >> (2 * COORD_BITS)) as usize,
        v & COORD_MASK,
        v >> COORD_BITS & COORD_MASK,
    )
}

/// Whether `map` hides `r` below `t` (every pixel above it), where `r`'s finest
/// texels are `(tx0, ty0)..=(tx1, ty1)`, over `levels` levels (0 the finest; texel
/// `(x, y)` of level `l` covers finest texels `x << l ..` and `y << l ..`). Stops at
/// the first texel answered [`Texel::Visible`].
#[inline(always)]
pub fn rect_hidden(
    map: &impl TexelTest,
    r: &ScreenRect,
    t: f32,
    (tx0, ty0, tx1, ty1): (u32, u32, u32, u32),
    levels: usize,
) -> bool {
    debug_assert!(levels <= MAX_DESCENT_LEVELS && tx1 <= COORD_MASK && ty1 <= COORD_MASK);
    let k = start_level(tx0, tx1)
        .max(start_level(ty0, ty1))
        .min(levels.saturating_sub(1));
    let start = (tx0 >> k, ty0 >> k, tx1 >> k, ty1 >> k);
    // `block_hidden` reads a block's corners: it must be at most 2×2 (the coarsest
    // level is one texel, so the cap on `k` never leaves a wider one).
    debug_assert!(start.2 - start.0 <= 1 && start.3 - start.1 <= 1);
    if map.block_hidden(t, k, start) {
        return true;
    }
    let mut stack = [0u32; 4 + 3 * MAX_DESCENT_LEVELS];
    let mut top = 0;
    for y in start.1..=start.3 {
        for x in start.0..=start.2 {
            stack[top] = pack(k, x, y);
            top += 1;
        }
    }
    while top > 0 {
        top -= 1;
        let (l, x, y) = unpack(stack[top]);
        match map.texel(r, t, l, x, y) {
            Texel::Hidden => continue,
            Texel::Visible => return false,
            Texel::Split => {}
        }
        debug_assert!(l > 0, "the finest level settles every texel");
        let c = l - 1;
        let children = (
            (2 * x).max(tx0 >> c),
            (2 * y).max(ty0 >> c),
            (2 * x + 1).min(tx1 >> c),
            (2 * y + 1).min(ty1 >> c),
        );
        if map.block_hidden(t, c, children) {
            continue;
        }
        for cy in children.1..=children.3 {
            for cx in children.0..=children.2 {
                stack[top] = pack(c, cx, cy);
                top += 1;
            }
        }
    }
    true
}

/// The finest level `k` at which finest texels `t0..=t1` (along one axis) span at most
/// two texels: `(t1 >> k) − (t0 >> k) ≤ 1`. Their distance `d` is below `2^(b+1)` for
/// its bit length `b + 1`, so level `b + 1` always does and level `b` may: one test
/// instead of a loop over the levels (a tenth of a box test as a loop).
#[inline(always)]
fn start_level(t0: u32, t1: u32) -> usize {
    let b = (u32::BITS - (t1 - t0).leading_zeros()).saturating_sub(1);
    (b + u32::from((t1 >> b) - (t0 >> b) > 1)) as usize
}

/// The answer of a texel from its bounds on `1/w` under it, for a rect hidden where
/// every pixel holds more than `t`.
#[inline(always)]
pub fn by_bounds(far: f32, near: f32, t: f32) -> Texel {
    if far > t {
        Texel::Hidden
    } else if near <= t {
        Texel::Visible
    } else {
        Texel::Split
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_start_level_is_the_finest_spanning_at_most_two_texels() {
        for t0 in 0..300u32 {
            for t1 in t0..t0 + 600 {
                let finest = (0..).find(|&k| (t1 >> k) - (t0 >> k) <= 1).unwrap();
                assert_eq!(start_level(t0, t1), finest, "{t0}..={t1}");
            }
        }
        assert_eq!(start_level(0, 1023), 9);
    }

    #[test]
    fn packing_round_trips_the_largest_coordinates() {
        let m = MAX_VIEWPORT_SIDE - 1;
        for (l, x, y) in [
            (0, 0, 0),
            (MAX_DESCENT_LEVELS - 1, m, m),
            (3, m, 0),
            (7, 1, m),
        ] {
            assert_eq!(unpack(pack(l, x, y)), (l, x, y));
        }
    }

    /// Finest texels hidden but for some holes, every coarser texel split: records
    /// which finest texels the descent asks about.
    struct Holes {
        holes: [(u32, u32); 2],
        seen: std::cell::RefCell<Vec<(u32, u32)>>,
    }

    impl TexelTest for Holes {
        fn texel(&self, _: &ScreenRect, _: f32, l: usize, x: u32, y: u32) -> Texel {
            if l > 0 {
                return Texel::Split;
            }
            self.seen.borrow_mut().push((x, y));
            if self.holes.contains(&(x, y)) {
                Texel::Visible
            } else {
                Texel::Hidden
            }
        }
    }

    /// The descent answers whether all the rect's finest texels are hidden, and when
    /// they are it has asked about each of them once.
    #[test]
    fn descent_reaches_every_finest_texel_of_the_rect() {
        let (w, h) = (10u32, 7u32);
        let map = Holes {
            holes: [(3, 4), (9, 0)],
            seen: Default::default(),
        };
        let r = ScreenRect {
            x0: 0,
            y0: 0,
            x1: 1,
            y1: 1,
            near: 1.0,
            far: 1.0,
        };
        let levels = 5;
        for tx0 in 0..w {
            for tx1 in tx0..w {
                for ty0 in 0..h {
                    for ty1 in ty0..h {
                        map.seen.borrow_mut().clear();
                        let got = rect_hidden(&map, &r, 0.0, (tx0, ty0, tx1, ty1), levels);
                        let all: Vec<_> = (tx0..=tx1)
                            .flat_map(|x| (ty0..=ty1).map(move |y| (x, y)))
                            .collect();
                        let want = all.iter().all(|c| !map.holes.contains(c));
                        assert_eq!(got, want, "rect {tx0},{ty0}..{tx1},{ty1}");
                        if want {
                            let mut seen = map.seen.borrow().clone();
                            seen.sort();
                            assert_eq!(seen, all, "each finest texel once");
                        }
                    }
                }
            }
        }
    }
}
