//! Visibility from a region (`Pose::region`, `core::region`) against the exact oracle
//! at eyes sampled in the region: nothing any of them sees may be missing.
//!
//! On the demo city and every shared scene, street-level poses with balls of radius
//! 0.1–2 m and turns of 0–30°, 64 eyes each (the centre, points of the ball's surface
//! and interior) looking along directions across the cone (its axis and its rim);
//! and box regions of every direction on the demo city. The oracle is the native
//! backend's exact ID buffer at each eye, its own pixel grid.

use crate::common;
use homcull::eval::region_eyes::Xorshift as Rng;

use glam::Vec3;
use homcull::core::camera::Camera;
use homcull::core::cull::{Culler, PreparedScene};
use homcull::core::native::NativeBackend;
use homcull::core::occluders::OccluderParams;
use homcull::core::region;
use homcull::core::sampler::PoseSampler;
use homcull::core::scene::demo_city;
use homcull::eval::region_eyes::{ball_region, eyes_in_ball};
use homcull_proto::{DebVariant, Method, Pose, Region};

const RADII: [f32; 4] = [0.1, 0.5, 1.0, 2.0];
const TURNS: [f32; 3] = [0.0, 10.0, 30.0];
const EYES: usize = 64;

/// Region answers for `n` sampled poses of `prep`: returns the objects missing
/// (seen by an eye's oracle, not in the answer), and the kept and seen triangles.
fn check(name: &str, prep: &PreparedScene, n: usize, seed: u64) -> (usize, u64, u64) {
    let hom = common::scenes::settings(prep, Method::Hom, DebVariant::Raster, false);
    let exact = common::scenes::settings(prep, Method::Exact, DebVariant::Raster, false);
    let sampled = PoseSampler::new(&prep.scene).sample(n, seed, [480, 270], &|_| true);
    let mut rng = Rng::new(seed);
    let tris = |ids: &[u32]| -> u64 {
        ids.iter()
            .map(|&id| prep.scene.objects[id as usize].triangles() as u64)
            .sum()
    };
    let (mut missing, mut kept, mut seen, mut ms) = (0, 0u64, 0u64, 0.0);
    let mut unseen = std::collections::BTreeMap::new();
    for (i, pose) in sampled.poses.iter().enumerate() {
        let (radius, turn) = (RADII[i % RADII.len()], TURNS[i % TURNS.len()]);
        let forward = Camera::new(pose).unwrap().forward();
        let asked = ball_region(pose, radius, turn);
        let cam = Camera::new(&asked).unwrap();
        // The answer is the candidates some verdict keeps (`region::cull` serves the
        // same judgement); the verdicts say why the unseen ones were kept.
        let started = std::time::Instant::now();
        let judged = region::explain(prep, &cam, cam.region.as_ref().unwrap(), &hom);
        ms += started.elapsed().as_secs_f64() * 1e3;
        let visible: Vec<u32> = judged
            .iter()
            .filter(|(_, v)| v.is_some())
            .map(|&(id, _)| id)
            .collect();
        let eyes: Vec<Camera> = eyes_in_ball(&mut rng, pose, forward, radius, turn, EYES)
            .iter()
            .map(|p| Camera::new(p).unwrap())
            .collect();
        let mut union = Vec::new();
        for oracle in NativeBackend.cull(prep, &eyes, &exact).unwrap() {
            union = homcull::core::cull::union(&union, &oracle.visible);
        }
        let lost: Vec<u32> = union
            .iter()
            .copied()
            .filter(|id| visible.binary_search(id).is_err())
            .collect();
        assert!(
            lost.is_empty(),
            "{name}: pose {i} {asked:?}: eyes of the region see {lost:?}, not in the answer"
        );
        missing += lost.len();
        // Why the answer keeps what no eye saw, by triangles.
        for &(id, why) in &judged {
            if let Some(v) = why {
                if union.binary_search(&id).is_err() {
                    *unseen.entry(format!("{v:?}")).or_insert(0u64) += tris(&[id]);
                }
            }
        }
        if let Some(dir) = std::env::var_os("HOMCULL_REGION_IMAGES") {
            let leaky: Vec<_> = judged
                .iter()
                .filter(|&&(id, why)| {
                    why == Some(region::Verdict::Leak) && union.binary_search(&id).is_err()
                })
                .map(|&(id, _)| prep.scene.objects[id as usize].aabb)
                .collect();
            let maps = region::draw_maps(prep, &cam, cam.region.as_ref().unwrap(), &hom);
            let (w, h, rgb) = maps[0].debug_rgb(&leaky);
            let mut ppm = format!("P6 {w} {h} 255\n").into_bytes();
            ppm.extend(rgb);
            let file = std::path::Path::new(&dir).join(format!("{name}_{i}.ppm"));
            std::fs::write(file, ppm).unwrap();
        }
        kept += tris(&visible);
        seen += tris(&union);
    }
    eprintln!(
        "{name}: {n} regions × {EYES} eyes, {missing} missing, kept ÷ seen triangles {:.3}, \
         {:.1} ms per region; kept and unseen triangles by why they were kept: {unseen:?}",
        kept as f64 / seen.max(1) as f64,
        ms / n as f64
    );
    (missing, kept, seen)
}

fn demo() -> PreparedScene {
    PreparedScene::new(demo_city(), OccluderParams::default())
}

#[test]
fn nothing_an_eye_of_the_region_sees_is_culled() {
    for (name, scene) in common::scenes::demo_and_shared() {
        let prep = PreparedScene::new(scene, OccluderParams::default());
        let (missing, kept, seen) = check(&name, &prep, 12, 3);
        assert_eq!(missing, 0, "{name}");
        assert!(kept >= seen, "{name}: the answer holds what the eyes see");
    }
}

#[test]
fn a_region_answer_culls_what_walls_hide_on_the_demo_street() {
    let prep = demo();
    let objects = prep.scene.objects.len();
    let pose = Pose::looking_at([0.0, 1.7, 0.0], [40.0, 1.7, 0.0]);
    let asked = Pose {
        region: Some(Region {
            radius_m: Some(0.5),
            turn_deg: Some(10.0),
            ..Region::default()
        }),
        viewport: [480, 270],
        ..pose
    };
    let cam = Camera::new(&asked).unwrap();
    let hom = common::scenes::settings(&prep, Method::Hom, DebVariant::Raster, false);
    let r = region::cull(&prep, &cam, cam.region.as_ref().unwrap(), &hom);
    eprintln!(
        "demo street, r = 0.5 m, 10°: {} of {} candidates kept ({} objects)",
        r.visible.len(),
        r.candidates.len(),
        objects
    );
    assert!(
        r.visible.len() * 2 < r.candidates.len(),
        "a region answer on the street keeps {} of {} candidates",
        r.visible.len(),
        r.candidates.len()
    );
}

#[test]
fn a_box_of_eyes_looking_every_way_sees_nothing_outside_its_answer() {
    let prep = demo();
    let hom = common::scenes::settings(&prep, Method::Hom, DebVariant::Raster, false);
    let exact = common::scenes::settings(&prep, Method::Exact, DebVariant::Raster, false);
    let sampled = PoseSampler::new(&prep.scene).sample(2, 11, [320, 180], &|_| true);
    let mut rng = Rng(7);
    let directions = [Vec3::X, Vec3::NEG_X, Vec3::Z, Vec3::NEG_Z];
    for pose in &sampled.poses {
        let c = Vec3::from(pose.position);
        let half = Vec3::new(0.3, 0.2, 0.3);
        let (lo, hi) = (c - half, c + half);
        let asked = Pose {
            region: Some(Region {
                bounds: Some([lo.to_array(), hi.to_array()]),
                all_directions: true,
                ..Region::default()
            }),
            ..pose.clone()
        };
        let cam = Camera::new(&asked).unwrap();
        let answer = region::cull(&prep, &cam, cam.region.as_ref().unwrap(), &hom);
        let eyes: Vec<Camera> = (0..16)
            .flat_map(|k| {
                let e = match k {
                    0 => c,
                    1 => lo,
                    2 => hi,
                    _ => lo + (hi - lo) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()),
                };
                directions.map(|d| {
                    let p = Pose {
                        position: e.to_array(),
                        rotation: None,
                        look_at: Some((e + d).to_array()),
                        up: Some([0.0, 1.0, 0.0]),
                        region: None,
                        ..pose.clone()
                    };
                    Camera::new(&p).unwrap()
                })
            })
            .collect();
        for oracle in NativeBackend.cull(&prep, &eyes, &exact).unwrap() {
            let lost: Vec<_> = oracle
                .visible
                .iter()
                .filter(|id| answer.visible.binary_search(id).is_err())
                .collect();
            assert!(lost.is_empty(), "box {lo}..{hi}: an eye sees {lost:?}");
        }
        eprintln!(
            "box {lo}..{hi}, every direction: {} of {} objects kept",
            answer.visible.len(),
            prep.scene.objects.len()
        );
        assert!(answer.visible.len() < prep.scene.objects.len());
    }
}
