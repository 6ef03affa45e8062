//! Tests of the occlusion map: against the reference depth map, its rect test against
//! every pixel, reused from pose to pose, drawn band by band in parallel and drawn
//! again on bounds it left, and its rows test against every lane.

use super::*;
use crate::camera::look_at;
use crate::native::span::LANES;
use crate::native::test_triangles::random_triangles;
use crate::reference::raster::raster_depth;
use rand::{Rng, SeedableRng};

#[test]
fn map_matches_the_reference_depth_map_and_rects_test_every_pixel() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
    let (w, h) = (83u32, 45u32);
    let cam = look_at(Vec3::new(0.0, 0.5, 8.0), Vec3::ZERO, w, h);
    let tris: Vec<[Vec3; 3]> = (0..120)
        .map(|_| {
            let c = Vec3::new(
                rng.random_range(-4.0..4.0),
                rng.random_range(-2.0..2.0),
                rng.random_range(-6.0..3.0),
            );
            [0, 1, 2].map(|_| {
                c + Vec3::new(
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-1.0..1.0),
                )
            })
        })
        .collect();
    let mut reference = vec![0.0; (w * h) as usize];
    raster_depth(&cam, tris.iter().copied(), &mut reference);
    let mut map = OcclusionMap::default();
    map.reset(w, h);
    map.draw(&cam, tris.iter().copied());
    for (i, (&r, &m)) in reference.iter().zip(map.pixels()).enumerate() {
        assert_eq!(r > 0.0, m > 0.0, "coverage of pixel {i}");
        if r > 0.0 {
            assert!(
                (r * m - 1.0).abs() < 2e-6,
                "depth of pixel {i}: {r} vs {}",
                1.0 / m
            );
        }
    }
    // Drawing left the map bounded, as building the bounds from scratch would.
    let (far, near) = (map.far.clone(), map.near.clone());
    map.build_bounds();
    assert!(far == map.far && near == map.near, "bounds left by drawing");
    let mut hidden = 0;
    for _ in 0..4000 {
        let x0 = rng.random_range(0..w);
        let y0 = rng.random_range(0..h);
        let r = ScreenRect {
            x0,
            y0,
            x1: (x0 + rng.random_range(1..16)).min(w),
            y1: (y0 + rng.random_range(1..12)).min(h),
            near: 1.0,
            far: 2.0,
        };
        let t = [0.0, 0.1, 0.125, 0.15][rng.random_range(0..4)];
        let want =
            (r.y0..r.y1).all(|y| (r.x0..r.x1).all(|x| map.pixels()[(y * w + x) as usize] > t));
        assert_eq!(map.rect_hidden(&r, t), want, "{r:?} at {t}");
        hidden += want as u32;
    }
    assert!(
        hidden > 100,
        "only {hidden} hidden rects: the test says little"
    );
}

#[test]
fn a_pose_without_occluders_keeps_no_bounds_of_the_pose_before() {
    use crate::scene::SceneBuilder;
    let mut b = SceneBuilder::default();
    let v = [
        Vec3::new(-5.0, -5.0, 0.0),
        Vec3::new(5.0, -5.0, 0.0),
        Vec3::new(5.0, 5.0, 0.0),
        Vec3::new(-5.0, 5.0, 0.0),
    ];
    b.push("wall".into(), &v, &[0, 1, 2, 0, 2, 3], None);
    let scene = b.build("t");
    let (w, h) = (64u32, 48u32);
    let cam = look_at(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, w, h);
    let mut map = OcclusionMap::default();
    let whole = ScreenRect {
        x0: 0,
        y0: 0,
        x1: w,
        y1: h,
        near: 1.0,
        far: 2.0,
    };
    map.reset(w, h);
    map.draw_occluders(&scene, &cam, &[0]);
    assert!(map.rect_hidden(&whole, 0.0), "the wall covers the view");
    // The next pose on the same map has no occluders: nothing is covered.
    map.reset(w, h);
    map.draw_occluders(&scene, &cam, &[]);
    assert!(!map.rect_hidden(&whole, 0.0), "bounds of the pose before");
    assert!(map.pixels().iter().all(|&v| v == 0.0));
}

#[test]
fn a_map_reused_from_pose_to_pose_ends_as_a_fresh_one() {
    use crate::scene::SceneBuilder;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(33);
    let mut b = SceneBuilder::default();
    for k in 0..40 {
        let c = Vec3::new(
            rng.random_range(-8.0..8.0),
            rng.random_range(-3.0..3.0),
            rng.random_range(-12.0..2.0),
        );
        let s = rng.random_range(0.3..3.0);
        let v: Vec<Vec3> = (0..4)
            .map(|_| c + Vec3::new(rng.random_range(-s..s), rng.random_range(-s..s), 0.3))
            .collect();
        b.push(
            format!("o{k}"),
            &v,
            &[0, 1, 2, 0, 2, 3, 2, 1, 0, 3, 2, 0],
            None,
        );
    }
    let scene = b.build("t");
    let mut reused = OcclusionMap::default();
    for pose in 0..60 {
        // Two viewport sizes, any number of occluders (none included).
        let (w, h) = [(96u32, 54u32), (61, 37)][rng.random_range(0..2)];
        let eye = Vec3::new(rng.random_range(-2.0..2.0), 0.0, rng.random_range(5.0..9.0));
        let cam = look_at(eye, Vec3::new(0.0, 0.0, -4.0), w, h);
        let n = [0, 1, 5, 40][rng.random_range(0..4)];
        let mut ids: Vec<u32> = (0..40).collect();
        rand::seq::SliceRandom::shuffle(&mut ids[..], &mut rng);
        ids.truncate(n);
        let mut fresh = OcclusionMap::default();
        for map in [&mut reused, &mut fresh] {
            map.reset(w, h);
            map.draw_occluders(&scene, &cam, &ids);
        }
        assert!(reused.pixels() == fresh.pixels(), "pose {pose}: pixels");
        assert!(
            reused.far == fresh.far && reused.near == fresh.near,
            "pose {pose}: bounds"
        );
    }
}

#[test]
fn drawing_bands_in_parallel_gives_the_same_map_and_bounds() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(21);
    // A width that is not a multiple of the lanes and a last band cut short.
    let (w, h) = (203u32, 150u32);
    let cam = look_at(Vec3::new(0.0, 0.5, 8.0), Vec3::ZERO, w, h);
    let first = random_triangles(&mut rng, 150);
    let second = random_triangles(&mut rng, 10);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap();
    let maps = [false, true].map(|parallel| {
        let mut map = OcclusionMap::default();
        map.reset(w, h);
        map.bands_in_parallel = parallel;
        // A second draw on the bounded map leaves the bands it misses alone.
        pool.install(|| {
            map.draw(&cam, first.iter().copied());
            map.draw(&cam, second.iter().copied());
        });
        map
    });
    let [seq, par] = &maps;
    let covered = seq.pixels().iter().filter(|&&v| v > 0.0).count();
    assert!(covered > 1000, "only {covered} pixels covered");
    assert!(seq.pixels() == par.pixels(), "pixels differ");
    assert!(seq.far == par.far && seq.near == par.near, "bounds differ");
    // The second draw bounded only the tiles it reached: the bounds are those
    // built from scratch.
    let mut rebuilt = OcclusionMap::default();
    rebuilt.reset(w, h);
    rebuilt.inv_w.clone_from(&seq.inv_w);
    rebuilt.build_bounds();
    assert!(
        seq.far == rebuilt.far && seq.near == rebuilt.near,
        "stale bounds"
    );
}

#[test]
fn rows_the_bounds_hide_hide_every_lane_of_their_spans() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let (w, h) = (160u32, 96u32);
    let cam = look_at(Vec3::new(0.0, 0.5, 8.0), Vec3::ZERO, w, h);
    let mut map = OcclusionMap::default();
    map.reset(w, h);
    map.draw(&cam, random_triangles(&mut rng, 100).into_iter());
    let margin = 1e-5;
    let (mut blocks, mut hidden) = (0, 0);
    for tri in random_triangles(&mut rng, 300) {
        crate::native::span::span_triangles(&cam, tri, |t| {
            let (y0, y1) = (t.tri.y0, t.tri.y1);
            for block in (y0 - y0 % ROWS as u32..=y1).step_by(ROWS) {
                let rows = t.row_block(block, (y0, y1));
                let by_bounds = map.rows_hidden(t, block, rows, margin);
                let (first, last) = rows;
                let (mut lanes_hidden, mut any) = (true, false);
                for r in 0..ROWS {
                    if first[r] > last[r] {
                        continue;
                    }
                    any = true;
                    let y = block + r as u32;
                    let s = t.span(y, first[r] as u32, last[r] as u32);
                    let nearest = t.nearest_in((first[r] as u32, last[r] as u32), (y, y)) as f32;
                    let mut lanes = s.lanes_from(0);
                    for i in (0..s.pixels()).step_by(LANES) {
                        let v = lanes.next_chunk();
                        for (k, &v) in v.iter().enumerate().take(s.pixels() - i) {
                            assert!(v <= nearest, "a lane above the rect's bound");
                            let x = (s.x0 as usize + i + k) as u32;
                            let m = map.pixels()[(y * w + x) as usize];
                            lanes_hidden &= m > (1.0 + margin as f32) * v;
                        }
                    }
                }
                blocks += any as u32;
                if by_bounds {
                    assert!(
                        lanes_hidden,
                        "rows {block}.. called hidden with a lane in front"
                    );
                    hidden += 1;
                }
            }
            true
        });
    }
    assert!(
        blocks > 1000 && hidden > 50,
        "{hidden} of {blocks} blocks hidden: the test says little"
    );
}
