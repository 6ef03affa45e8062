use glam::Vec3;
use rand::{Rng, SeedableRng};

use super::*;
use crate::camera::look_at;
use crate::native::map::OcclusionMap;
use crate::native::span::span_triangles;
use crate::native::test_triangles::random_triangles;

fn draw_both(cam: &Camera, tris: &[[Vec3; 3]]) -> (MaskedMap, OcclusionMap) {
    let mut masked = MaskedMap::default();
    masked.reset(cam.width, cam.height);
    for &tri in tris {
        span_triangles(cam, tri, |t| {
            masked.draw_triangle(t);
            true
        });
    }
    masked.build_pyramid();
    let mut exact = OcclusionMap::default();
    exact.reset(cam.width, cam.height);
    exact.draw(cam, tris.iter().copied());
    (masked, exact)
}

#[test]
fn tile_bounds_never_exceed_the_per_pixel_map_and_exact_tiles_equal_it() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(41);
    // A width and height that are not multiples of the tile.
    for (w, h) in [(203u32, 150u32), (96, 64), (37, 11)] {
        let cam = look_at(Vec3::new(0.0, 0.5, 8.0), Vec3::ZERO, w, h);
        let tris = random_triangles(&mut rng, 150);
        let (mut masked, exact) = draw_both(&cam, &tris);
        let mut bounded = 0;
        for y in 0..h {
            for x in 0..w {
                let want = exact.pixels()[(y * w + x) as usize];
                let bound = masked.bound_at(x, y);
                // The bound holds under the plane; the per-pixel map is the plane
                // stepped in f32 (within `LANE_SLACK`, 4e-6, of it).
                assert!(
                    bound as f64 <= want as f64 * (1.0 + 1e-5),
                    "pixel ({x}, {y}): bound {bound} above {want}"
                );
                bounded += (bound > 0.0) as u32;
                let got = masked.exact_at(x, y);
                assert_eq!(got > 0.0, want > 0.0, "coverage of ({x}, {y})");
                if want > 0.0 {
                    assert!(
                        (got / want - 1.0).abs() < 2e-6,
                        "({x}, {y}): {got} vs {want}"
                    );
                }
            }
        }
        // The bounds say something: most covered pixels have one.
        let covered = exact.pixels().iter().filter(|&&v| v > 0.0).count() as u32;
        assert!(
            bounded * 10 > covered * 8,
            "{w}x{h}: {bounded} of {covered} covered pixels bounded"
        );
    }
}

#[test]
fn rects_hidden_by_the_tiles_are_hidden_at_every_pixel() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(42);
    let (w, h) = (203u32, 150u32);
    let cam = look_at(Vec3::new(0.0, 0.5, 8.0), Vec3::ZERO, w, h);
    let tris = random_triangles(&mut rng, 300);
    let (masked, exact) = draw_both(&cam, &tris);
    let (mut hidden, mut by_pixels) = (0, 0);
    for _ in 0..6000 {
        let x0 = rng.random_range(0..w);
        let y0 = rng.random_range(0..h);
        let r = ScreenRect {
            x0,
            y0,
            x1: (x0 + rng.random_range(1..90)).min(w),
            y1: (y0 + rng.random_range(1..60)).min(h),
            near: 1.0,
            far: 2.0,
        };
        let t = [0.0, 0.05, 0.1, 0.125, 0.15][rng.random_range(0..5)];
        let want =
            (r.y0..r.y1).all(|y| (r.x0..r.x1).all(|x| exact.pixels()[(y * w + x) as usize] > t));
        let got = masked.rect_hidden(&r, t);
        assert!(
            !got || want,
            "{r:?} at {t}: hidden by the tiles, not by the pixels"
        );
        // And the same as the bounds per pixel say (the pyramid loses nothing).
        let by_bounds = (r.y0..r.y1).all(|y| (r.x0..r.x1).all(|x| masked.bound_at(x, y) > t));
        assert_eq!(got, by_bounds, "{r:?} at {t}");
        hidden += got as u32;
        by_pixels += want as u32;
    }
    assert!(
        hidden > 300,
        "only {hidden} hidden rects: the test says little"
    );
    assert!(
        hidden * 10 > by_pixels * 7,
        "tiles hide {hidden} of the {by_pixels} rects the pixels hide"
    );
}

#[test]
fn merging_keeps_every_pixels_bound_below_its_nearest_fragment() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(43);
    for round in 0..3000 {
        // Some tiles cut by the viewport's edges.
        let outside: [u32; H] = if round % 3 == 0 {
            let cols = rng.random_range(1..=TILE_W);
            let rows = rng.random_range(1..=TILE_H) as usize;
            std::array::from_fn(|r| {
                if r >= rows {
                    !0
                } else if cols == TILE_W {
                    0
                } else {
                    !0u32 << cols
                }
            })
        } else {
            [0; H]
        };
        let mut tile = Tile::default();
        let mut nearest = [[0.0f32; TILE_W as usize]; H];
        for _ in 0..rng.random_range(1..12) {
            let cov: [u32; H] = std::array::from_fn(|r| {
                let m = match rng.random_range(0..4) {
                    0 => !0,
                    1 => 0,
                    _ => span_mask(rng.random_range(-4..36), rng.random_range(-4..36)),
                };
                m & !outside[r]
            });
            // One bound for the whole tile, or one per row.
            let one = rng.random_range(0.01f32..1.0);
            let z: [f32; H] = std::array::from_fn(|_| {
                if round % 2 == 0 {
                    one
                } else {
                    rng.random_range(0.01f32..1.0)
                }
            });
            merge(&mut tile, &cov, &z, &outside);
            for r in 0..H {
                for k in 0..TILE_W {
                    if cov[r] >> k & 1 == 1 {
                        nearest[r][k as usize] = nearest[r][k as usize].max(z[r]);
                    }
                }
            }
            for r in 0..H {
                for k in 0..TILE_W {
                    if outside[r] >> k & 1 == 0 {
                        let b = tile.bound_at(r, k);
                        assert!(b <= nearest[r][k as usize], "round {round}: {tile:?}");
                    }
                }
            }
            for r in 0..H {
                assert!((tile.mask[r] != 0) == (tile.layer[r] > 0.0), "{tile:?}");
                assert!(tile.layer[r] == 0.0 || tile.layer[r] > tile.base[r]);
            }
        }
    }
    // One triangle over the whole tile makes the base.
    let mut tile = Tile::default();
    merge(&mut tile, &[!0; H], &[0.5; H], &[0; H]);
    assert_eq!((tile.base, tile.layer), ([0.5; H], [0.0; H]));
}
