//! Opt-in smoothing of a WebSocket client's visible set over time (stream options
//! `lookahead_ms` and `hold_ms`). Both only ever *add* objects to the set a cull
//! returns, so the streamed set stays conservative: it contains the set `POST /cull`
//! returns for the same pose.
//!
//! - [`MotionEstimator`]: a thin client draws the set for the pose it sent one round
//!   trip ago, so what walking reveals in that time arrives late. With a lookahead the
//!   server also culls the pose extrapolated along the client's recent motion and
//!   streams the union, so the set covers where the camera will be when it is drawn.
//! - [`HeldSet`]: small, distant objects come and go as the eye moves by less than a
//!   pixel. Holding an object for a while after its last sighting stops that flicker,
//!   which is most of what delta frames carry on a walk.

use std::collections::{BTreeMap, VecDeque};
use std::time::{Duration, Instant};

use glam::Vec3;
use homcull_proto::Pose;

use homcull_engine::cull::union;

/// Longest lookahead a client may ask for, ms.
pub const MAX_LOOKAHEAD_MS: u32 = 1000;
/// Longest hold a client may ask for, ms.
pub const MAX_HOLD_MS: u32 = 10_000;
/// Poses further back than this do not count towards the velocity.
const VELOCITY_WINDOW: Duration = Duration::from_millis(250);
/// Faster than this is a jump, not motion: no lookahead (metres per second).
const MAX_SPEED: f32 = 30.0;

/// Estimates a client's eye velocity from the poses it sent, timed as they arrive.
#[derive(Debug, Default)]
pub struct MotionEstimator {
    recent: VecDeque<(Instant, Vec3)>,
}

impl MotionEstimator {
    /// Records the eye of a pose that arrived at `at`.
    pub fn observe(&mut self, at: Instant, eye: Vec3) {
        self.recent.push_back((at, eye));
        while self
            .recent
            .front()
            .is_some_and(|&(t, _)| at.duration_since(t) > VELOCITY_WINDOW)
        {
            self.recent.pop_front();
        }
    }

    /// Mean velocity over the window (m/s); zero with fewer than two poses, over too
    /// short a time, or when the eye jumped.
    pub fn velocity(&self) -> Vec3 {
        let (Some(&(t0, a)), Some(&(t1, b))) = (self.recent.front(), self.recent.back()) else {
            return Vec3::ZERO;
        };
        let dt = t1.duration_since(t0).as_secs_f32();
        if dt < 1e-3 {
            return Vec3::ZERO;
        }
        let v = (b - a) / dt;
        if v.is_finite() && v.length() <= MAX_SPEED {
            v
        } else {
            Vec3::ZERO
        }
    }
}

/// `pose` moved by `offset` (its `look_at` target too, so the view direction stays).
pub fn moved(pose: &Pose, offset: Vec3) -> Pose {
    let shift = |p: [f32; 3]| (Vec3::from_array(p) + offset).to_array();
    Pose {
        position: shift(pose.position),
        look_at: pose.look_at.map(shift),
        ..pose.clone()
    }
}

/// Keeps each object in the streamed set for `hold` after the cull last returned it.
#[derive(Debug)]
pub struct HeldSet {
    hold: Duration,
    /// Objects not in the latest cull, with the time they were last in one.
    held: BTreeMap<u32, Instant>,
    /// The latest cull's set, and when it was taken.
    current: Vec<u32>,
    last_update: Option<Instant>,
}

impl HeldSet {
    pub fn new(hold: Duration) -> Self {
        HeldSet {
            hold,
            held: BTreeMap::new(),
            current: Vec::new(),
            last_update: None,
        }
    }

    /// False when the hold time is zero: the cull's set passes through unchanged.
    pub fn holds(&self) -> bool {
        !self.hold.is_zero()
    }

    /// Takes the cull's set (ascending) at `now` and returns the set to stream: the cull's
    /// set plus every object it returned within the hold time.
    pub fn update(&mut self, now: Instant, visible: Vec<u32>) -> Vec<u32> {
        if !self.holds() {
            return visible;
        }
        // Objects that just left the cull's set were last seen by the previous cull.
        let seen = self.last_update.unwrap_or(now);
        let mut v = visible.iter().peekable();
        for &id in &self.current {
            while v.next_if(|&&x| x < id).is_some() {}
            if v.peek() != Some(&&id) {
                self.held.insert(id, seen);
            }
        }
        for id in &visible {
            self.held.remove(id);
        }
        self.held
            .retain(|_, &mut last| now.duration_since(last) < self.hold);
        self.current = visible;
        self.last_update = Some(now);
        let held: Vec<u32> = self.held.keys().copied().collect();
        union(&self.current, &held)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn velocity_is_the_mean_over_the_window_and_ignores_jumps() {
        let t0 = Instant::now();
        let ms = |m| t0 + Duration::from_millis(m);
        let mut m = MotionEstimator::default();
        assert_eq!(m.velocity(), Vec3::ZERO);
        for k in 0..20u64 {
            // 1.5 m/s along x, a pose every 16 ms.
            m.observe(ms(16 * k), Vec3::new(0.024 * k as f32, 1.7, 0.0));
        }
        let v = m.velocity();
        assert!((v.x - 1.5).abs() < 1e-3 && v.y.abs() < 1e-6, "{v}");
        // Only the last 250 ms count: after stopping for 300 ms the velocity is zero.
        m.observe(ms(16 * 19 + 300), Vec3::new(0.024 * 19.0, 1.7, 0.0));
        assert_eq!(m.velocity(), Vec3::ZERO);
        // A teleport is not motion.
        m.observe(ms(16 * 19 + 316), Vec3::new(500.0, 1.7, 0.0));
        assert_eq!(m.velocity(), Vec3::ZERO);
    }

    #[test]
    fn moved_shifts_the_eye_and_the_target() {
        let p: Pose =
            serde_json::from_str(r#"{"position": [1, 2, 3], "look_at": [1, 2, 0]}"#).unwrap();
        let q = moved(&p, Vec3::new(0.5, 0.0, -1.0));
        assert_eq!(q.position, [1.5, 2.0, 2.0]);
        assert_eq!(q.look_at, Some([1.5, 2.0, -1.0]));
        assert_eq!(q.viewport, p.viewport);
    }

    #[test]
    fn held_objects_stay_for_the_hold_time_then_leave() {
        let t0 = Instant::now();
        let ms = |m| t0 + Duration::from_millis(m);
        let mut h = HeldSet::new(Duration::from_millis(100));
        assert_eq!(h.update(ms(0), vec![1, 2, 3]), [1, 2, 3]);
        // 2 flickers out: still streamed.
        assert_eq!(h.update(ms(16), vec![1, 3, 4]), [1, 2, 3, 4]);
        // ...and back in before the hold ends: no change at all.
        assert_eq!(h.update(ms(32), vec![1, 2, 3, 4]), [1, 2, 3, 4]);
        // 3 leaves for good: held until 100 ms after its last sighting (at 32 ms).
        assert_eq!(h.update(ms(64), vec![1, 2, 4]), [1, 2, 3, 4]);
        assert_eq!(h.update(ms(120), vec![1, 2, 4]), [1, 2, 3, 4]);
        assert_eq!(h.update(ms(140), vec![1, 2, 4]), [1, 2, 4]);
        // The cull's own set is always there, whatever is held.
        assert_eq!(h.update(ms(180), vec![9]), [1, 2, 4, 9]);
        // Without a hold the set passes through.
        let mut none = HeldSet::new(Duration::ZERO);
        assert_eq!(none.update(ms(0), vec![5]), [5]);
        assert_eq!(none.update(ms(1), vec![6]), [6]);
    }
}
