//! The statistics block of Full and Delta frames.

use super::*;

/// The 6-word statistics block of Full and Delta frames, in wire order.
///
/// Only what a client cannot work out itself travels: the scene's object count is in the
/// [`Hello`], and the objects culled by each test follow from it, `candidates` and the
/// size of the visible set ([`FrameStats::culled_by_frustum`],
/// [`FrameStats::culled_by_occlusion`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct FrameStats {
    /// Objects whose bounds intersect the view frustum.
    pub candidates: u32,
    /// Occluders rendered into the occlusion map.
    pub occluders_used: u32,
    /// Superseded poses dropped since the previous frame sent to this client.
    pub dropped_poses: u32,
    /// GPU time in microseconds (saturating).
    pub gpu_us: u32,
    /// Total cull time in microseconds (saturating).
    pub total_us: u32,
    /// The scene version the set was culled at (its low 32 bits; version 4).
    pub scene_version: u32,
}

impl FrameStats {
    /// Objects removed by the frustum test: `objects − candidates`, where `objects` is the
    /// scene's object count (the Hello's `object_count`). Saturates at 0 for inconsistent
    /// input.
    pub fn culled_by_frustum(&self, objects: u32) -> u32 {
        objects.saturating_sub(self.candidates)
    }

    /// In-frustum objects removed by the occlusion test: `candidates − visible`, where
    /// `visible` is the size of the visible set this frame describes (a Full frame's
    /// `ids.len()`, or the set once a Delta is applied). Saturates at 0 for inconsistent
    /// input.
    pub fn culled_by_occlusion(&self, visible: usize) -> u32 {
        let visible = u32::try_from(visible).unwrap_or(u32::MAX);
        self.candidates.saturating_sub(visible)
    }

    pub(super) fn to_words(self) -> [u32; STATS_WORDS] {
        [
            self.candidates,
            self.occluders_used,
            self.dropped_poses,
            self.gpu_us,
            self.total_us,
            self.scene_version,
        ]
    }

    pub(super) fn from_words(w: [u32; STATS_WORDS]) -> FrameStats {
        let [
            candidates,
            occluders_used,
            dropped_poses,
            gpu_us,
            total_us,
            scene_version,
        ] = w;
        FrameStats {
            candidates,
            occluders_used,
            dropped_poses,
            gpu_us,
            total_us,
            scene_version,
        }
    }
}
