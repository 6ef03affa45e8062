//! Eyes sampled in a region, to check a region answer against the exact oracle.
//!
//! A union of point answers is not a region answer (it misses what shows between the
//! samples), but the converse is a test: every object the oracle sees from any eye of
//! the region must be in the region's answer. The eyes are the pose itself, then
//! points of the ball's surface and interior, alternately, each looking along a
//! direction of the cone (every fourth on its rim, where a turn reveals the most).

use glam::{Quat, Vec3};
use homcull_proto::{Pose, Region};

/// A small deterministic generator (xorshift64) for eyes and directions.
#[derive(Debug, Clone)]
pub struct Xorshift(pub u64);

impl Xorshift {
    /// A generator for `seed` (any value; zero is mapped to a non-zero state).
    pub fn new(seed: u64) -> Self {
        Xorshift(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }

    /// Uniform in [0, 1).
    pub fn next_f32(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }

    /// A point of the unit ball: on its surface when `surface`.
    pub fn in_ball(&mut self, surface: bool) -> Vec3 {
        loop {
            let v = Vec3::new(self.next_f32(), self.next_f32(), self.next_f32()) * 2.0 - 1.0;
            let l = v.length();
            if l > 1e-3 && l <= 1.0 {
                return if surface { v / l } else { v };
            }
        }
    }
}

/// `n` eye poses of the ball region around `pose` (its position and view direction
/// `forward`, unit): radius `radius` m, directions within `turn_deg` of `forward`.
/// The first is the pose's own eye and direction; each keeps the pose's field of view,
/// viewport and clip planes, and has no region of its own.
pub fn eyes_in_ball(
    rng: &mut Xorshift,
    pose: &Pose,
    forward: Vec3,
    radius: f32,
    turn_deg: f32,
    n: usize,
) -> Vec<Pose> {
    let centre = Vec3::from(pose.position);
    let turn = turn_deg.to_radians();
    (0..n)
        .map(|k| {
            if k == 0 {
                return looking(pose, centre, forward);
            }
            let eye = centre + rng.in_ball(k % 2 == 1) * radius;
            let side = forward.cross(Vec3::Y).normalize_or(Vec3::X);
            let axis =
                Quat::from_axis_angle(forward, rng.next_f32() * std::f32::consts::TAU) * side;
            let angle = if k % 4 == 3 {
                turn
            } else {
                turn * rng.next_f32()
            };
            looking(pose, eye, Quat::from_axis_angle(axis, angle) * forward)
        })
        .collect()
}

/// `pose` asked as the ball region of radius `radius_m` turning `turn_deg` about it.
pub fn ball_region(pose: &Pose, radius_m: f32, turn_deg: f32) -> Pose {
    Pose {
        region: Some(Region {
            radius_m: Some(radius_m),
            turn_deg: Some(turn_deg),
            ..Region::default()
        }),
        ..pose.clone()
    }
}

/// `pose` moved to `eye`, looking along `dir`, with no region or stereo.
fn looking(pose: &Pose, eye: Vec3, dir: Vec3) -> Pose {
    Pose {
        position: eye.to_array(),
        rotation: None,
        look_at: Some((eye + dir).to_array()),
        up: Some([0.0, 1.0, 0.0]),
        region: None,
        stereo: None,
        ..pose.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eyes_lie_in_the_ball_and_look_within_the_cone() {
        let pose = Pose {
            position: [1.0, 2.0, 3.0],
            rotation: None,
            look_at: Some([1.0, 2.0, 2.0]),
            up: None,
            fov_y_deg: 60.0,
            viewport: [64, 36],
            near: 0.1,
            far: 100.0,
            stereo: None,
            region: None,
        };
        let forward = Vec3::NEG_Z;
        let mut rng = Xorshift::new(5);
        let eyes = eyes_in_ball(&mut rng, &pose, forward, 0.5, 20.0, 64);
        assert_eq!(eyes.len(), 64);
        assert_eq!(eyes[0].position, pose.position);
        let (mut on_surface, mut on_rim) = (0, 0);
        for e in &eyes {
            let d = Vec3::from(e.position).distance(Vec3::from(pose.position));
            assert!(d <= 0.5 + 1e-5, "{d}");
            on_surface += usize::from(d > 0.5 - 1e-4);
            let dir = (Vec3::from(e.look_at.unwrap()) - Vec3::from(e.position)).normalize();
            let angle = dir.angle_between(forward).to_degrees();
            assert!(angle <= 20.0 + 1e-3, "{angle}");
            on_rim += usize::from(angle > 20.0 - 1e-2);
            assert!(e.region.is_none() && e.stereo.is_none());
        }
        assert_eq!(on_surface, 32, "every odd eye on the surface");
        assert_eq!(on_rim, 16, "every fourth eye on the rim");
    }
}
