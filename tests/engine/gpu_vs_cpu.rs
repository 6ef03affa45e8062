//! Every GPU pass against its CPU twin on the same input, and property tests of the
//! conservativeness claim on random scenes (ARCHITECTURE.md, "Conservativeness").

use crate::common;

use common::scenes::{random_scene, settings};
use glam::Vec3;
use homcull::core::camera::{Camera, look_at};
use homcull::core::cull::{Culler, PreparedScene, plan};
use homcull::core::gpu::GpuBackend;
use homcull::core::occluders::OccluderParams;
use homcull::core::reference::ReferenceBackend;
use homcull::core::reference::pyramid::{self, LevelLayout};
use homcull::core::scene::demo_city;
use homcull_proto::{DebVariant, Method};
use proptest::prelude::*;

fn demo_cams(w: u32, h: u32) -> Vec<Camera> {
    [
        (Vec3::new(0.0, 1.7, 3.0), Vec3::new(40.0, 1.7, 10.0)),
        (Vec3::new(-35.0, 1.7, -30.0), Vec3::new(-35.0, 3.0, 60.0)),
        (Vec3::new(10.0, 40.0, 10.0), Vec3::new(200.0, 0.0, 150.0)),
        (Vec3::new(3.0, 1.7, -3.0), Vec3::new(-50.0, 1.5, -60.0)),
    ]
    .iter()
    .map(|&(e, t)| look_at(e, t, w, h))
    // And the converged (off-axis) eyes of a stereo pose: frusta shifted sideways.
    .chain({
        let mut pose = homcull_proto::Pose::looking_at([0.0, 1.7, 3.0], [40.0, 1.7, 10.0]);
        pose.viewport = [w, h];
        pose.stereo = Some(homcull_proto::Stereo {
            ipd_m: 0.5,
            convergence_m: Some(5.0),
        });
        homcull::core::camera::stereo::eyes(&pose).unwrap()
    })
    .collect()
}

#[test]
fn raster_pyramid_and_test_match_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let prep = PreparedScene::new(demo_city(), OccluderParams::default());
    let mut backend = GpuBackend::new(gpu, &prep);
    let (w, h) = (320, 180);
    let s = settings(&prep, Method::Hom, DebVariant::Raster, false);
    let plans: Vec<_> = demo_cams(w, h).iter().map(|c| plan(&prep, c, &s)).collect();
    let (g_opacity, g_depth) = backend.pyramids(&plans, &s).unwrap();
    let layout = LevelLayout::new(w, h);
    let stride = layout.total as usize;
    let gpu_masks = backend.visibility(&prep, &plans, &s).unwrap();
    let refined = settings(&prep, Method::Hom, DebVariant::Raster, true);
    let gpu_refined = backend.visibility(&prep, &plans, &refined).unwrap();
    let mut refined_away = 0;
    for (k, p) in plans.iter().enumerate() {
        let go = &g_opacity[k * stride..(k + 1) * stride];
        let gd = &g_depth[k * stride..(k + 1) * stride];
        // Raster: coverage may differ only on a thin set of edge pixels; depth agrees.
        let cpu0 = ReferenceBackend::occluder_depth(&prep.scene, p);
        let n0 = (w * h) as usize;
        let mismatched = (0..n0)
            .filter(|&i| (cpu0[i] > 0.0) != (go[i] > 0.0))
            .count();
        assert!(
            mismatched * 200 < n0,
            "pose {k}: {mismatched} of {n0} pixels differ in coverage"
        );
        // Where both cover a pixel the nearest depth agrees, except where an edge pixel
        // went to a different triangle: the GPU's lies behind the exact depth by at most
        // its slack (`DEPTH_SLACK_PX` of the depth's gradient, estimated from the CPU's
        // neighbouring pixels), never in front.
        let both: Vec<usize> = (0..n0).filter(|&i| cpu0[i] > 0.0 && go[i] > 0.0).collect();
        let gradient = |i: usize| {
            let step = |j: Option<usize>| {
                j.filter(|&j| j < n0 && cpu0[j] > 0.0)
                    .map_or(0.0, |j| (cpu0[j] - cpu0[i]).abs())
            };
            let w = w as usize;
            step(i.checked_sub(1)).max(step(Some(i + 1)))
                + step(i.checked_sub(w)).max(step(Some(i + w)))
        };
        let slack = homcull::core::gpu::prelude::DEPTH_SLACK_PX;
        let nearer = (both.iter())
            .filter(|&&i| gd[i] < cpu0[i] * (1.0 - 1e-3))
            .count();
        // Farther than the slack the CPU's neighbours suggest: a face seen edge-on, a
        // pixel wide, whose own gradient (what the GPU uses) is far steeper.
        let farther = (both.iter())
            .filter(|&&i| gd[i] > cpu0[i] * (1.0 + 1e-3) + 2.0 * slack * gradient(i))
            .count();
        assert!(
            both.len() > n0 / 10,
            "pose {k}: too little coverage to compare"
        );
        assert!(
            nearer * 200 < both.len() && farther * 100 < both.len(),
            "pose {k}: of {} covered pixels, {nearer} nearer on the GPU, {farther} farther than its slack",
            both.len()
        );
        // Pyramid: CPU reduction of the GPU's level 0 must equal the GPU's levels exactly.
        let (co, cd) = pyramid::build(&layout, &gd[..n0]);
        assert_eq!(co, go, "pose {k}: opacity pyramid differs");
        assert_eq!(cd, gd, "pose {k}: depth pyramid differs");
        // Object test on the same pyramid.
        let cpu_mask = ReferenceBackend::test_boxes(&prep.scene, p, &s, &layout, go, gd);
        assert_eq!(cpu_mask, gpu_masks[k], "pose {k}: object test differs");
        assert!(cpu_mask.iter().any(|&w| w != 0));
        // Refinement of the same box test's survivors, each side against its own
        // rasterizer's occluder depth (the comparison has no margin, so it must not mix
        // the CPU's object depths with the GPU's map). Rasterization differs on a thin
        // set of edge pixels between the two, so an object whose only visible pixels are
        // such edge pixels may go either way; conservativeness against the oracle is the
        // property test's job.
        let mut cpu_refined = cpu_mask.clone();
        ReferenceBackend::refine(&prep, p, &cpu0, &mut cpu_refined);
        let g = &gpu_refined[k];
        assert!(
            g.iter().zip(&gpu_masks[k]).all(|(r, b)| r & !b == 0),
            "pose {k}: refinement only removes objects"
        );
        let ones = |m: &[u32]| m.iter().map(|w| w.count_ones()).sum::<u32>();
        let differ: u32 = cpu_refined
            .iter()
            .zip(g)
            .map(|(a, b)| (a ^ b).count_ones())
            .sum();
        assert!(
            differ * 50 <= ones(&cpu_mask),
            "pose {k}: GPU and CPU refinement differ on {differ} of {} kept objects",
            ones(&cpu_mask)
        );
        refined_away += ones(&cpu_mask) - ones(g);
    }
    assert!(
        refined_away > 0,
        "the refinement culls what the boxes could not"
    );
}

#[test]
fn pyramid_matches_cpu_at_odd_viewports() {
    let Some(gpu) = common::gpu() else { return };
    let prep = PreparedScene::new(demo_city(), OccluderParams::default());
    let mut backend = GpuBackend::new(gpu, &prep);
    let s = settings(&prep, Method::Hom, DebVariant::Raster, false);
    for (w, h) in [(1, 1), (2, 1), (33, 17), (257, 129), (131, 301)] {
        let plans: Vec<_> = demo_cams(w, h).iter().map(|c| plan(&prep, c, &s)).collect();
        let (g_opacity, g_depth) = backend.pyramids(&plans, &s).unwrap();
        let layout = LevelLayout::new(w, h);
        let stride = layout.total as usize;
        let n0 = (w * h) as usize;
        for k in 0..plans.len() {
            let go = &g_opacity[k * stride..(k + 1) * stride];
            let gd = &g_depth[k * stride..(k + 1) * stride];
            let (co, cd) = pyramid::build(&layout, &gd[..n0]);
            assert_eq!(co, go, "{w}x{h} pose {k}: opacity pyramid differs");
            assert_eq!(cd, gd, "{w}x{h} pose {k}: depth pyramid differs");
        }
        assert!(
            g_opacity.iter().any(|&o| o > 0.0) || n0 < 4,
            "{w}x{h}: nothing covered"
        );
    }
}

#[test]
fn refinement_paths_agree() {
    // Early depth tests against the occluders' depth buffer, and the fallback's
    // comparison with the occlusion map: both conservative (property test), and they
    // differ only on depth near-ties.
    let (Some(gpu), Some(fallback)) = (common::gpu(), common::gpu_without_early_z()) else {
        return;
    };
    let prep = PreparedScene::new(demo_city(), OccluderParams::default());
    let s = settings(&prep, Method::Hom, DebVariant::Raster, true);
    let cams = demo_cams(320, 180);
    let a = GpuBackend::new(gpu, &prep).cull(&prep, &cams, &s).unwrap();
    let b = GpuBackend::new(fallback, &prep)
        .cull(&prep, &cams, &s)
        .unwrap();
    for (k, (a, b)) in a.iter().zip(&b).enumerate() {
        let differ = a.visible.iter().filter(|i| !b.visible.contains(i)).count()
            + b.visible.iter().filter(|i| !a.visible.contains(i)).count();
        assert!(
            differ * 50 <= b.visible.len().max(50),
            "pose {k}: the refinement paths differ on {differ} of {} objects",
            b.visible.len()
        );
        assert!(!a.visible.is_empty());
    }
}

#[test]
fn exact_oracle_matches_cpu() {
    let Some(gpu) = common::gpu() else { return };
    let prep = PreparedScene::new(demo_city(), OccluderParams::default());
    let mut backend = GpuBackend::new(gpu, &prep);
    let s = settings(&prep, Method::Exact, DebVariant::Raster, false);
    let cams = demo_cams(320, 180);
    let g = backend.cull(&prep, &cams, &s).unwrap();
    let c = ReferenceBackend.cull(&prep, &cams, &s).unwrap();
    for (a, b) in g.iter().zip(&c) {
        let diff = a.visible.iter().filter(|i| !b.visible.contains(i)).count()
            + b.visible.iter().filter(|i| !a.visible.contains(i)).count();
        // Only objects owning a pixel or two on a shared edge may differ.
        assert!(
            diff * 50 <= a.visible.len().max(50),
            "{diff} objects differ of {}",
            a.visible.len()
        );
        assert!(!a.visible.is_empty());
    }
}

#[test]
fn batch_equals_single_calls() {
    let Some(gpu) = common::gpu() else { return };
    let prep = PreparedScene::new(demo_city(), OccluderParams::default());
    let mut backend = GpuBackend::new(gpu, &prep);
    for method in [Method::Hom, Method::Hzb, Method::Exact] {
        let s = settings(&prep, method, DebVariant::Tiles, true);
        // More poses than one group of slots, so group boundaries are exercised.
        let cams: Vec<Camera> = (0..20)
            .map(|i| demo_cams(200, 120)[i % 4].clone())
            .collect();
        let batched = backend.cull(&prep, &cams, &s).unwrap();
        for (i, cam) in cams.iter().enumerate().take(4) {
            let single = backend.cull(&prep, std::slice::from_ref(cam), &s).unwrap();
            assert_eq!(single[0].visible, batched[i].visible, "{method:?} pose {i}");
            assert_eq!(batched[i].visible, batched[i + 16].visible);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn hom_and_hzb_never_cull_what_the_oracle_sees(
        boxes in prop::collection::vec((-50.0f32..50.0, -50.0f32..50.0, 0.2f32..12.0, 0.2f32..20.0, 0.2f32..12.0), 5..60),
        eye in (-40.0f32..40.0, 0.5f32..15.0, -40.0f32..40.0),
        dir in (0.0f32..std::f32::consts::TAU, -0.5f32..0.3),
    ) {
        let Some(gpu) = common::gpu() else { return Ok(()) };
        let prep = PreparedScene::new(random_scene(&boxes), OccluderParams { min_diagonal: 0.0, ..Default::default() });
        let eye = Vec3::new(eye.0, eye.1, eye.2);
        let target = eye + Vec3::new(dir.0.cos(), dir.1, dir.0.sin());
        let cam = look_at(eye, target, 160, 90);
        let mut backend = GpuBackend::new(gpu, &prep);
        let exact = backend.cull(&prep, std::slice::from_ref(&cam), &settings(&prep, Method::Exact, DebVariant::Raster, false)).unwrap();
        // The refinement's path on adapters without forced early depth tests.
        let mut fallback = GpuBackend::new(common::gpu_without_early_z().expect("a GPU"), &prep);
        let r = fallback.cull(&prep, std::slice::from_ref(&cam), &settings(&prep, Method::Hom, DebVariant::Raster, true)).unwrap();
        for id in &exact[0].visible {
            prop_assert!(r[0].visible.contains(id), "refinement without early depth tests culled {} which the oracle sees", id);
        }
        for (method, deb) in [(Method::Hom, DebVariant::Raster), (Method::Hom, DebVariant::Tiles), (Method::Hom, DebVariant::Plane), (Method::Hzb, DebVariant::Raster)] {
            for refine in [false, true] {
                let r = backend.cull(&prep, std::slice::from_ref(&cam), &settings(&prep, method, deb, refine)).unwrap();
                for id in &exact[0].visible {
                    prop_assert!(r[0].visible.contains(id), "{:?}/{:?} (refine {}) culled {} which the oracle sees", method, deb, refine, id);
                }
            }
        }
        // The CPU reference keeps the same promise against the CPU oracle.
        let cpu_exact = ReferenceBackend.cull(&prep, std::slice::from_ref(&cam), &settings(&prep, Method::Exact, DebVariant::Raster, false)).unwrap();
        for refine in [false, true] {
            let cpu_hom = ReferenceBackend.cull(&prep, std::slice::from_ref(&cam), &settings(&prep, Method::Hom, DebVariant::Raster, refine)).unwrap();
            for id in &cpu_exact[0].visible {
                prop_assert!(cpu_hom[0].visible.contains(id), "CPU hom (refine {}) culled {}", refine, id);
            }
        }
    }
}
