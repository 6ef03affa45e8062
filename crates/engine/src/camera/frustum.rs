//! The frustum test of many boxes against one camera, plane by plane in lanes.
//!
//! [`Camera::intersects`] walks its six planes one after another through glam's `Vec3`
//! and is called out of line: in the planning of a street pose (the BVH query and the
//! test boxes of every candidate) it was ~40 % of the plan. [`FrustumPlanes`] holds the
//! same planes one coefficient per array, so that the six distances are one pass of
//! lane arithmetic that inlines into its caller's loop. It does the same f32 operations
//! in the same order as `Camera::intersects` (`((nx·px + ny·py) + nz·pz) + w`, no fused
//! multiply-add, which Rust never forms on its own), so it answers the same for every
//! box, bit for bit (tested on random boxes and cameras).

use super::{Camera, FRUSTUM_EPSILON};
use crate::geom::Aabb;

/// Lanes of [`FrustumPlanes`]: the six planes and two copies of the first (a copy
/// answers as the plane does, so the padding never changes the answer, whatever the
/// box, infinite corners of an empty box included).
const LANES: usize = 8;

/// A camera's six frustum planes laid out lane by lane ([`Camera::frustum_planes`]).
#[derive(Clone, Copy, Debug)]
pub struct FrustumPlanes {
    /// The planes' normals' x, y and z, and their offsets, lane `k` plane `k % 6`.
    nx: [f32; LANES],
    ny: [f32; LANES],
    nz: [f32; LANES],
    w: [f32; LANES],
}

impl FrustumPlanes {
    pub fn new(cam: &Camera) -> Self {
        let lane = |k: usize| cam.planes[k % cam.planes.len()].0;
        FrustumPlanes {
            nx: std::array::from_fn(|k| lane(k).x),
            ny: std::array::from_fn(|k| lane(k).y),
            nz: std::array::from_fn(|k| lane(k).z),
            w: std::array::from_fn(|k| lane(k).w),
        }
    }

    /// [`Camera::intersects`]: false only if the box lies wholly outside one plane (its
    /// corner farthest along the plane's normal is more than [`FRUSTUM_EPSILON`] out).
    #[inline(always)]
    pub fn intersects(&self, b: &Aabb) -> bool {
        let mut inside = true;
        for k in 0..LANES {
            // The corner farthest along the normal (`Plane::max_distance`).
            let px = if self.nx[k] >= 0.0 { b.max.x } else { b.min.x };
            let py = if self.ny[k] >= 0.0 { b.max.y } else { b.min.y };
            let pz = if self.nz[k] >= 0.0 { b.max.z } else { b.min.z };
            let d = ((self.nx[k] * px + self.ny[k] * py) + self.nz[k] * pz) + self.w[k];
            inside &= d >= -FRUSTUM_EPSILON;
        }
        inside
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::camera::look_at;

    /// A tiny deterministic generator (xorshift), so a failure repeats.
    fn next(state: &mut u64) -> f32 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 40) as f32 / (1u64 << 24) as f32
    }

    #[test]
    fn answers_as_the_camera_on_random_boxes() {
        let mut s = 0x9e37_79b9_7f4a_7c15;
        let mut disagreed = 0;
        let (mut inside, mut outside) = (0, 0);
        for _ in 0..200 {
            let v = |s: &mut u64| Vec3::new(next(s), next(s), next(s)) * 200.0 - 100.0;
            let (eye, target) = (v(&mut s), v(&mut s));
            if (target - eye).length() < 1.0 {
                continue;
            }
            let cam = look_at(eye, target, 320, 200);
            let planes = FrustumPlanes::new(&cam);
            for _ in 0..500 {
                let c = v(&mut s);
                let half = Vec3::new(next(&mut s), next(&mut s), next(&mut s)) * 20.0;
                let b = Aabb::new(c - half, c + half);
                let want = cam.intersects(&b);
                disagreed += usize::from(planes.intersects(&b) != want);
                if want {
                    inside += 1;
                } else {
                    outside += 1;
                }
            }
            // The empty box (infinite corners) and a degenerate point box.
            for b in [Aabb::EMPTY, Aabb::new(eye, eye)] {
                disagreed += usize::from(planes.intersects(&b) != cam.intersects(&b));
            }
        }
        assert_eq!(disagreed, 0);
        // Both answers were exercised.
        assert!(
            inside > 1000 && outside > 1000,
            "{inside} in, {outside} out"
        );
    }
}
