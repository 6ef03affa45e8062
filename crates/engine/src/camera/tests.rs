//! The camera's conventions, checked: projection and unprojection, pose validation,
//! box projection (near clipping, the side-by-side fast path).

use super::*;

fn cam() -> Camera {
    look_at(Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, 200, 100)
}

#[test]
fn the_side_by_side_projection_equals_the_corner_by_corner_one() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let (mut in_front, mut clipped) = (0, 0);
    for round in 0..20000 {
        let eye = Vec3::new(
            rng.random_range(-50.0..50.0),
            rng.random_range(0.5..30.0),
            rng.random_range(-50.0..50.0),
        );
        let target = eye
            + Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-0.6..0.3),
                rng.random_range(-1.0..1.0),
            );
        let cam = look_at(eye, target, 960, 540);
        let scale = [0.01, 1.0, 20.0][round % 3];
        let c = Vec3::new(
            rng.random_range(-60.0..60.0),
            rng.random_range(-5.0..40.0),
            rng.random_range(-60.0..60.0),
        );
        let e = Vec3::new(
            rng.random_range(0.0..1.0),
            rng.random_range(0.0..1.0),
            rng.random_range(0.0..1.0),
        ) * scale;
        let b = Aabb::new(c - e, c + e);
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx") {
            // SAFETY: AVX was detected on this CPU just above.
            let lanes = unsafe { cam.project_box_avx(&b) };
            assert_eq!(lanes, cam.project_box(&b), "AVX lanes: {b:?} from {eye}");
        }
        match cam.project_box_in_front(&b) {
            Some(r) => {
                assert_eq!(r, cam.project_box_clipped(&b), "{b:?} from {eye}");
                in_front += 1;
            }
            None => clipped += 1,
        }
    }
    assert!(
        in_front > 5000 && clipped > 1000,
        "{in_front} in front, {clipped} not"
    );
}

#[test]
fn unproject_pixel_inverts_projection() {
    let cam = look_at(
        Vec3::new(3.0, 2.0, 10.0),
        Vec3::new(0.5, 1.0, 0.0),
        200,
        100,
    );
    for (x, y, depth) in [(0, 0, 1.0), (199, 99, 7.5), (37, 61, 30.0)] {
        let p = cam.unproject_pixel(x, y, depth);
        let (sx, sy, d) = project_point(&cam, p);
        assert!((sx - (x as f32 + 0.5)).abs() < 1e-3, "{sx} vs {x}");
        assert!((sy - (y as f32 + 0.5)).abs() < 1e-3, "{sy} vs {y}");
        assert!((d - depth).abs() < 1e-3 * depth);
        assert!((cam.depth_of(p) - depth).abs() < 1e-3 * depth);
    }
}

#[test]
fn rejects_bad_poses() {
    let mut p = Pose::looking_at([0.0; 3], [0.0, 0.0, -1.0]);
    assert!(Camera::new(&p).is_ok());
    p.position[0] = f32::NAN;
    assert_eq!(Camera::new(&p), Err(PoseError::NotFinite("position")));
    p.position[0] = 0.0;
    p.viewport = [0, 10];
    assert!(matches!(Camera::new(&p), Err(PoseError::Viewport { .. })));
    p.viewport = [10, 10];
    p.near = 0.0;
    assert!(matches!(Camera::new(&p), Err(PoseError::Planes { .. })));
    p.near = 0.1;
    p.rotation = Some([0.0, 0.0, 0.0, 1.0]);
    assert_eq!(Camera::new(&p), Err(PoseError::BothOrientations));
    p.look_at = None;
    p.rotation = Some([0.0; 4]);
    assert_eq!(Camera::new(&p), Err(PoseError::Rotation));
    p.rotation = Some([1e30, 1e30, 0.0, 1e30]);
    assert_eq!(Camera::new(&p), Err(PoseError::Rotation));
    p.rotation = None;
    p.look_at = Some([0.0, 5.0, 0.0]);
    assert_eq!(Camera::new(&p), Err(PoseError::LookAt));
}

#[test]
fn rotation_and_look_at_agree() {
    // Identity rotation looks along −Z, as look_at towards −Z does.
    let mut p = Pose::looking_at([1.0, 2.0, 3.0], [1.0, 2.0, -5.0]);
    let a = Camera::new(&p).unwrap();
    p.look_at = None;
    p.rotation = Some([0.0, 0.0, 0.0, 1.0]);
    let b = Camera::new(&p).unwrap();
    assert!(a.view.abs_diff_eq(b.view, 1e-5));
    assert!((a.forward() - Vec3::NEG_Z).length() < 1e-5);
}

#[test]
fn reversed_z_and_depth() {
    let c = cam();
    let near = c.view_proj * Vec4::new(0.0, 0.0, 10.0 - c.near, 1.0);
    let far = c.view_proj * Vec4::new(0.0, 0.0, 10.0 - c.far, 1.0);
    assert!((near.z / near.w - 1.0).abs() < 1e-5);
    assert!((far.z / far.w).abs() < 1e-5);
    assert!((c.depth_of(Vec3::ZERO) - 10.0).abs() < 1e-5);
    assert!((near.w - c.near).abs() < 1e-5);
}

#[test]
fn rect_contains_projected_points() {
    let c = cam();
    let b = Aabb::new(Vec3::new(-1.0, -1.0, -1.0), Vec3::new(2.0, 0.5, 1.0));
    let r = c.project_box(&b).unwrap();
    for p in b.corners() {
        let (x, y, d) = project_point(&c, p);
        assert!(x >= r.x0 as f32 && x <= r.x1 as f32 && y >= r.y0 as f32 && y <= r.y1 as f32);
        assert!(d >= r.near - 1e-4 && d <= r.far + 1e-4);
    }
    assert!((r.near - 9.0).abs() < 1e-4 && (r.far - 11.0).abs() < 1e-4);
}

#[test]
fn near_clipped_box_uses_near_depth() {
    let c = cam();
    let b = Aabb::new(Vec3::new(-0.5, -0.5, 5.0), Vec3::new(0.5, 0.5, 20.0));
    let r = c.project_box(&b).unwrap();
    assert_eq!(r.near, c.near);
    // Box behind the camera projects to nothing.
    assert!(
        c.project_box(&Aabb::new(
            Vec3::new(-1.0, -1.0, 11.0),
            Vec3::new(1.0, 1.0, 12.0)
        ))
        .is_none()
    );
}

#[test]
fn box_with_one_corner_in_front_spans_the_clip_points() {
    // Flat ground box around the camera, only one corner ahead of it: the clipped
    // polygon spans the whole screen width.
    let c = look_at(
        Vec3::new(0.0, 1.7, 0.0),
        Vec3::new(-1.0, 1.6, 0.0),
        960,
        540,
    );
    let b = Aabb::new(Vec3::new(-10.0, 0.0, -30.0), Vec3::new(60.0, 0.0, 40.0));
    let r = c.project_box(&b).unwrap();
    assert_eq!((r.x0, r.x1), (0, 960));
    assert_eq!(r.near, c.near);
}

#[test]
fn frustum_rejects_outside() {
    let c = cam();
    assert!(c.intersects(&Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0))));
    assert!(!c.intersects(&Aabb::new(
        Vec3::new(500.0, 0.0, 0.0),
        Vec3::new(501.0, 1.0, 1.0)
    )));
    assert!(!c.intersects(&Aabb::new(
        Vec3::new(0.0, 0.0, 11.0),
        Vec3::new(1.0, 1.0, 12.0)
    )));
}
