//! The native backend's two occlusion maps side by side on the shared scenes: the
//! per-pixel map (`NativeBackend`, served) and the masked map (`MaskedBackend`), on
//! the same planned poses, one thread, interleaved pose by pose (each pose's best of
//! five runs of each, so that a noisy VM slows both alike).
//!
//! Per scene: the masked map's draw, box test and refinement times, the per-pixel
//! map's whole pose, false culls and refined efficiency against the exact oracle, and
//! the box test's efficiency alone on each map.
//!
//! Run: `cargo run --release --example masked_vs_per_pixel` (`POSES=N`, default 32;
//! scenes from `HOMCULL_SCENES`, default `../shared/scenes`).

use std::time::Instant;

use homcull::core::camera::Camera;
use homcull::core::cull::deb::DEPTH_MARGIN;
use homcull::core::cull::{CullSettings, PosePlan, PreparedScene, clear_bit, has_bit, plan};
use homcull::core::native::NativeBackend;
use homcull::core::native::masked::{MaskedMap, hidden_masked};
use homcull::core::occluders::OccluderParams;
use homcull::core::sampler::PoseSampler;
use homcull::core::scene::load_path;
use homcull_proto::{CullOptions, Method};

const REPS: usize = 5;

/// The masked map's answer for one pose, and how long its draw, box test and
/// refinement took (ms); `refine` false stops after the box test.
fn masked(
    map: &mut MaskedMap,
    prep: &PreparedScene,
    p: &PosePlan,
    refine: bool,
) -> (Vec<u32>, [f64; 3]) {
    let t0 = Instant::now();
    map.reset(p.cam.width, p.cam.height);
    map.draw_occluders(&prep.scene, &p.cam, &p.occluders.ids);
    let t1 = Instant::now();
    let mut mask = p.box_test(&prep.scene, |r| {
        map.rect_hidden(r, (1.0 + DEPTH_MARGIN) / r.near)
    });
    let t2 = Instant::now();
    if refine {
        for &c in &p.candidates {
            if has_bit(&mask, c) && hidden_masked(map, &prep.scene, &p.cam, c) {
                clear_bit(&mut mask, c);
            }
        }
    }
    let ms = |a: Instant, b: Instant| (b - a).as_secs_f64() * 1e3;
    (mask, [ms(t0, t1), ms(t1, t2), ms(t2, Instant::now())])
}

/// Culled ÷ hidden in-frustum objects, and objects culled that the oracle sees.
fn quality(plans: &[PosePlan], masks: &[Vec<u32>], oracle: &[Vec<u32>]) -> (f64, usize) {
    let (mut hidden, mut culled, mut wrong) = (0, 0, 0);
    for ((p, m), o) in plans.iter().zip(masks).zip(oracle) {
        for &c in &p.candidates {
            let (kept, seen) = (has_bit(m, c), has_bit(o, c));
            wrong += (seen && !kept) as usize;
            hidden += !seen as usize;
            culled += (!seen && !kept) as usize;
        }
    }
    (culled as f64 / hidden.max(1) as f64, wrong)
}

fn main() {
    let poses: usize = std::env::var("POSES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(32);
    let dir = std::env::var("HOMCULL_SCENES").unwrap_or_else(|_| "../shared/scenes".into());
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()
        .expect("a one-thread pool");
    println!(
        "scene      | masked draw box refine = total | per-pixel | false culls | refined eff | box test eff masked / per-pixel"
    );
    for name in ["munich", "etoile", "oa_shouse", "oa_dm1"] {
        let scene = load_path(&std::path::Path::new(&dir).join(format!("{name}.glb")))
            .expect("a shared scene");
        let sampled = PoseSampler::new(&scene).sample(poses, 1, [960, 540], &|_| true);
        let prep = PreparedScene::new(scene, OccluderParams::default());
        let opts = |method, refine| {
            CullSettings::new(
                CullOptions {
                    method,
                    refine,
                    ..CullOptions::default()
                },
                &prep,
            )
        };
        let (hom, boxes, exact) = (
            opts(Method::Hom, true),
            opts(Method::Hom, false),
            opts(Method::Exact, false),
        );
        let plans: Vec<PosePlan> = sampled
            .poses
            .iter()
            .map(|p| plan(&prep, &Camera::new(p).expect("a pose"), &hom))
            .collect();
        let oracle: Vec<Vec<u32>> = plans
            .iter()
            .map(|p| NativeBackend::pose_mask(&prep, p, &exact))
            .collect();
        let mut map = MaskedMap::default();
        let (mut parts, mut per_pixel) = ([0.0; 3], 0.0);
        let mut answers = Vec::new();
        for p in &plans {
            let (mut best, mut best_pp) = ([f64::MAX; 3], f64::MAX);
            for _ in 0..REPS {
                let t = Instant::now();
                std::hint::black_box(NativeBackend::pose_mask(&prep, p, &hom));
                best_pp = best_pp.min(t.elapsed().as_secs_f64() * 1e3);
                let (_, ms) = masked(&mut map, &prep, p, true);
                for k in 0..3 {
                    best[k] = best[k].min(ms[k]);
                }
            }
            (0..3).for_each(|k| parts[k] += best[k]);
            per_pixel += best_pp;
            answers.push(masked(&mut map, &prep, p, true).0);
        }
        let (eff, wrong) = quality(&plans, &answers, &oracle);
        let masked_boxes: Vec<Vec<u32>> = plans
            .iter()
            .map(|p| masked(&mut map, &prep, p, false).0)
            .collect();
        let pixel_boxes: Vec<Vec<u32>> = plans
            .iter()
            .map(|p| NativeBackend::pose_mask(&prep, p, &boxes))
            .collect();
        let n = plans.len() as f64;
        println!(
            "{name:10} | {:.3} {:.3} {:.3} = {:.3} ms | {:.3} ms | {wrong} | {eff:.4} | {:.3} / {:.3}",
            parts[0] / n,
            parts[1] / n,
            parts[2] / n,
            parts.iter().sum::<f64>() / n,
            per_pixel / n,
            quality(&plans, &masked_boxes, &oracle).0,
            quality(&plans, &pixel_boxes, &oracle).0,
        );
    }
}
