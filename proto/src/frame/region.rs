//! The region frame (version 5): what the sets that follow it hold for.
//!
//! A stream opened with a region (`?region_m=`) culls once per region instead of once
//! per pose: it announces each region it culls with a [`RegionFrame`], then sends the
//! region's set as a Full or Delta frame, and answers the poses that stay inside with
//! empty deltas. The set holds for every eye within `radius_m` of `centre` looking
//! within `turn_deg` of `axis`, with the frustum shape (field of view, viewport, near
//! and far) of the pose it answers (`ack`), at any pixel grid.

use super::words::{Reader, Writer};
use super::{Frame, FrameError};

/// The region the next Full or Delta frame's set holds for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RegionFrame {
    pub seq: u32,
    /// The pose whose cull made the region.
    pub ack: u32,
    /// The centre of the ball of eyes, world coordinates.
    pub centre: [f32; 3],
    pub radius_m: f32,
    /// The view direction the turn is measured from (unit length).
    pub axis: [f32; 3],
    /// How far a view direction may turn from `axis`, degrees.
    pub turn_deg: f32,
}

impl RegionFrame {
    pub(super) const PAYLOAD_WORDS: usize = 8;

    pub(super) fn write(&self, w: &mut Writer) {
        let [cx, cy, cz] = self.centre;
        let [ax, ay, az] = self.axis;
        for v in [cx, cy, cz, self.radius_m, ax, ay, az, self.turn_deg] {
            w.f32(v);
        }
    }

    pub(super) fn read(seq: u32, ack: u32, p: &mut Reader<'_>) -> Result<Self, FrameError> {
        let [cx, cy, cz, r, ax, ay, az, t] = p.fixed::<8>()?.map(f32::from_bits);
        p.tail(0)?;
        Ok(RegionFrame {
            seq,
            ack,
            centre: [cx, cy, cz],
            radius_m: r,
            axis: [ax, ay, az],
            turn_deg: t,
        })
    }

    /// Whether an eye at `position` looking along unit `forward` lies in the region
    /// (the frustum shape aside).
    pub fn holds(&self, position: [f32; 3], forward: [f32; 3]) -> bool {
        let d2: f32 = (0..3).map(|i| (position[i] - self.centre[i]).powi(2)).sum();
        let cos: f32 = (0..3).map(|i| forward[i] * self.axis[i]).sum();
        d2 <= self.radius_m * self.radius_m
            && cos.clamp(-1.0, 1.0).acos() <= self.turn_deg.to_radians()
    }
}

impl From<RegionFrame> for Frame {
    fn from(f: RegionFrame) -> Frame {
        Frame::Region(f)
    }
}
