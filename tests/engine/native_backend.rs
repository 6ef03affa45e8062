//! The native CPU backend (`core::native`) against the exact oracle.
//!
//! - Random scenes (property test): zero false culls against the CPU oracle twin
//!   (`reference::oracle`, the reference's exact-arithmetic ID buffer), for the refined
//!   test and the box test alone with each DEB, on both maps; the backend's own `exact` equals the
//!   twin's.
//! - Every shared scene and the demo city, sampled street-level poses at 960×540,
//!   for both maps (the per-pixel map and the masked map, `MaskedBackend`): zero
//!   false culls against the CPU twin; against the GPU oracle where an adapter
//!   exists, every object the GPU sees and this backend culls must be one the CPU
//!   twin does not see either (the GPU snaps vertices to a fixed-point grid: it can
//!   leave a pixel uncovered between nearer triangles, a crack, see `real_scenes.rs`,
//!   and it decides a near tie, where an object meets a surface just in front of it,
//!   by its own depth arithmetic where the refinement decides it in f64 as the CPU
//!   twin does), and such sightings stay bounded (munich 20, etoile 28 in 120 poses);
//!   refined efficiency floors; kept ÷ oracle triangles bounds. The answers checked are the
//!   served ones (`Culler::cull`, which also leaves out the scene's exact copies,
//!   `cull::copies`), and every copy is checked hidden in each oracle at every pose.

use crate::common;

use common::scenes::{random_scene, settings};
use glam::Vec3;
use homcull::core::camera::{Camera, look_at};
use homcull::core::cull::{
    CullSettings, Culler, PosePlan, PreparedScene, has_bit, plan, set_bit, words_per_pose,
};
use homcull::core::geom::Aabb;
use homcull::core::gpu::GpuBackend;
use homcull::core::native::NativeBackend;
use homcull::core::native::map::{OcclusionMap, front_facing};
#[cfg(feature = "experimental")]
use homcull::core::native::masked::MaskedBackend;
use homcull::core::occluders::OccluderParams;
use homcull::core::pvs::Pvs;
use homcull::core::reference::ReferenceBackend;
use homcull::core::sampler::PoseSampler;
use homcull::core::scene::{Scene, demo_city, load_path};
use homcull_proto::{DebVariant, Method};
use proptest::prelude::*;

/// Objects `mask` culls that `oracle` sees, over the candidates of each pose.
fn false_culls(plans: &[PosePlan], mask: &[Vec<u32>], oracle: &[Vec<u32>]) -> Vec<(usize, u32)> {
    let mut out = Vec::new();
    for (k, p) in plans.iter().enumerate() {
        for &c in &p.candidates {
            if has_bit(&oracle[k], c) && !has_bit(&mask[k], c) {
                out.push((k, c));
            }
        }
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

    #[test]
    fn native_never_culls_what_the_cpu_oracle_sees(
        boxes in prop::collection::vec((-50.0f32..50.0, -50.0f32..50.0, 0.2f32..12.0, 0.2f32..20.0, 0.2f32..12.0), 5..60),
        eye in (-40.0f32..40.0, 0.5f32..15.0, -40.0f32..40.0),
        dir in (0.0f32..std::f32::consts::TAU, -0.5f32..0.3),
    ) {
        let prep = PreparedScene::new(random_scene(&boxes), OccluderParams { min_diagonal: 0.0, ..Default::default() });
        let eye = Vec3::new(eye.0, eye.1, eye.2);
        let cam = look_at(eye, eye + Vec3::new(dir.0.cos(), dir.1, dir.0.sin()), 192, 108);
        let inside_a_box = prep.scene.objects.iter().any(|o| {
            let m = Vec3::splat(cam.near * 2.0);
            Aabb::new(o.aabb.min - m, o.aabb.max + m).contains(eye)
        });
        let exact = settings(&prep, Method::Exact, DebVariant::Raster, false);
        let oracle_plans = [plan(&prep, &cam, &exact)];
        let oracle = ReferenceBackend.visibility(&prep, &oracle_plans, &exact).unwrap();
        let native_exact = NativeBackend.visibility(&prep, &oracle_plans, &exact).unwrap();
        if !inside_a_box {
            // (From inside a box its bottom face lies in the ground's plane: which of
            // the two wins a pixel is a tie decided by the last bits of each
            // rasterizer's depth, f32 lanes here and f64 per pixel in the oracle.)
            prop_assert_eq!(&native_exact, &oracle, "the native exact cull differs from the CPU oracle");
        }
        for (deb, refine) in [
            (DebVariant::Raster, true),
            (DebVariant::Raster, false),
            (DebVariant::Tiles, false),
            (DebVariant::Plane, false),
        ] {
            let s = settings(&prep, Method::Hom, deb, refine);
            let plans = [plan(&prep, &cam, &s)];
            if refine {
                prop_assert!(skipping_draw_is_exact(&prep, &plans[0]), "the occluder draw's map differs");
            }
            let mask = NativeBackend.visibility(&prep, &plans, &s).unwrap();
            let wrong = false_culls(&plans, &mask, &oracle);
            prop_assert!(wrong.is_empty(), "{:?} refine {}: culled {:?}", deb, refine, wrong);
            #[cfg(feature = "experimental")]
            {
                let masked = MaskedBackend.visibility(&prep, &plans, &s).unwrap();
                let wrong = false_culls(&plans, &masked, &oracle);
                prop_assert!(wrong.is_empty(), "masked map, {:?} refine {}: culled {:?}", deb, refine, wrong);
            }
            if deb == DebVariant::Raster && !refine && !inside_a_box {
                // The native box test is the reference's conservative test answered
                // exactly: the same answer, object for object. (From inside a box the
                // reference draws that box's back faces, which the native leaves out.)
                let reference = ReferenceBackend.visibility(&prep, &plans, &s).unwrap();
                prop_assert_eq!(&mask, &reference, "box test differs from the reference");
            }
        }
    }
}

/// The occluder draw (band by band, occluders and triangles the map already hides
/// left out) leaves the map bit for bit as drawing every front face does, in reverse.
fn skipping_draw_is_exact(prep: &PreparedScene, p: &PosePlan) -> bool {
    let (scene, cam) = (&prep.scene, &p.cam);
    let mut skipping = OcclusionMap::default();
    skipping.reset(cam.width, cam.height);
    skipping.draw_occluders(scene, cam, &p.occluders.ids);
    let mut all = OcclusionMap::default();
    all.reset(cam.width, cam.height);
    all.draw(
        cam,
        p.occluders.ids.iter().rev().flat_map(|&id| {
            scene
                .corners_of(&scene.objects[id as usize])
                .filter(|t| front_facing(cam.position, t))
        }),
    );
    skipping.pixels() == all.pixels()
}

/// The refined efficiency floor: 0.99 on every scene (120 poses measured against the
/// CPU oracle, per-pixel map / masked map: demo 1.0 / 1.0, munich 0.9999 / 0.9995,
/// etoile 0.9996 / 0.9965, oa_shouse 0.9983 / 0.9924, oa_dm1 0.9979 / 0.9915,
/// godot_room 1.0 / 1.0, fzk_haus 0.9966 / 0.9910; answers are deterministic).
const FLOOR: f64 = 0.99;

/// Kept ÷ oracle triangles bounds, over what was measured (per-pixel map / masked map:
/// munich 1.0004 / 1.0025, etoile 1.0009 / 1.0199, oa_shouse 1.0097 / 1.0210, oa_dm1
/// 1.0045 / 1.0384): the masked map decides no near tie finely, so surfaces flush
/// behind an occluder (within its depth margin) weigh most there.
fn max_overdraw(scene: &str) -> f64 {
    if scene.starts_with("oa_") {
        1.045
    } else {
        1.03
    }
}

const POSES: usize = 120;

fn check(scene: Scene) {
    let name = scene.name.clone();
    let pvs = Pvs::from_scene(&scene).map(|r| r.expect("the scene's PVS parses"));
    let accept = |p: Vec3| pvs.as_ref().is_none_or(|v| v.cluster_at(p) >= 0);
    let sampled = PoseSampler::new(&scene).sample(POSES, 11, [960, 540], &accept);
    assert_eq!(sampled.poses.len(), POSES, "{name}: too few poses");
    let cams: Vec<Camera> = sampled
        .poses
        .iter()
        .map(|p| Camera::new(p).unwrap())
        .collect();
    let prep = PreparedScene::new(scene, OccluderParams::default());
    let hom = settings(&prep, Method::Hom, DebVariant::Raster, true);
    let plans: Vec<PosePlan> = cams.iter().map(|c| plan(&prep, c, &hom)).collect();
    let exact = settings(&prep, Method::Exact, DebVariant::Raster, false);
    let oracle = ReferenceBackend.visibility(&prep, &plans, &exact).unwrap();
    // The served per-pixel map, and with the `experimental` feature the masked map.
    #[allow(unused_mut)]
    let mut maps = vec![(
        "per-pixel",
        served(&mut NativeBackend, &prep, &cams, &plans, &hom),
    )];
    #[cfg(feature = "experimental")]
    maps.push((
        "masked",
        served(&mut MaskedBackend, &prep, &cams, &plans, &hom),
    ));
    copies_hidden(&name, &prep, &oracle, "CPU");
    if name == "oa_dm1" {
        // Six brush models saved both on their own and inside the level's main mesh.
        assert_eq!(prep.copies.len(), 6, "oa_dm1: copies");
    }
    for (map, mask) in &maps {
        quality(&name, map, &prep, &plans, mask, &oracle);
    }

    // Against the GPU oracle: only cracks and near ties the GPU decides otherwise.
    let scene = &prep.scene;
    let Some(gpu) = common::gpu() else { return };
    let gpu_oracle = GpuBackend::new(gpu, &prep)
        .visibility(&prep, &plans, &exact)
        .unwrap();
    assert_eq!(gpu_oracle[0].len(), words_per_pose(scene.objects.len()));
    copies_hidden(&name, &prep, &gpu_oracle, "GPU");
    for (map, mask) in &maps {
        let gpu_only = false_culls(&plans, mask, &gpu_oracle);
        for &(k, c) in &gpu_only {
            assert!(
                !has_bit(&oracle[k], c),
                "{name} ({map} map): pose {k} object {c}: the CPU oracle sees it too"
            );
        }
        eprintln!(
            "{name} ({map} map): {} objects only the GPU oracle sees (cracks, near ties), culled",
            gpu_only.len()
        );
        assert!(
            gpu_only.len() * 3 <= POSES,
            "{name} ({map} map): {} GPU-only sightings in {POSES} poses",
            gpu_only.len()
        );
    }
}

/// The served answers of `culler` (`Culler::cull`) as bitmasks, checked to be of the
/// same candidates as `plans`.
fn served(
    culler: &mut dyn Culler,
    prep: &PreparedScene,
    cams: &[Camera],
    plans: &[PosePlan],
    s: &CullSettings,
) -> Vec<Vec<u32>> {
    let results = culler.cull(prep, cams, s).unwrap();
    let words = words_per_pose(prep.scene.objects.len());
    results
        .iter()
        .zip(plans)
        .map(|(r, p)| {
            assert_eq!(r.candidates, p.candidates, "the same plan");
            let mut m = vec![0; words];
            r.visible.iter().for_each(|&id| set_bit(&mut m, id));
            m
        })
        .collect()
}

/// Every exact copy of the scene is hidden in `oracle` at every pose.
fn copies_hidden(name: &str, prep: &PreparedScene, oracle: &[Vec<u32>], which: &str) {
    for (k, o) in oracle.iter().enumerate() {
        for copy in prep.copies.ids() {
            assert!(
                !has_bit(o, copy),
                "{name}: pose {k}: the {which} oracle sees copy {copy}"
            );
        }
    }
}

fn quality(
    name: &str,
    map: &str,
    prep: &PreparedScene,
    plans: &[PosePlan],
    native: &[Vec<u32>],
    oracle: &[Vec<u32>],
) {
    let wrong = false_culls(plans, native, oracle);
    assert!(
        wrong.is_empty(),
        "{name} ({map} map): culled objects the CPU oracle sees: {wrong:?}"
    );

    // Efficiency and over-draw against the CPU oracle.
    let scene = &prep.scene;
    let (mut hidden, mut culled, mut kept_tris, mut oracle_tris) = (0u64, 0u64, 0u64, 0u64);
    for (k, p) in plans.iter().enumerate() {
        for &c in &p.candidates {
            let tris = scene.objects[c as usize].index_count as u64 / 3;
            let seen = has_bit(&oracle[k], c);
            let kept = has_bit(&native[k], c);
            hidden += !seen as u64;
            culled += (!seen && !kept) as u64;
            kept_tris += kept as u64 * tris;
            oracle_tris += seen as u64 * tris;
        }
    }
    let efficiency = culled as f64 / hidden.max(1) as f64;
    let overdraw = kept_tris as f64 / oracle_tris.max(1) as f64;
    eprintln!(
        "{name} ({map} map): refined efficiency {efficiency:.4}, kept/oracle triangles {overdraw:.4}"
    );
    assert!(
        efficiency >= FLOOR,
        "{name} ({map} map): refined efficiency {efficiency:.4} below {FLOOR}"
    );
    assert!(
        overdraw <= max_overdraw(name),
        "{name} ({map} map): kept/oracle triangles {overdraw:.4}"
    );
}

fn shared(file: &str) {
    let Some(dir) = common::scenes_dir() else {
        return;
    };
    check(load_path(&dir.join(file)).expect("shared scene loads"));
}

#[test]
fn demo_city_native() {
    check(demo_city());
}

#[test]
fn munich_native() {
    shared("munich.glb");
}

#[test]
fn etoile_native() {
    shared("etoile.glb");
}

#[test]
fn oa_shouse_native() {
    shared("oa_shouse.glb");
}

#[test]
fn oa_dm1_native() {
    shared("oa_dm1.glb");
}

#[test]
fn godot_room_native() {
    shared("godot_room.glb");
}

#[test]
fn fzk_haus_native() {
    shared("fzk_haus.glb");
}

/// Squares just behind, just in front of, and well behind a wall: the refinement
/// decides a near tie (a depth gap below its f32 margin, 3e-6 of the depth here) in
/// f64, as the oracle does, and culls only what the oracle hides.
#[test]
fn near_ties_are_decided_as_the_oracle_decides() {
    use homcull::core::scene::SceneBuilder;
    let square = |z: f32, half: f32| -> Vec<Vec3> {
        [(-half, -half), (half, -half), (half, half), (-half, half)]
            .iter()
            .map(|&(x, y)| Vec3::new(x + 0.13, y + 2.07, z))
            .collect()
    };
    let quad = [0, 1, 2, 0, 2, 3];
    let mut b = SceneBuilder::default();
    b.push("wall".into(), &square(0.0, 4.0), &quad, None);
    let cases = [
        ("just behind", -3e-5, false),
        ("well behind", -3e-4, false),
        ("just in front", 3e-5, true),
    ];
    for (name, dz, _) in cases {
        b.push(name.into(), &square(dz, 1.0), &quad, None);
    }
    let prep = PreparedScene::new(
        b.build("near ties"),
        OccluderParams {
            min_diagonal: 0.0,
            ..Default::default()
        },
    );
    let cam = look_at(
        Vec3::new(0.4, 2.3, 10.0),
        Vec3::new(0.1, 2.0, 0.0),
        320,
        180,
    );
    let exact = settings(&prep, Method::Exact, DebVariant::Raster, false);
    let oracle = ReferenceBackend
        .visibility(&prep, &[plan(&prep, &cam, &exact)], &exact)
        .unwrap();
    let hom = settings(&prep, Method::Hom, DebVariant::Raster, true);
    let served = served(
        &mut NativeBackend,
        &prep,
        std::slice::from_ref(&cam),
        &[plan(&prep, &cam, &hom)],
        &hom,
    );
    for (k, (name, _, seen)) in cases.into_iter().enumerate() {
        let id = k as u32 + 1;
        assert_eq!(has_bit(&oracle[0], id), seen, "{name}: the oracle");
        assert_eq!(has_bit(&served[0], id), seen, "{name}: the refinement");
    }
}
