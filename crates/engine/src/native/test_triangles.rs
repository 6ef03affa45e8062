//! Random world triangles for the tests of the native maps: scattered in front of a
//! camera at (0, 0.5, 8) looking at the origin, of sizes from a tenth of a unit to a
//! few units, so that a viewport sees small, large and overlapping ones.

use glam::Vec3;
use rand::Rng;

/// `n` random triangles (each: a centre, a size, three corners around it).
pub fn random_triangles(rng: &mut impl Rng, n: usize) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|_| {
            let c = Vec3::new(
                rng.random_range(-6.0..6.0),
                rng.random_range(-4.0..4.0),
                rng.random_range(-6.0..3.0),
            );
            let s = rng.random_range(0.1..4.0);
            [0, 1, 2].map(|_| {
                c + Vec3::new(
                    rng.random_range(-s..s),
                    rng.random_range(-s..s),
                    rng.random_range(-1.0..1.0),
                )
            })
        })
        .collect()
}
