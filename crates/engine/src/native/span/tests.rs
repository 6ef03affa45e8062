use super::*;
use crate::camera::look_at;
use crate::reference::raster::raster_triangle;
use rand::{Rng, SeedableRng};

/// Every covered pixel and its depth, by spans.
fn by_spans(cam: &Camera, tri: [Vec3; 3]) -> Vec<(u32, u32, f32)> {
    let mut out = Vec::new();
    span_triangles(cam, tri, |t| {
        t.spans((0, cam.height - 1), |y, s| {
            for i in 0..s.pixels() {
                let inv_w = s.lanes(i)[0];
                out.push((s.x0 + i as u32, y, 1.0 / inv_w));
            }
            true
        })
    });
    out
}

#[test]
fn the_fast_span_ends_equal_the_stepped_ones() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let (w, h) = (64u32, 48u32);
    let mut rows = 0;
    for round in 0..20000 {
        // Vertices on the pixel grid, on pixel centres, on half-centres, and anywhere.
        let snap = [1.0, 2.0, 4.0, 0.0][round % 4];
        let mut p = || {
            let (x, y) = (rng.random_range(-20.0..84.0), rng.random_range(-20.0..68.0));
            let s = |v: f64| {
                if snap > 0.0 {
                    (v * snap).round() / snap
                } else {
                    v
                }
            };
            ScreenVertex {
                x: s(x),
                y: s(y),
                inv_w: 1.0,
            }
        };
        let Some(t) = ScreenTriangle::new(w, h, [p(), p(), p()]) else {
            continue;
        };
        let s = SpanTriangle::new(t);
        for y in t.y0..=t.y1 {
            let want = row_span_stepping(&t, y);
            assert_eq!(s.row(y), want, "{t:?} row {y}");
            let within = (t.y0, t.y1);
            let block = |from: u32, r: usize| {
                let (lo, hi) = s.row_block(from, within);
                (lo[r] <= hi[r]).then(|| (lo[r] as u32, hi[r] as u32))
            };
            assert_eq!(block(y, 0), want, "{t:?} block at row {y}");
            if y >= t.y0 + ROWS as u32 - 1 {
                let from = y + 1 - ROWS as u32;
                assert_eq!(block(from, ROWS - 1), want, "{t:?} row {y}");
            }
            rows += 1;
        }
    }
    assert!(rows > 100_000);
}

#[test]
fn stepped_chunks_equal_the_multiplied_ones_to_a_rounding() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(8);
    for _ in 0..2000 {
        let s = Span {
            x0: 0,
            x1: rng.random_range(0..4000),
            start: rng.random_range(1e-4..2.0),
            slope: rng.random_range(-1e-3..1e-3),
        };
        let mut chunks = s.lanes_from(0);
        for n in 0..s.pixels() / LANES {
            let (a, b) = (chunks.next_chunk(), s.lanes(n * LANES));
            for k in 0..LANES {
                let scale = a[k].abs().max(b[k].abs()).max(1e-30);
                assert!(
                    (a[k] - b[k]).abs() <= 2.0 * f32::EPSILON * scale,
                    "{s:?} at {n}"
                );
            }
        }
    }
}

#[test]
fn spans_cover_exactly_the_reference_pixels() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let cam = look_at(Vec3::new(0.0, 1.0, 6.0), Vec3::ZERO, 97, 61);
    for round in 0..3000 {
        // Small and huge triangles, some crossing the near plane, some on the
        // pixel grid (ties), some far outside the viewport.
        let scale = [0.05, 1.0, 10.0, 400.0][round % 4];
        let mut p = || {
            let v = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            ) * scale;
            if round % 5 == 0 { v.round() } else { v }
        };
        let tri = [p(), p(), p()];
        let mut want = Vec::new();
        raster_triangle(&cam, tri, |x, y, d| want.push((x, y, d)));
        let mut got = by_spans(&cam, tri);
        want.sort_by_key(|&(x, y, _)| (y, x));
        got.sort_by_key(|&(x, y, _)| (y, x));
        assert_eq!(
            want.iter().map(|&(x, y, _)| (x, y)).collect::<Vec<_>>(),
            got.iter().map(|&(x, y, _)| (x, y)).collect::<Vec<_>>(),
            "round {round}: {tri:?}"
        );
        for (w, g) in want.iter().zip(&got) {
            assert!(
                ((w.2 - g.2) / w.2).abs() < 2e-6,
                "round {round}: depth {} vs {}",
                w.2,
                g.2
            );
        }
    }
}
