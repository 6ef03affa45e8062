//! The HOM algorithm, independent of where it runs (DESIGN.md §4).
//!
//! Everything here is plain Rust and is the CPU reference of the GPU passes in
//! `gpu/`: each function has a WGSL twin with the same name and the same arithmetic,
//! and tests feed both the same input. It also runs as the fallback when no GPU
//! adapter exists.
//!
//! - [`raster`]: a small rasterizer with the GPU's sampling rules (pixel centres,
//!   top-left fill rule, near/far clipping, perspective-correct view depth).
//! - [`pyramid`]: level layout and the 2×2 average (opacity) / max (depth) reduction.
//! - [`deb`]: depth estimation buffers from occluder boxes (plane, tiles).
//! - [`test`]: the per-object overlap + depth test, and the HZB test.

pub mod deb;
pub mod pyramid;
pub mod raster;
pub mod test;

/// Relative depth margin: an occluder at view depth `d` hides an object whose nearest
/// depth is `n` only if `d * (1 + DEPTH_MARGIN) < n`. It absorbs float error between
/// interpolated depths, box-corner depths and the oracle's depth buffer (all far
/// below 1e-5 relative), so ties are never culled.
pub const DEPTH_MARGIN: f32 = 1e-4;

/// Most pyramid levels homcull builds (a 8192-pixel side needs 14).
pub const MAX_LEVELS: usize = 16;

/// Opacity threshold per level: `O_0` at level 0 and `O_{k+1} = (3 + O_k) / 4` above,
/// so that a texel passing at level k+1 can hide at most as many uncovered level-0
/// pixels as `O_0` allows (seed 000, "Approximatives Culling"). `O_0 = 1` gives 1
/// everywhere: conservative culling.
pub fn level_thresholds(o0: f32, levels: usize) -> Vec<f32> {
    let mut t = Vec::with_capacity(levels);
    let mut o = o0;
    for _ in 0..levels {
        t.push(o);
        o = (3.0 + o) / 4.0;
    }
    t
}

/// Whether an occluder depth lies safely in front of an object's nearest depth.
#[inline]
pub fn in_front(occluder_depth: f32, object_near: f32) -> bool {
    occluder_depth * (1.0 + DEPTH_MARGIN) < object_near
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thresholds_propagate() {
        assert_eq!(level_thresholds(1.0, 5), vec![1.0; 5]);
        let t = level_thresholds(0.8, 3);
        assert!((t[1] - 0.95).abs() < 1e-6 && (t[2] - 0.9875).abs() < 1e-6);
    }
}
