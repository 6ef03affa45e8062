//! The native CPU backend, pass by pass, on the shared real scenes (divan; one thread).
//! Run: `cargo bench --bench native`. Scenes come from `HOMCULL_SCENES` (default
//! `../shared/scenes`) and the built-in demo city (`demo`); 32 sampled street-level poses per scene at 960×540, the poses
//! `homcull eval --random 32` would use (seed 1).
//!
//! - `plan`: frustum query, test boxes, occluder selection (shared with every backend).
//! - `draw`: the occluders' front faces into the occlusion map (those already hidden
//!   after the nearest quarter left out).
//! - `bounds`: the tile-bounds pyramid over the map.
//! - `box_test`: the box test of every in-frustum test box (per box: compare with
//!   MOC's 40–90 ns per object test).
//! - `pose`: the whole query through the culler (plan, draw, bounds, box test,
//!   refinement, the answer), what a client waits for, beside `exact` (the ID-buffer
//!   oracle on the same spans) and `stereo` (both eyes of the pose, 64 mm apart, in
//!   one cull: one occluder choice, a map and tests per eye).
//! - `masked_draw`, `pose_masked_unplanned` beside `pose_per_pixel_unplanned`: the
//!   masked map (`native::masked`, `MaskedBackend`) against the per-pixel map, the
//!   whole pose after planning (with `--features experimental`).

mod common;

use std::sync::OnceLock;

use divan::Bencher;
use homcull::core::camera::{Camera, stereo};
use homcull::core::cull::{CullSettings, Culler, PosePlan, PreparedScene, plan};
use homcull::core::native::NativeBackend;
use homcull::core::native::map::OcclusionMap;
#[cfg(feature = "experimental")]
use homcull::core::native::masked::{MaskedBackend, MaskedMap};
use homcull::core::occluders::OccluderParams;
use homcull::core::sampler::PoseSampler;
use homcull_proto::{CullOptions, Method, Pose, Stereo};

/// The shared scenes MOC was measured on, and the built-in demo city (what `homcull
/// serve` and `homcull loadgen` run on by default).
const SCENES: &[&str] = &["munich", "etoile", "oa_shouse", "oa_dm1", "demo"];
const POSES: usize = 32;

fn main() {
    // One thread: the figures are per core.
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()
        .expect("a one-thread pool");
    divan::main();
}

struct Bench {
    prep: PreparedScene,
    poses: Vec<Pose>,
    cams: Vec<Camera>,
}

fn scene(name: &str) -> &'static Bench {
    static ALL: OnceLock<Vec<(String, Bench)>> = OnceLock::new();
    let all = ALL.get_or_init(|| {
        SCENES
            .iter()
            .map(|&n| {
                let scene = common::scene_named(n);
                let sampled = PoseSampler::new(&scene).sample(POSES, 1, [960, 540], &|_| true);
                let cams = sampled
                    .poses
                    .iter()
                    .map(|p| Camera::new(p).unwrap())
                    .collect();
                let prep = PreparedScene::new(scene, OccluderParams::default());
                let poses = sampled.poses;
                (n.to_string(), Bench { prep, poses, cams })
            })
            .collect()
    });
    &all.iter()
        .find(|(n, _)| n == name)
        .expect("a benchmarked scene")
        .1
}

fn settings(b: &Bench, method: Method) -> CullSettings {
    // The served options (threshold 1, raster DEB, refined) with this method.
    CullSettings::new(
        CullOptions {
            method,
            ..CullOptions::default()
        },
        &b.prep,
    )
}

fn plans(b: &Bench, method: Method) -> Vec<PosePlan> {
    let s = settings(b, method);
    b.cams.iter().map(|c| plan(&b.prep, c, &s)).collect()
}

#[divan::bench(args = SCENES)]
fn plan_per_pose(bencher: Bencher, name: &str) {
    let b = scene(name);
    let s = settings(b, Method::Hom);
    bencher
        .counter(divan::counter::ItemsCount::new(b.cams.len()))
        .bench(|| {
            b.cams
                .iter()
                .map(|c| plan(&b.prep, c, &s).candidates.len())
                .sum::<usize>()
        });
}

fn draw(map: &mut OcclusionMap, b: &Bench, p: &PosePlan) {
    map.reset(p.cam.width, p.cam.height);
    map.draw_occluders(&b.prep.scene, &p.cam, &p.occluders.ids);
}

#[divan::bench(args = SCENES)]
fn draw_per_pose(bencher: Bencher, name: &str) {
    let b = scene(name);
    let plans = plans(b, Method::Hom);
    let mut map = OcclusionMap::default();
    bencher
        .counter(divan::counter::ItemsCount::new(plans.len()))
        .bench_local(|| {
            for p in &plans {
                draw(&mut map, b, p);
            }
        });
}

#[divan::bench(args = SCENES)]
fn bounds_per_pose(bencher: Bencher, name: &str) {
    let b = scene(name);
    let plans = plans(b, Method::Hom);
    let mut map = OcclusionMap::default();
    draw(&mut map, b, &plans[0]);
    bencher.bench_local(|| map.build_bounds());
}

#[divan::bench(args = SCENES)]
fn box_test_per_box(bencher: Bencher, name: &str) {
    let b = scene(name);
    let plans = plans(b, Method::Hom);
    let s = settings(b, Method::Hom);
    let maps: Vec<OcclusionMap> = plans
        .iter()
        .map(|p| {
            let mut m = OcclusionMap::default();
            draw(&mut m, b, p);
            m.build_bounds();
            m
        })
        .collect();
    let boxes: usize = plans.iter().map(|p| p.test_boxes.len()).sum();
    bencher
        .counter(divan::counter::ItemsCount::new(boxes))
        .bench_local(|| {
            plans
                .iter()
                .zip(&maps)
                .map(|(p, m)| NativeBackend::test_boxes(m, &b.prep, p, &s)[0])
                .sum::<u32>()
        });
}

#[divan::bench(args = SCENES)]
fn pose_hom_refined(bencher: Bencher, name: &str) {
    whole_pose(bencher, name, Method::Hom);
}

/// The whole pose on the per-pixel map (`NativeBackend`, the served path), planned
/// outside the timing, beside `pose_masked_unplanned`.
#[divan::bench(args = SCENES)]
fn pose_per_pixel_unplanned(bencher: Bencher, name: &str) {
    unplanned(bencher, name, NativeBackend::pose_mask);
}

/// The whole pose on the masked map (`MaskedBackend`), planned outside the timing.
#[cfg(feature = "experimental")]
#[divan::bench(args = SCENES)]
fn pose_masked_unplanned(bencher: Bencher, name: &str) {
    unplanned(bencher, name, MaskedBackend::pose_mask_masked);
}

/// Every pose's image-space work by `mask` (refined HOM), the poses planned first.
fn unplanned(
    bencher: Bencher,
    name: &str,
    mask: fn(&PreparedScene, &PosePlan, &CullSettings) -> Vec<u32>,
) {
    let b = scene(name);
    let plans = plans(b, Method::Hom);
    let s = settings(b, Method::Hom);
    bencher
        .counter(divan::counter::ItemsCount::new(plans.len()))
        .bench_local(|| plans.iter().map(|p| mask(&b.prep, p, &s)[0]).sum::<u32>());
}

#[cfg(feature = "experimental")]
#[divan::bench(args = SCENES)]
fn masked_draw_per_pose(bencher: Bencher, name: &str) {
    let b = scene(name);
    let plans = plans(b, Method::Hom);
    let mut map = MaskedMap::default();
    bencher
        .counter(divan::counter::ItemsCount::new(plans.len()))
        .bench_local(|| {
            for p in &plans {
                map.reset(p.cam.width, p.cam.height);
                map.draw_occluders(&b.prep.scene, &p.cam, &p.occluders.ids);
            }
        });
}

#[divan::bench(args = SCENES)]
fn pose_exact(bencher: Bencher, name: &str) {
    whole_pose(bencher, name, Method::Exact);
}

#[divan::bench(args = SCENES)]
fn pose_stereo_refined(bencher: Bencher, name: &str) {
    let b = scene(name);
    let s = settings(b, Method::Hom);
    let eyes: Vec<Vec<Camera>> = b
        .poses
        .iter()
        .map(|p| {
            let stereo = Stereo {
                ipd_m: 0.064,
                convergence_m: None,
            };
            stereo::eyes(&Pose {
                stereo: Some(stereo),
                ..p.clone()
            })
            .unwrap()
        })
        .collect();
    // Through the culler, as the server culls: the eyes share one occluder choice.
    let mut culler = NativeBackend;
    bencher
        .counter(divan::counter::ItemsCount::new(eyes.len()))
        .bench_local(|| {
            eyes.iter()
                .map(|e| culler.cull(&b.prep, e, &s).unwrap()[0].visible.len())
                .sum::<usize>()
        });
}

fn whole_pose(bencher: Bencher, name: &str, method: Method) {
    let b = scene(name);
    let s = settings(b, method);
    let mut culler = NativeBackend;
    bencher
        .counter(divan::counter::ItemsCount::new(b.cams.len()))
        .bench_local(|| {
            b.cams
                .iter()
                .map(|c| {
                    culler.cull(&b.prep, std::slice::from_ref(c), &s).unwrap()[0]
                        .visible
                        .len()
                })
                .sum::<usize>()
        });
}
