//! Region streams (`?region_m=R&turn_deg=T`): one cull per region, not per pose.
//!
//! The stream culls the region of eyes within `R` of a centre, looking within `T` of
//! the pose's direction (`core::region`), announces it with a region frame and sends
//! its set; the poses that follow are answered with empty deltas, without a cull, for
//! as long as they stay in the inner part of that region ([`HOLD_FRACTION`] of its
//! radius and turn), at the same frustum shape and scene version, and within the
//! scene's motion horizon (a moving object's test boxes are swept over it and no
//! further). A pose outside culls the next region, its centre set a quarter of the
//! radius ahead along the client's motion, so that the client, a round trip behind,
//! walks into it: the region answer holds for every eye inside, so a client that
//! draws the set while its own pose lies in the announced region never misses what
//! its view shows. `R` is the least radius: a client too fast for it (its speed over
//! the last region's answer time and the round trip) gets a larger next region
//! ([`RegionSpec::radius`]), so that it stays inside until the next one reaches it;
//! an overloaded server then culls less often, not later.

use std::time::{Duration, Instant};

use glam::Vec3;
use homcull_proto::frame::{Frame, FrameStats, RegionFrame};
use homcull_proto::{Pose, Region};

use super::Pending;
use super::frames::{Sent, visibility_frame};
use homcull_engine::camera::Camera;
use homcull_engine::camera::region::{MAX_RADIUS_M, MAX_TURN_DEG};

/// The part of a region's radius and turn within which a pose keeps the held set: the
/// rest is the client's margin for the round trip of the next region.
pub(super) const HOLD_FRACTION: f32 = 0.5;
/// Slowest motion (m/s) that moves the next region's centre ahead.
const MIN_SPEED: f32 = 0.05;
/// How much more than the measured latency the outer part of a region must last.
const SIZE_MARGIN: f32 = 1.5;

/// What a region stream asked for.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub(super) struct RegionSpec {
    pub radius_m: f32,
    pub turn_deg: f32,
}

impl RegionSpec {
    /// The spec of a stream's query, checked (`None`: a point stream).
    pub(super) fn of(radius_m: Option<f32>, turn_deg: Option<f32>) -> Result<Option<Self>, String> {
        let Some(r) = radius_m else {
            return match turn_deg {
                Some(_) => Err("turn_deg needs region_m".into()),
                None => Ok(None),
            };
        };
        if !(r.is_finite() && r > 0.0 && r <= MAX_RADIUS_M) {
            return Err(format!(
                "region_m must be in (0, {MAX_RADIUS_M}] metres, got {r}"
            ));
        }
        let t = turn_deg.unwrap_or(0.0);
        if !(t.is_finite() && (0.0..=MAX_TURN_DEG).contains(&t)) {
            return Err(format!(
                "turn_deg must be in [0, {MAX_TURN_DEG}] degrees, got {t}"
            ));
        }
        Ok(Some(RegionSpec {
            radius_m: r,
            turn_deg: t,
        }))
    }

    /// The radius of the next region for a client moving at `speed` (m/s), whose
    /// last region took `answer` from its pose's arrival to its frame (the cull and
    /// its wait for the worker) and whose round trip is `rtt`: the stream's, or more
    /// where the client would cross the region's outer part (1 − [`HOLD_FRACTION`])
    /// before the next region could reach it, up to [`MAX_RADIUS_M`]. The turn
    /// stays as asked (a wider turn widens the map, and its cost).
    pub(super) fn radius(&self, speed: f32, answer: Duration, rtt: Duration) -> f32 {
        let late = (answer + rtt).as_secs_f32();
        let needed = SIZE_MARGIN * speed * late / (1.0 - HOLD_FRACTION);
        if needed.is_nan() {
            self.radius_m
        } else {
            self.radius_m.max(needed.min(MAX_RADIUS_M))
        }
    }

    /// The region pose to cull for pose `p`, of radius `radius`: centred a quarter of
    /// the radius ahead along its motion, turning about its direction; `None` for a
    /// stereo pose (region streams take mono poses).
    pub(super) fn pose(&self, p: &Pending, radius: f32) -> Option<Pose> {
        if p.pose.stereo.is_some() {
            return None;
        }
        let v = p.velocity;
        let ahead = if v.length() > MIN_SPEED {
            v.normalize() * (0.25 * radius)
        } else {
            Vec3::ZERO
        };
        let centre = Vec3::from(p.pose.position) + ahead;
        Some(Pose {
            position: centre.to_array(),
            region: Some(Region {
                radius_m: Some(radius),
                turn_deg: Some(self.turn_deg),
                ..Region::default()
            }),
            ..p.pose.clone()
        })
    }
}

impl RegionSpec {
    /// The region pose for pose `p` ([`RegionSpec::pose`]), sized by the last region
    /// `last` and the client's round trip `rtt` ([`RegionSpec::radius`]), and its
    /// camera, or why it cannot be culled.
    pub(super) fn camera(
        &self,
        p: &Pending,
        last: Option<&Held>,
        rtt: Duration,
    ) -> Result<(Pose, Camera), String> {
        let answer = last.map_or(Duration::ZERO, |h| h.answer_took);
        let radius = self.radius(p.velocity.length(), answer, rtt);
        let asked = self
            .pose(p, radius)
            .ok_or_else(|| "stereo: a region stream takes mono poses".to_string())?;
        let cam = Camera::new(&asked).map_err(|e| e.to_string())?;
        Ok((asked, cam))
    }
}

/// The region whose set the client holds, and what a pose must match to keep it.
pub(super) struct Held {
    pub frame: RegionFrame,
    /// The stats of the frame that sent its set (what empty deltas repeat).
    pub stats: FrameStats,
    /// The region pose (its frustum shape).
    pose: Pose,
    /// The view axes of the pose it was culled for.
    forward: Vec3,
    up: Vec3,
    version: u64,
    /// When the scene's motion makes the set stale (`None`: nothing moves).
    until: Option<Instant>,
    /// From its pose's arrival to its region frame (what sizes the next region).
    answer_took: Duration,
}

impl Held {
    /// The region `asked` culled for the pose whose camera is `eye` (arrived at
    /// `started`), at scene `version`, held at most `horizon` (`None`: nothing moves).
    pub(super) fn new(
        (seq, ack): (u32, u32),
        (asked, eye): (&Pose, &Camera),
        started: Instant,
        version: u64,
        horizon: Option<Duration>,
    ) -> Self {
        let spec = asked.region.unwrap_or_default();
        let (forward, up) = (eye.forward(), eye.up());
        Held {
            frame: RegionFrame {
                seq,
                ack,
                centre: asked.position,
                radius_m: spec.radius_m.unwrap_or(0.0),
                axis: forward.to_array(),
                turn_deg: spec.turn_deg.unwrap_or(0.0),
            },
            stats: FrameStats::default(),
            pose: asked.clone(),
            forward,
            up,
            version,
            until: horizon.map(|h| Instant::now() + h),
            answer_took: started.elapsed(),
        }
    }

    /// Whether pose `p` keeps the held set: the same frustum shape, the scene at the
    /// same version, within the horizon, and its eye in the inner part of the region.
    pub(super) fn holds(&self, p: &Pending, version: u64, now: Instant) -> bool {
        let (a, b) = (&self.pose, &p.pose);
        let shape = a.fov_y_deg == b.fov_y_deg
            && a.viewport == b.viewport
            && a.near == b.near
            && a.far == b.far
            && b.stereo.is_none();
        if !shape || version != self.version || self.until.is_some_and(|u| now >= u) {
            return false;
        }
        let f = &self.frame;
        let inside =
            Vec3::from(b.position).distance(Vec3::from(f.centre)) <= HOLD_FRACTION * f.radius_m;
        let Some(eye) = p.eyes.first() else {
            return false;
        };
        let (forward, up) = (eye.forward(), eye.up());
        let turned = if f.turn_deg == 0.0 {
            // No turn: the very view the region was culled for.
            (forward, up) == (self.forward, self.up)
        } else {
            forward.angle_between(self.forward) <= HOLD_FRACTION * f.turn_deg.to_radians()
        };
        inside && turned
    }
}

impl Held {
    /// The answer to a pose inside the region, without a cull: the held set again,
    /// an empty delta (or a full frame when `want_full`) with the region's stats.
    pub(super) fn answer(
        &self,
        (seq, ack): (u32, u32),
        dropped: u32,
        started: Instant,
        held: Sent<'_>,
        want_full: bool,
    ) -> Frame {
        let stats = FrameStats {
            dropped_poses: dropped,
            gpu_us: 0,
            total_us: started.elapsed().as_micros().min(u32::MAX as u128) as u32,
            ..self.stats
        };
        visibility_frame(seq, ack, stats, held, held, want_full)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_next_region_grows_to_cover_the_motion_during_its_answer() {
        let spec = RegionSpec {
            radius_m: 0.5,
            turn_deg: 15.0,
        };
        let ms = Duration::from_millis;
        // Standing, or quick: the asked radius.
        assert_eq!(spec.radius(0.0, ms(500), ms(100)), 0.5);
        assert_eq!(spec.radius(1.4, ms(20), ms(10)), 0.5);
        // 1.4 m/s with 200 ms of answer and round trip: the outer half must last
        // 1.5 × 0.28 m.
        let r = spec.radius(1.4, ms(150), ms(50));
        assert!((r - 1.5 * 1.4 * 0.2 / 0.5).abs() < 1e-5, "{r}");
        // Never beyond the largest region, nor a number that is not one.
        assert_eq!(spec.radius(10.0, ms(2000), ms(0)), MAX_RADIUS_M);
        assert_eq!(spec.radius(f32::NAN, ms(100), ms(0)), 0.5);
        assert_eq!(spec.radius(f32::INFINITY, ms(100), ms(0)), MAX_RADIUS_M);
    }
}
