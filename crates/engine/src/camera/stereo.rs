//! The two eyes of a stereo pose.
//!
//! As the seed derives them for parallel optical axes: the eyes sit `ipd / 2` to the
//! left and right of the pose's position along the camera's right axis and look along
//! the pose's direction. Without a convergence distance each eye's frustum is the
//! pose's own, moved sideways (zero parallax at infinity). With one, `c`, each frustum
//! is also shifted off-axis so that the two images coincide at view depth `c`, the
//! zero-parallax plane: a point straight ahead of the pose at depth `c` lies `∓ipd/2`
//! to the side of each eye, which projects to NDC `∓scale·ipd / (2c)`, so each eye's
//! window moves by the opposite amount ([`Camera::shift`]). Both eyes keep the pose's
//! field of view, viewport, near and far planes.
//!
//! Culling both eyes stays conservative for each: every eye is culled as a camera of
//! its own (its own frustum, occlusion map and tests against the exact oracle's pixel
//! grid for that eye), and the answer is the union, so an object is left out only when
//! both eyes' tests leave it out.
//!
//! The eyes share one occluder selection ([`Camera::selection`]): the occluders are
//! chosen once, in the frustum of a camera set back behind the pair so that its
//! frustum encloses both eyes' ([`selection_camera`]), and each eye draws that same
//! list into its own map. A shared selection cannot hide anything an eye sees: an
//! occluder set is only a choice of which objects' own triangles an eye draws, each
//! drawn from that eye, clipped to its view and compared with its fragments, so the
//! map holds only real surfaces in front of whatever it hides; choosing other objects
//! changes how much is culled, never whether culling is conservative. Enclosing both
//! frusta keeps every occluder either eye could use in the choice (an occluder outside
//! one eye's frustum draws nothing there).

use std::sync::Arc;

use glam::{Mat4, Vec3};
use homcull_proto::Pose;

use super::{Camera, PoseError};

/// Largest accepted distance between the eyes, metres.
pub const MAX_IPD_M: f32 = 1.0;

/// The cameras of `pose`: the pose's own for a mono pose, the left then the right eye
/// for a stereo pose (see the module docs).
pub fn eyes(pose: &Pose) -> Result<Vec<Camera>, PoseError> {
    let center = Camera::new(pose)?;
    let Some(stereo) = pose.stereo else {
        return Ok(vec![center]);
    };
    if center.region.is_some() {
        return Err(PoseError::Region {
            field: "region",
            why: "is not taken with stereo yet: give the region that holds both eyes instead"
                .into(),
        });
    }
    let ipd = stereo.ipd_m;
    if !(ipd.is_finite() && ipd > 0.0 && ipd <= MAX_IPD_M) {
        return Err(PoseError::Ipd(ipd));
    }
    let shift_per_offset = match stereo.convergence_m {
        None => 0.0,
        Some(c) if c.is_finite() && c > pose.near => center.scale[0] / c,
        Some(c) => {
            return Err(PoseError::Convergence {
                convergence: c,
                near: pose.near,
            });
        }
    };
    let right = right_axis(&center);
    let selection = Arc::new(selection_camera(
        &center,
        pose.fov_y_deg,
        0.5 * ipd,
        (0.5 * ipd * shift_per_offset).abs(),
    ));
    [-0.5 * ipd, 0.5 * ipd]
        .into_iter()
        .map(|offset| {
            // Each eye is the mono camera of its own pose (so that culling it is culling
            // that pose, float for float), shifted off-axis when converging.
            let eye = Camera::new(&moved_along(pose, right, offset))?;
            let mut eye = match offset * shift_per_offset {
                0.0 => eye,
                shift => Camera::from_view_shifted(
                    eye.position,
                    eye.view,
                    pose.fov_y_deg,
                    eye.width,
                    eye.height,
                    eye.near,
                    eye.far,
                    shift,
                ),
            };
            eye.selection = Some(selection.clone());
            Ok(eye)
        })
        .collect()
}

/// A camera whose frustum encloses those of two eyes `half_ipd` to either side of
/// `center`, looking its way with its vertical field of view `fov_y_deg`, each
/// shifted off-axis by at most `shift` in NDC. In the centre's view coordinates an
/// eye at lateral offset `o` sees `o + t·d` for view depths `d ≥ near` and `|t| ≤ T`,
/// `T = (1 + shift) / scale_x`; a camera set back by `D = half_ipd / T` with lateral
/// tangent `T` sees `|x| ≤ T·(d + D)`, which holds there since `|o| ≤ T·D`.
/// Vertically, being set back only widens what it sees; its near plane stays where
/// the centre's is (nearer than the eyes' own, `D` behind it) and its far plane moves
/// back by `D`. The wider tangent comes from a wider viewport (the aspect ratio; the
/// selection never rasterizes with it).
fn selection_camera(center: &Camera, fov_y_deg: f32, half_ipd: f32, shift: f32) -> Camera {
    let lateral = (1.0 + shift) / center.scale[0];
    let back = half_ipd / lateral;
    let forward = -center.view.row(2).truncate().normalize();
    let view = Mat4::from_translation(Vec3::new(0.0, 0.0, -back)) * center.view;
    let width = (center.width as f32 * (1.0 + shift)).ceil() as u32;
    Camera::from_view(
        center.position - forward * back,
        view,
        fov_y_deg,
        width,
        center.height,
        center.near,
        center.far + back,
    )
}

/// The mono pose of the eye `offset` metres along `pose`'s right axis, looking the same
/// way (a `look_at` target moves with the eye); `pose` must be valid.
pub fn eye_pose(pose: &Pose, offset: f32) -> Pose {
    let right = Camera::new(pose).map_or(Vec3::X, |c| right_axis(&c));
    moved_along(pose, right, offset)
}

/// A camera's right axis in world space.
fn right_axis(cam: &Camera) -> Vec3 {
    cam.view.row(0).truncate().normalize()
}

/// `pose` moved `offset` metres along `right`, looking the same way, as a mono pose.
fn moved_along(pose: &Pose, right: Vec3, offset: f32) -> Pose {
    let moved = |p: [f32; 3]| (Vec3::from(p) + right * offset).to_array();
    Pose {
        position: moved(pose.position),
        look_at: pose.look_at.map(moved),
        stereo: None,
        ..pose.clone()
    }
}

#[cfg(test)]
mod tests {
    use homcull_proto::Stereo;

    use super::*;

    fn pose(stereo: Option<Stereo>) -> Pose {
        Pose {
            stereo,
            ..Pose::looking_at([1.0, 1.7, 2.0], [1.0, 1.7, -10.0])
        }
    }

    #[test]
    fn eyes_sit_apart_along_the_right_axis_looking_the_same_way() {
        let mono = pose(None);
        assert_eq!(eyes(&mono).unwrap(), vec![Camera::new(&mono).unwrap()]);
        let st = pose(Some(Stereo {
            ipd_m: 0.064,
            convergence_m: None,
        }));
        let [l, r] = <[Camera; 2]>::try_from(eyes(&st).unwrap()).unwrap();
        assert!(
            (l.position - Vec3::new(0.968, 1.7, 2.0)).length() < 1e-5,
            "{}",
            l.position
        );
        assert!(
            (r.position - Vec3::new(1.032, 1.7, 2.0)).length() < 1e-5,
            "{}",
            r.position
        );
        assert!((l.forward() - r.forward()).length() < 1e-6, "parallel axes");
        assert_eq!((l.shift, r.shift), (0.0, 0.0));
        // A far point ahead projects to the centre of both images.
        let far = Vec3::new(1.0, 1.7, -1e4);
        for cam in [&l, &r] {
            let c = cam.view_proj * far.extend(1.0);
            assert!((c.x / c.w).abs() < 1e-4);
        }
    }

    #[test]
    fn the_shared_selection_frustum_encloses_both_eyes() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        for (ipd, convergence) in [(0.064, None), (0.064, Some(0.5)), (1.0, Some(2.0))] {
            let mut st = pose(Some(Stereo {
                ipd_m: ipd,
                convergence_m: convergence,
            }));
            st.far = 60.0;
            let cams = eyes(&st).unwrap();
            let sel = cams[0]
                .selection
                .clone()
                .expect("eyes share a selection camera");
            assert!(Arc::ptr_eq(&sel, cams[1].selection.as_ref().unwrap()));
            for eye in &cams {
                let inverse = eye.view_proj.inverse();
                for _ in 0..4000 {
                    // A point of the eye's frustum, up to its corners and planes.
                    let ndc = glam::Vec4::new(
                        rng.random_range(-1.0..=1.0),
                        rng.random_range(-1.0..=1.0),
                        rng.random_range(0.0..=1.0),
                        1.0,
                    );
                    let p = inverse * ndc;
                    let p = p.truncate() / p.w;
                    for (i, plane) in sel.planes.iter().enumerate() {
                        let d = plane.distance(p);
                        assert!(d >= -1e-3 * (1.0 + p.length()), "plane {i}: {d} at {p}");
                    }
                }
            }
        }
    }

    #[test]
    fn converged_eyes_see_the_zero_parallax_plane_alike() {
        let st = pose(Some(Stereo {
            ipd_m: 0.064,
            convergence_m: Some(3.0),
        }));
        let [l, r] = <[Camera; 2]>::try_from(eyes(&st).unwrap()).unwrap();
        assert!(l.shift < 0.0 && r.shift > 0.0 && (l.shift + r.shift).abs() < 1e-7);
        // Points on the zero-parallax plane (3 m ahead) project to the same pixel in
        // both eyes; nearer points have negative parallax, farther ones positive.
        let ndc = |cam: &Camera, p: Vec3| {
            let c = cam.view_proj * p.extend(1.0);
            c.x / c.w
        };
        for x in [-0.5f32, 0.0, 0.7] {
            let p = Vec3::new(1.0 + x, 1.7, -1.0);
            assert!((ndc(&l, p) - ndc(&r, p)).abs() < 1e-5, "{x}");
        }
        let near = Vec3::new(1.0, 1.7, 1.0);
        let far = Vec3::new(1.0, 1.7, -20.0);
        assert!(ndc(&l, near) > ndc(&r, near), "in front of the plane");
        assert!(ndc(&l, far) < ndc(&r, far), "behind the plane");
        // The box projection agrees with the matrix.
        let b = crate::geom::Aabb {
            min: Vec3::new(0.9, 1.6, -1.1),
            max: Vec3::new(1.1, 1.8, -0.9),
        };
        for cam in [&l, &r] {
            let rect = cam.project_box(&b).unwrap();
            let centre = (ndc(cam, Vec3::new(1.0, 1.7, -1.0)) * 0.5 + 0.5) * cam.width as f32;
            assert!(
                (rect.x0 as f32) < centre && centre < rect.x1 as f32,
                "{rect:?} vs {centre}"
            );
        }
    }

    #[test]
    fn bad_stereo_parameters_are_refused() {
        for (ipd, convergence, err) in [
            (0.0, None, "ipd_m"),
            (f32::NAN, None, "ipd_m"),
            (1.5, None, "ipd_m"),
            (0.064, Some(0.05), "convergence_m"),
            (0.064, Some(f32::INFINITY), "convergence_m"),
        ] {
            let st = pose(Some(Stereo {
                ipd_m: ipd,
                convergence_m: convergence,
            }));
            let e = eyes(&st).unwrap_err().to_string();
            assert!(e.contains(err), "{ipd} {convergence:?}: {e}");
        }
    }
}
