//! Level-of-detail hints against a reference computed independently from the exact
//! projected bounds: the box clipped at the near plane in clip space (the
//! `view_proj` matrix, not the camera's view-and-scale arithmetic), projected, clamped
//! to the viewport. Levels must agree except where the reference size lies within
//! 0.01 px of a threshold (the two float paths may round either way there; a size
//! equal to a threshold takes the finer level).

use crate::common;

use glam::{Vec3, Vec4};
use homcull::core::camera::{BOX_EDGES, Camera};
use homcull::core::cull::PreparedScene;
use homcull::core::geom::Aabb;
use homcull::core::lod;
use homcull::core::occluders::OccluderParams;
use homcull::core::sampler::PoseSampler;
use homcull::core::scene::Scene;
use homcull_proto::LodThresholds;

/// The reference size: larger side of the clamped float bounds (0 if none).
fn reference_size(cam: &Camera, b: &Aabb) -> f32 {
    let corners: Vec<Vec4> = b
        .corners()
        .iter()
        .map(|c| cam.view_proj * c.extend(1.0))
        .collect();
    // Clip w is the view depth: keep what is in front of the near plane.
    let mut points: Vec<Vec4> = corners
        .iter()
        .copied()
        .filter(|c| c.w >= cam.near)
        .collect();
    for (a, c) in BOX_EDGES {
        let (pa, pc) = (corners[a], corners[c]);
        if (pa.w < cam.near) != (pc.w < cam.near) {
            let t = (cam.near - pa.w) / (pc.w - pa.w);
            points.push(pa + (pc - pa) * t);
        }
    }
    if points.is_empty() {
        return 0.0;
    }
    let (w, h) = (cam.width as f32, cam.height as f32);
    let px = |p: &Vec4| {
        let (x, y) = (p.x / p.w, p.y / p.w);
        Vec3::new((x * 0.5 + 0.5) * w, (0.5 - y * 0.5) * h, 0.0)
    };
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for p in &points {
        lo = lo.min(px(p));
        hi = hi.max(px(p));
    }
    let (x0, x1) = (lo.x.clamp(0.0, w), hi.x.clamp(0.0, w));
    let (y0, y1) = (lo.y.clamp(0.0, h), hi.y.clamp(0.0, h));
    if x0 >= x1 || y0 >= y1 {
        return 0.0;
    }
    (x1 - x0).max(y1 - y0)
}

/// Checks every in-frustum object of `n` street poses of `scene`; returns how many
/// levels were compared and how many were ties left unchecked.
fn check_scene(name: &str, scene: Scene, n: usize) -> (usize, usize) {
    let prep = PreparedScene::new(scene, OccluderParams::default());
    let thresholds = LodThresholds::new(&[200.0, 64.0, 16.0, 4.0]).unwrap();
    let sampled = PoseSampler::new(&prep.scene).sample(n, 11, [960, 540], &|_| true);
    let (mut compared, mut ties) = (0, 0);
    let mut per_level = [0usize; 5];
    for pose in &sampled.poses {
        let cam = Camera::new(pose).unwrap();
        let mut ids = Vec::new();
        prep.bvh.frustum_query(&cam, |i| ids.push(i));
        ids.sort_unstable();
        let objects = &prep.scene.objects;
        let levels = lod::levels(
            std::slice::from_ref(&cam),
            &ids,
            |id| objects[id as usize].aabb,
            &thresholds,
        );
        for (&id, &level) in ids.iter().zip(&levels) {
            let size = reference_size(&cam, &objects[id as usize].aabb);
            if thresholds.px().iter().any(|t| (size - t).abs() < 0.01) {
                ties += 1;
                continue;
            }
            assert_eq!(
                level,
                thresholds.level(size),
                "{name}: object {id} at {pose:?}: reference size {size} px"
            );
            per_level[level as usize] += 1;
            compared += 1;
        }
    }
    eprintln!("{name}: {compared} levels agree ({ties} ties unchecked), per level {per_level:?}");
    assert!(
        per_level.iter().filter(|&&c| c > 0).count() >= 3,
        "{name}: the thresholds exercise several levels: {per_level:?}"
    );
    (compared, ties)
}

#[test]
fn levels_agree_with_the_exact_projected_bounds() {
    for (name, scene) in common::scenes::demo_and_shared() {
        let (compared, _) = check_scene(&name, scene, 40);
        if name == "demo" {
            assert!(compared > 10_000, "{compared}");
        }
    }
}

#[test]
fn the_eye_that_sees_an_object_larger_sets_its_level() {
    let cam = |x: f32| {
        Camera::new(&homcull_proto::Pose {
            position: [x, 1.7, 0.0],
            rotation: None,
            look_at: Some([x, 1.7, -10.0]),
            up: None,
            fov_y_deg: 60.0,
            viewport: [960, 540],
            near: 0.1,
            far: 1000.0,
            stereo: None,
            region: None,
        })
        .unwrap()
    };
    // A box seen half off the left edge by one eye and whole by the other.
    let b = Aabb {
        min: Vec3::new(-7.0, 1.0, -10.5),
        max: Vec3::new(-5.0, 2.0, -9.5),
    };
    let (left, right) = (cam(-3.0), cam(3.0));
    let size = |eyes: &[Camera]| lod::projected_size(eyes, &b);
    let (l, r) = (
        size(std::slice::from_ref(&left)),
        size(std::slice::from_ref(&right)),
    );
    assert_eq!(size(&[left, right]), l.max(r));
    assert!(
        l.max(r) > l.min(r) + 1.0,
        "the eyes see it at different sizes: {l} vs {r}"
    );
}
