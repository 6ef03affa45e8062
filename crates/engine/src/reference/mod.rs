//! The HOM algorithm on the CPU, pass by pass: the reference backend (the oracle twin).
//!
//! Everything here is plain Rust and is the CPU twin of a GPU pass in `gpu/`, named
//! alike (`reference/refine.rs` beside `gpu/refine.rs`): each has a WGSL twin with the same
//! arithmetic, and tests feed both the same input. [`ReferenceBackend`] runs them
//! behind the `Culler` seam, as the test oracle of the GPU and native backends (no command serves with it).
//!
//! - [`raster`]: a small rasterizer with the GPU's sampling rules (pixel centres,
//!   top-left fill rule, near/far clipping, perspective-correct view depth).
//! - [`pyramid`]: level layout and the 2×2 average (opacity) / max (depth) reduction.
//! - [`test`]: the per-object overlap + depth test, and the HZB test.
//! - [`refine`]: the per-pixel re-test of the box test's survivors.
//! - [`oracle`]: the exact ID-buffer oracle.
//! - [`backend`]: the reference backend itself, [`ReferenceBackend`].

pub mod backend;
pub mod oracle;
pub mod pyramid;
pub mod raster;
pub mod refine;
pub mod test;

pub use backend::ReferenceBackend;

use crate::scene::Scene;

/// The triangles of the objects `ids`, each with its object's ID, as corner triples.
pub fn triangles_of<'a>(
    scene: &'a Scene,
    ids: &'a [u32],
) -> impl Iterator<Item = (u32, [glam::Vec3; 3])> + 'a {
    ids.iter().flat_map(move |&id| {
        scene
            .corners_of(&scene.objects[id as usize])
            .map(move |t| (id, t))
    })
}

/// Most pyramid levels homcull builds (a 8192-pixel side needs 14).
pub const MAX_LEVELS: usize = 16;

/// Opacity threshold per level: `O_0` at level 0 and `O_{k+1} = (3 + O_k) / 4` above,
/// so that a texel passing at level k+1 can hide at most as many uncovered level-0
/// pixels as `O_0` allows (Zhang et al. 1997, approximate culling). `O_0 = 1` gives 1
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
