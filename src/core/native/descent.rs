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

use crate::core::camera::MAX_VIEWPORT_SIDE;

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

/// A map's answer per texel ([`rect_hidden`]). A trait rather than a closure: its
/// method is inlined wherever the descent is, so that it runs at the caller's SIMD
/// level (a closure was left out of line, compiled for the baseline CPU).
pub trait TexelTest {
    /// The answer for texel `(x, y)` of level `l`.
    fn texel(&mut self, l: usize, x: u32, y: u32) -> Texel;
}

/// Closures answer too (the tests').
impl<F: FnMut(usize, u32, u32) -> Texel> TexelTest for F {
    #[inline(always)]
    fn texel(&mut self, l: usize, x: u32, y: u32) -> Texel {
        self(l, x, y)
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

/// Whether every texel of the rect whose finest texels are `(tx0, ty0)..=(tx1, ty1)`
/// is hidden by `texel.texel(level, x, y)`, over `levels` levels (0 the finest; texel
/// `(x, y)` of level `l` covers finest texels `x << l ..` and `y << l ..`). Stops at
/// the first texel answered [`Texel::Visible`].
#[inline(always)]
pub fn rect_hidden(
    (tx0, ty0, tx1, ty1): (u32, u32, u32, u32),
    levels: usize,
    mut texel: impl TexelTest,
) -> bool {
    debug_assert!(levels <= MAX_DESCENT_LEVELS && tx1 <= COORD_MASK && ty1 <= COORD_MASK);
    let mut k = 0;
    while k + 1 < levels && ((tx1 >> k) - (tx0 >> k) > 1 || (ty1 >> k) - (ty0 >> k) > 1) {
        k += 1;
    }
    let mut stack = [0u32; 4 + 3 * MAX_DESCENT_LEVELS];
    let mut top = 0;
    for y in (ty0 >> k)..=(ty1 >> k) {
        for x in (tx0 >> k)..=(tx1 >> k) {
            stack[top] = pack(k, x, y);
            top += 1;
        }
    }
    while top > 0 {
        top -= 1;
        let (l, x, y) = unpack(stack[top]);
        match texel.texel(l, x, y) {
            Texel::Hidden => continue,
            Texel::Visible => return false,
            Texel::Split => {}
        }
        debug_assert!(l > 0, "the finest level settles every texel");
        let c = l - 1;
        for cy in (2 * y).max(ty0 >> c)..=(2 * y + 1).min(ty1 >> c) {
            for cx in (2 * x).max(tx0 >> c)..=(2 * x + 1).min(tx1 >> c) {
                stack[top] = pack(c, cx, cy);
                top += 1;
            }
        }
    }
    true
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

    /// A one-level map of `w`×`h` texels, hidden where `hidden` says: the descent
    /// answers whether all the rect's texels are.
    #[test]
    fn descent_reaches_every_finest_texel_of_the_rect() {
        // Levels over a 10×7 grid of finest texels; a texel of level l is hidden iff
        // all finest texels under it (inside the grid) are, and split otherwise.
        let (w, h) = (10u32, 7u32);
        let holes = [(3u32, 4u32), (9, 0)];
        let finest_hidden = |x: u32, y: u32| !holes.contains(&(x, y));
        let levels = 5;
        for tx0 in 0..w {
            for tx1 in tx0..w {
                for ty0 in 0..h {
                    for ty1 in ty0..h {
                        let mut seen = Vec::new();
                        let got = rect_hidden((tx0, ty0, tx1, ty1), levels, |l, x, y| {
                            if l == 0 {
                                seen.push((x, y));
                                return if finest_hidden(x, y) {
                                    Texel::Hidden
                                } else {
                                    Texel::Visible
                                };
                            }
                            Texel::Split
                        });
                        let want = (tx0..=tx1).all(|x| (ty0..=ty1).all(|y| finest_hidden(x, y)));
                        assert_eq!(got, want, "rect {tx0},{ty0}..{tx1},{ty1}");
                        if want {
                            seen.sort();
                            let all: Vec<_> = (tx0..=tx1)
                                .flat_map(|x| (ty0..=ty1).map(move |y| (x, y)))
                                .collect();
                            assert_eq!(seen, all, "each finest texel once");
                        }
                    }
                }
            }
        }
    }
}
