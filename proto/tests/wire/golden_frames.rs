//! The frames of the golden vectors ([`goldens`]): one imagined session on a scene
//! of 1234 objects, each frame under the name of its file in `tests/golden/`.

use homcull_proto::Stereo;
use homcull_proto::frame::{
    Applied, ErrorCode, ErrorFrame, Frame, FrameStats, Hello, LodChanges, MovedObject, PoseFrame,
    RegionFrame, TransformsFrame, VisibleDelta, VisibleFull,
};

/// Objects in the scene of the golden session (the Hello's `object_count`).
pub(crate) const OBJECTS: u32 = 1234;

pub(crate) const HELLO_JSON: &str = r#"{"scene":{"id":"demo","name":"Démo city","objects":1234}}"#;
pub(crate) const ERROR_MESSAGE: &str = "fov_y_deg must be in (0°, 180°), got 200";

/// The visible set after `full.hex`, then after `delta.hex` is applied to it.
pub(crate) const FULL_IDS: [u32; 6] = [3, 17, 256, 1000, 1001, 1233];
pub(crate) const AFTER_DELTA: [u32; 7] = [3, 5, 17, 256, 700, 1000, 1001];
/// The levels of `full_lod.hex`, then of the set after `delta_lod.hex`.
pub(crate) const FULL_LEVELS: [u8; 6] = [0, 1, 1, 4, 2, 3];
pub(crate) const LEVELS_AFTER_DELTA: [u8; 7] = [0, 3, 2, 1, 0, 4, 8];

/// The golden frames, in file order.
pub(crate) fn goldens() -> Vec<(&'static str, Frame)> {
    vec![
        (
            "hello",
            Frame::Hello(Hello {
                seq: 1,
                object_count: OBJECTS,
                info_json: HELLO_JSON.to_owned(),
            }),
        ),
        (
            "pose",
            Frame::Pose(PoseFrame {
                seq: 42,
                want_full: true,
                position: [1.5, -2.0, 0.25],
                rotation: [0.5, -0.5, 0.5, 0.5],
                fov_y_deg: 60.0,
                viewport: [960, 540],
                near: 0.125,
                far: 5000.0,
                stereo: None,
            }),
        ),
        (
            "pose_stereo",
            Frame::Pose(PoseFrame {
                seq: 49,
                want_full: false,
                position: [1.5, -2.0, 0.25],
                rotation: [0.5, -0.5, 0.5, 0.5],
                fov_y_deg: 90.0,
                viewport: [1280, 720],
                near: 0.125,
                far: 5000.0,
                stereo: Some(Stereo {
                    ipd_m: 0.0625,
                    convergence_m: Some(2.5),
                }),
            }),
        ),
        (
            "full",
            Frame::Full(VisibleFull {
                seq: 2,
                ack: 42,
                stats: FrameStats {
                    candidates: 10,
                    occluders_used: 2,
                    dropped_poses: 1,
                    gpu_us: 850,
                    total_us: 1200,
                    scene_version: 7,
                },
                ids: FULL_IDS.to_vec(),
                levels: None,
            }),
        ),
        (
            "delta",
            Frame::Delta(VisibleDelta {
                seq: 3,
                ack: 43,
                stats: FrameStats {
                    candidates: 9,
                    occluders_used: 2,
                    dropped_poses: 0,
                    gpu_us: 790,
                    total_us: 1100,
                    scene_version: 7,
                },
                added: vec![5, 700],
                removed: vec![1233],
                lod: None,
            }),
        ),
        (
            "full_empty",
            Frame::Full(VisibleFull {
                seq: 4,
                ack: 44,
                stats: FrameStats {
                    candidates: 0,
                    occluders_used: 0,
                    dropped_poses: 0,
                    gpu_us: 0,
                    total_us: 35,
                    scene_version: 7,
                },
                ids: vec![],
                levels: None,
            }),
        ),
        (
            "delta_empty",
            Frame::Delta(VisibleDelta {
                seq: 5,
                ack: 45,
                stats: FrameStats {
                    candidates: 0,
                    occluders_used: 0,
                    dropped_poses: 3,
                    gpu_us: 0,
                    total_us: 40,
                    scene_version: 7,
                },
                added: vec![],
                removed: vec![],
                lod: None,
            }),
        ),
        (
            "full_lod",
            Frame::Full(VisibleFull {
                seq: 7,
                ack: 47,
                stats: FrameStats {
                    candidates: 10,
                    occluders_used: 2,
                    dropped_poses: 0,
                    gpu_us: 850,
                    total_us: 1200,
                    scene_version: 7,
                },
                ids: FULL_IDS.to_vec(),
                levels: Some(FULL_LEVELS.to_vec()),
            }),
        ),
        (
            "delta_lod",
            Frame::Delta(VisibleDelta {
                seq: 8,
                ack: 48,
                stats: FrameStats {
                    candidates: 9,
                    occluders_used: 2,
                    dropped_poses: 0,
                    gpu_us: 790,
                    total_us: 1100,
                    scene_version: 7,
                },
                added: vec![5, 700],
                removed: vec![1233],
                lod: Some(LodChanges {
                    added: vec![3, 0],
                    changed: vec![17, 1001],
                    changed_levels: vec![2, 8],
                }),
            }),
        ),
        (
            "error",
            Frame::Error(ErrorFrame {
                seq: 6,
                ack: 46,
                code: ErrorCode::InvalidPose,
                message: ERROR_MESSAGE.to_owned(),
            }),
        ),
        (
            "transforms",
            Frame::Transforms(TransformsFrame {
                seq: 12,
                horizon_ms: Some(100.0),
                objects: vec![
                    MovedObject {
                        id: 5,
                        // A quarter turn about +Y, then 2 m along +X and 0.5 m up.
                        matrix: [0.0, 0.0, -1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 2.0, 0.5, 0.0],
                        velocity: [1.5, 0.0, -0.25],
                        angular_velocity: [0.0, 0.5, 0.0],
                        valid_ms: Some(50.0),
                    },
                    MovedObject {
                        id: 700,
                        matrix: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
                        velocity: [0.0; 3],
                        angular_velocity: [0.0; 3],
                        valid_ms: None,
                    },
                ],
            }),
        ),
        (
            "transforms_keep_horizon",
            Frame::Transforms(TransformsFrame {
                seq: 13,
                horizon_ms: None,
                objects: vec![],
            }),
        ),
        (
            "applied",
            Frame::Applied(Applied {
                seq: 7,
                ack: 12,
                version: (1 << 32) + 3,
                applied: 2,
            }),
        ),
        (
            "region",
            Frame::Region(RegionFrame {
                seq: 8,
                ack: 14,
                centre: [12.5, 1.75, -3.0],
                radius_m: 0.5,
                axis: [-1.0, 0.0, 0.0],
                turn_deg: 15.0,
            }),
        ),
    ]
}
