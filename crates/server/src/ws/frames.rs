//! What a stream sends and reads, as plain functions: the frame answering a pose (a
//! delta, or a full frame when asked or when the change is too big), its stats, and
//! the parsing of a client's pose messages into error frames where they are bad.

use glam::Vec3;
use homcull_proto::PoseMessage;
use homcull_proto::frame::{
    ErrorCode, ErrorFrame, Frame, FrameError, FrameStats, VisibleDelta, VisibleFull, diff,
    diff_levels,
};
use std::time::Instant;

use super::Pending;
use crate::motion::HeldSet;
use crate::state::SceneEntry;
use homcull_engine::camera::Camera;
use homcull_engine::camera::stereo;
use homcull_engine::cull::PoseResult;
use homcull_engine::cull::union;

/// A visible set and, on a stream that asked for them, the level of detail of each ID.
#[derive(Debug, Clone, Copy)]
pub(super) struct Sent<'a> {
    pub ids: &'a [u32],
    pub levels: Option<&'a [u8]>,
}

/// The answer to pose `ack`: a delta from `last` (what was last sent to this client) to
/// `now`, or a full frame when `want_full` or when the change does not fit in a delta
/// frame (more than [`MAX_DELTA_IDS`](homcull_proto::frame::MAX_DELTA_IDS) IDs added or
/// removed). With levels, the frame carries them (a delta: those of the added IDs and
/// of the kept ones whose level changed).
pub(super) fn visibility_frame(
    seq: u32,
    ack: u32,
    stats: FrameStats,
    last: Sent<'_>,
    now: Sent<'_>,
    want_full: bool,
) -> Frame {
    if !want_full {
        let (added, removed) = diff(last.ids, now.ids);
        let lod = now
            .levels
            .map(|levels| diff_levels(last.ids, last.levels.unwrap_or_default(), now.ids, levels));
        let delta = VisibleDelta {
            seq,
            ack,
            stats,
            added,
            removed,
            lod,
        };
        // A delta with levels needs the last frame's levels (a stream keeps its options).
        if delta.fits() && (now.levels.is_none() || last.levels.is_some()) {
            return Frame::Delta(delta);
        }
    }
    Frame::Full(VisibleFull {
        seq,
        ack,
        stats,
        ids: now.ids.to_vec(),
        levels: now.levels.map(<[u8]>::to_vec),
    })
}

pub(super) fn frame_stats(r: &PoseResult, dropped: u32, started: Instant) -> FrameStats {
    let us = |ms: f64| (ms * 1e3).clamp(0.0, u32::MAX as f64) as u32;
    // objects, culled_by_frustum and culled_by_occlusion are not sent: clients derive
    // them from the Hello's object count, `candidates` and the visible set.
    FrameStats {
        candidates: r.stats.candidates,
        occluders_used: r.stats.occluders_used,
        dropped_poses: dropped,
        gpu_us: us(r.stats.gpu_ms),
        total_us: us(started.elapsed().as_secs_f64() * 1e3),
        // The low 32 bits: what the wire carries.
        scene_version: r.stats.scene_version as u32,
    }
}

fn bad(code: ErrorCode, message: String) -> ErrorFrame {
    ErrorFrame {
        seq: 0,
        ack: 0,
        code,
        message,
    }
}

/// The pose of a decoded binary frame, or the error to answer.
pub(super) fn parse_frame(decoded: Result<Frame, FrameError>) -> Result<Pending, ErrorFrame> {
    match decoded {
        Ok(Frame::Pose(p)) => {
            let pose = p.to_pose();
            let eyes = stereo::eyes(&pose).map_err(|e| ErrorFrame {
                ack: p.seq,
                ..bad(ErrorCode::InvalidPose, e.to_string())
            })?;
            Ok(Pending {
                seq: p.seq,
                pose,
                eyes,
                want_full: p.want_full,
                velocity: Vec3::ZERO,
            })
        }
        Ok(other) => Err(bad(
            ErrorCode::MalformedFrame,
            format!("clients send pose frames, not {}", other.kind().name()),
        )),
        Err(e) => Err(bad(e.code(), e.to_string())),
    }
}

pub(super) fn parse_text(text: &str) -> Result<Pending, ErrorFrame> {
    let m: PoseMessage = serde_json::from_str(text)
        .map_err(|e| bad(ErrorCode::MalformedFrame, format!("pose message: {e}")))?;
    // A region answer costs the cull worker far more than a point pose, and a stream
    // sends a pose a frame: a stream takes its region once, in its query
    // (`?region_m=`, `region`), and culls once per region, not per pose.
    if m.pose.region.is_some() {
        return Err(ErrorFrame {
            ack: m.seq,
            ..bad(
                ErrorCode::InvalidPose,
                "region: a stream takes its region from ?region_m=&turn_deg=, not per pose".into(),
            )
        });
    }
    let eyes = stereo::eyes(&m.pose).map_err(|e| ErrorFrame {
        ack: m.seq,
        ..bad(ErrorCode::InvalidPose, e.to_string())
    })?;
    Ok(Pending {
        seq: m.seq,
        pose: m.pose,
        eyes,
        want_full: m.full,
        velocity: Vec3::ZERO,
    })
}

/// The set to stream from the culls of a pose's `eyes` (the first results) and its
/// lookahead (if any): their union plus the held objects. Objects streamed outside
/// every eye's frustum count as candidates, so that candidates − visible (what clients
/// show as culled by occlusion) stays what it says. Without smoothing this is the
/// pose's own answer (for a stereo pose, its eyes' union).
pub(super) fn smoothed(
    mut results: Vec<PoseResult>,
    held: &mut HeldSet,
    eyes: &[Camera],
    scene: &SceneEntry,
) -> PoseResult {
    let lookahead = results.split_off(eyes.len());
    let mut r = PoseResult::union_of(results).expect("one result per eye");
    let it = lookahead.into_iter();
    if it.len() == 0 && !held.holds() {
        return r;
    }
    let culled = r.visible.clone();
    for other in it {
        r.visible = union(&r.visible, &other.visible);
    }
    r.visible = held.update(Instant::now(), std::mem::take(&mut r.visible));
    if r.visible.len() != culled.len() {
        let placed = scene.placements();
        let outside = r
            .visible
            .iter()
            .filter(|id| culled.binary_search(id).is_err())
            .filter(|&&id| {
                let b = placed.bounds(id);
                !eyes.iter().any(|cam| cam.intersects(&b))
            })
            .count() as u32;
        r.stats.candidates += outside;
        r.stats.culled_by_frustum = r.stats.culled_by_frustum.saturating_sub(outside);
        r.stats.culled_by_occlusion = r.stats.candidates.saturating_sub(r.visible.len() as u32);
    }
    r
}

#[cfg(test)]
#[allow(
    clippy::wildcard_enum_match_arm,
    reason = "a test names the frame it expects and fails on any other"
)]
mod tests {
    use homcull_proto::frame::{MAX_DELTA_IDS, apply_delta};

    use super::*;

    fn ids(ids: &[u32]) -> Sent<'_> {
        Sent { ids, levels: None }
    }

    #[test]
    fn with_levels_a_delta_carries_those_of_added_and_changed_ids() {
        let stats = FrameStats::default();
        let last = Sent {
            ids: &[1, 2, 3],
            levels: Some(&[0, 1, 2]),
        };
        let now = Sent {
            ids: &[2, 3, 4],
            levels: Some(&[1, 0, 3]),
        };
        match visibility_frame(1, 1, stats, last, now, false) {
            Frame::Delta(d) => {
                assert_eq!((d.added, d.removed), (vec![4], vec![1]));
                let lod = d.lod.unwrap();
                assert_eq!(
                    (lod.added, lod.changed, lod.changed_levels),
                    (vec![3], vec![3], vec![0])
                );
            }
            f => panic!("expected a delta, got {:?}", f.kind()),
        }
        // Without the last frame's levels (none sent yet), a full frame.
        let first = visibility_frame(2, 2, stats, ids(&[]), now, false);
        assert!(matches!(first, Frame::Full(f) if f.levels.as_deref() == Some(&[1, 0, 3][..])));
    }

    #[test]
    fn a_change_too_big_for_a_delta_goes_out_as_a_full_frame() {
        let stats = FrameStats::default();
        let max = MAX_DELTA_IDS as u32;
        let many: Vec<u32> = (0..max + 1).collect();
        let fits: Vec<u32> = (1..max + 1).collect();
        // 65535 removed (and 65535 added) still fit in one delta...
        let shifted: Vec<u32> = (max + 1..2 * max + 1).collect();
        match visibility_frame(1, 1, stats, ids(&fits), ids(&shifted), false) {
            Frame::Delta(d) => {
                assert_eq!(
                    (d.added.len(), d.removed.len()),
                    (MAX_DELTA_IDS, MAX_DELTA_IDS)
                );
                let mut set = fits.clone();
                apply_delta(&mut set, &d).unwrap();
                assert_eq!(set, shifted);
            }
            f => panic!("expected a delta, got {:?}", f.kind()),
        }
        // ...65536 do not, in either list.
        for (old, new) in [(&many, &Vec::new()), (&Vec::new(), &many)] {
            match visibility_frame(2, 2, stats, ids(old), ids(new), false) {
                Frame::Full(f) => {
                    assert_eq!(&f.ids, new);
                    assert_eq!(Frame::Full(f).validate(), Ok(()));
                }
                f => panic!("expected a full frame, got {:?}", f.kind()),
            }
        }
        // Small changes are deltas unless a full frame is asked for.
        assert!(matches!(
            visibility_frame(3, 3, stats, ids(&[1, 2]), ids(&[2, 3]), false),
            Frame::Delta(d) if d.added == [3] && d.removed == [1]
        ));
        assert!(matches!(
            visibility_frame(4, 4, stats, ids(&[1, 2]), ids(&[2, 3]), true),
            Frame::Full(f) if f.ids == [2, 3]
        ));
    }
}
