//! Binary WebSocket frames: the streaming half of the protocol.
//!
//! A client streams [`PoseFrame`]s; the server answers each pose it culls with a
//! [`VisibleFull`] (the whole visible set) or a [`VisibleDelta`] (what changed since the
//! previous answer to that client), opens the connection with a [`Hello`] and reports
//! trouble with an [`ErrorFrame`]. A JavaScript client implements the same layout, and the
//! golden vectors in `proto/tests/golden/` pin it down byte for byte.
//!
//! # Layout
//!
//! A frame is a sequence of little-endian `u32` words; an `f32` travels as its IEEE-754
//! bit pattern (so NaN payloads and the sign of zero survive). The byte length of a frame
//! is always a multiple of 4. Every frame starts with the same 4-word header:
//!
//! | word | field            | meaning                                                        |
//! |-----:|------------------|----------------------------------------------------------------|
//! | 0    | `magic`          | [`MAGIC`] `0x4C434D48`: bytes `48 4D 43 4C`, ASCII `HMCL`       |
//! | 1    | `version \| kind << 16` | low 16 bits: [`PROTOCOL_VERSION`] (currently 5); high 16 bits: [`FrameKind`], 1 Hello, 2 Pose, 3 Full, 4 Delta, 5 Error, 6 FullLod, 7 DeltaLod, 8 Transforms, 9 Applied, 10 Region |
//! | 2    | `seq`            | the sender's sequence number (see below)                      |
//! | 3    | `ack`            | Full/Delta/Error: the pose `seq` answered, 0 if none; Applied: the Transforms `seq`; Region: the pose whose cull made it; Hello, Pose and Transforms: always 0 |
//!
//! `seq` is the client's pose sequence number in a Pose frame, and the server's frame
//! counter for that client in the frames the server sends.
//!
//! The payload is the rest of the frame: there is no length word, the frame's own length
//! (a WebSocket message carries exactly one frame) says where it ends. The payload follows
//! the header (`[a][b]` is one word each; `ids[n]` is `n` words):
//!
//! | kind      | direction       | payload                                                                 |
//! |-----------|-----------------|-------------------------------------------------------------------------|
//! | 1 Hello   | server → client | `[object_count][json_byte_len]` JSON bytes (UTF-8, zero-padded to a word) |
//! | 2 Pose    | client → server | `[flags][px][py][pz][qx][qy][qz][qw][fov_y_deg][width][height][near][far]` (13 words), then `[ipd_m][convergence_m]` with flag bit 1 |
//! | 3 Full    | server → client | stats (6 words) `[count]` `ids[count]`                                   |
//! | 4 Delta   | server → client | stats (6 words) `[added_count \| removed_count << 16]` `added[added_count]` `removed[removed_count]` |
//! | 5 Error   | server → client | `[code][byte_len]` message bytes (UTF-8, zero-padded to a word)          |
//! | 6 FullLod | server → client | as Full, then `levels`: one byte per ID, zero-padded to a word          |
//! | 7 DeltaLod | server → client | stats (6 words) `[added_count \| removed_count << 16]` `[changed_count]` `added[]` `removed[]` `changed[]`, then one byte per added ID and per changed ID, zero-padded |
//!
//! | 8 Transforms | client → server | `[horizon_ms][count]`, then per object 20 words `[id][matrix: 12][velocity: 3][angular_velocity: 3][valid_ms]` |
//! | 9 Applied | server → client | `[version_lo][version_hi][applied]`                                       |
//! | 10 Region | server → client | `[cx][cy][cz][radius_m][ax][ay][az][turn_deg]` (8 `f32` words)          |
//!
//! - **Hello**: the JSON is opaque to the codec (the server puts its `SceneInfo` and the
//!   like there); the decoder only checks that it is UTF-8. `object_count` is also what
//!   the derived stats below need.
//! - **Pose**: all fields are `f32` except `flags`, `width` and `height` (`u32`). Bit 0 of
//!   `flags` asks for a full frame instead of a delta ([`POSE_FLAG_WANT_FULL`]); bit 1
//!   ([`POSE_FLAG_STEREO`], version 3) makes it a stereo pose: two more words, the eyes'
//!   `ipd_m` and `convergence_m` (the word 0 for none; `+0.0` is never a convergence);
//!   the other bits must be 0. The codec carries the numbers bit-exactly and does not judge them
//!   (NaN, a zero quaternion and so on are the server's business).
//! - **Full**: the visible object IDs, strictly ascending.
//! - **Delta**: the IDs that became visible and those that stopped being visible since the
//!   previous Full/Delta sent to the same client; each list strictly ascending, and no ID
//!   in both. Both counts share one word, 16 bits each, so a delta carries at most
//!   [`MAX_DELTA_IDS`] (65535) IDs per list; a sender whose change is bigger sends a Full
//!   frame instead ([`VisibleDelta::fits`]). [`apply_delta`] applies one, [`diff`]
//!   computes one.
//! - **Error**: an [`ErrorCode`] and a human-readable message.
//! - **FullLod / DeltaLod** (version 3): the same with levels of detail, sent to a
//!   stream that asked for them (`?lod_px=`). A level is a byte, at most [`MAX_LEVEL`];
//!   a full frame gives every ID's, a delta those of the added IDs and of `changed`:
//!   IDs kept in the set (neither added nor removed) whose level changed, strictly
//!   ascending. [`diff_levels`] computes that part, [`apply_delta_with_levels`] applies
//!   it. In Rust they are [`VisibleFull::levels`] and [`VisibleDelta::lod`]; the kind
//!   follows from whether those are `Some`.
//!
//! - **Transforms / Applied** (version 4): a writer moves objects over its stream
//!   ([`TransformsFrame`]: placements relative to the scene file as the first three rows
//!   of the column-major 4×4, velocities, validity; IDs strictly ascending; an optional
//!   `f32` is the word [`motion::NO_VALUE`] when absent); the server answers with the
//!   scene version the update made ([`Applied`], `ack` = the update's `seq`) or an Error
//!   frame (`invalid_transform`, `unauthorized`).
//! - **Region** (version 5): on a stream opened with a region, the region that the
//!   next Full or Delta frame's set holds for ([`RegionFrame`]): every eye within
//!   `radius_m` of the centre, looking within `turn_deg` of the axis. The poses that
//!   stay inside are answered with empty deltas, without a cull.
//!
//! The stats block of Full and Delta is 6 `u32` words ([`FrameStats`]):
//!
//! | word | field            | meaning                                                       |
//! |-----:|------------------|---------------------------------------------------------------|
//! | 0    | `candidates`     | objects whose bounds intersect the view frustum               |
//! | 1    | `occluders_used` | occluders rendered into the occlusion map                     |
//! | 2    | `dropped_poses`  | superseded poses dropped since the previous frame sent to this client |
//! | 3    | `gpu_us`         | GPU time in microseconds (saturating)                         |
//! | 4    | `total_us`       | total cull time in microseconds (saturating)                  |
//! | 5    | `scene_version`  | the scene version the set was culled at, low 32 bits (version 4) |
//!
//! The rest is derived by the client and not sent: the scene's object count is the
//! Hello's `object_count`, objects culled by the frustum test are `object_count −
//! candidates` ([`FrameStats::culled_by_frustum`]), and in-frustum objects culled by the
//! occlusion test are `candidates − visible` where `visible` is the size of the visible
//! set once the frame is applied ([`FrameStats::culled_by_occlusion`]).
//!
//! Error codes ([`ErrorCode`]): 1 `malformed_frame`, 2 `unsupported_version`,
//! 3 `invalid_pose`, 4 `overloaded`, 5 `internal`, 6 `unknown_scene`,
//! 7 `invalid_transform`, 8 `unauthorized`.
//!
//! # Why this shape
//!
//! - **A fixed header** lets a receiver dispatch on `kind` and match `ack` to its pose
//!   without parsing the rest of the frame.
//! - **Small deltas**: at walking speed most deltas change nothing or a few IDs, so the
//!   fixed part dominates their size. Version 2 dropped everything a client can derive or
//!   read off the message length (version 1 had a separate kind word, a payload-length
//!   word, three derivable stats words and two count words): an empty delta was 40 bytes
//!   instead of 64, against 440 bytes for a full frame of 100 visible IDs (version 4's
//!   scene version word makes them 44 and 444).
//! - **Little-endian 32-bit words** are what a browser reads natively: a `DataView` with
//!   `getUint32(offset, true)` / `getFloat32(offset, true)`, or a `Uint32Array` over the
//!   frame's `ArrayBuffer` (every frame is word-aligned, and on every browser platform
//!   the typed array's native order is little-endian). Strings are padded so that
//!   everything after them stays aligned.
//! - **Strictly ascending IDs** make a delta a linear merge on both sides (see [`diff`]
//!   and [`apply_delta`]), make duplicates impossible, and let the decoder verify a list
//!   in one pass. Together with zero padding and the other checks below, every valid frame
//!   has exactly one encoding: `encode(decode(bytes)) == bytes`.
//!
//! # Decoding
//!
//! [`Frame::decode`] never panics and never allocates more than the input's size
//! justifies: every count is checked against the words actually present (in 64-bit or
//! checked arithmetic) before anything is allocated. It checks, in this order, and
//! reports the first failure as a [`FrameError`]:
//!
//! 1. length at most [`MAX_FRAME_BYTES`], at least the header, a multiple of 4;
//! 2. magic, version (low half of word 1), kind (high half), `ack == 0` for Hello and
//!    Pose;
//! 3. the payload: its counts and byte lengths match the words after the header exactly
//!    (no trailing words), pose flags, error code, zero padding, UTF-8, ascending and
//!    disjoint ID lists.
//!
//! [`FrameError::code`] gives the [`ErrorCode`] a server answers a bad frame with.
//!
//! # Example
//!
//! ```
//! use homcull_proto::frame::{apply_delta, diff, Frame, FrameStats, VisibleDelta, VisibleFull};
//!
//! let stats = FrameStats { candidates: 5, ..FrameStats::default() };
//! let full = Frame::Full(VisibleFull { seq: 1, ack: 7, stats, ids: vec![2, 3, 9], levels: None });
//! let bytes = full.encode();
//! assert_eq!(&bytes[..4], b"HMCL");
//! assert_eq!(bytes.len(), 16 + 4 * (6 + 1 + 3));
//! assert_eq!(Frame::decode(&bytes), Ok(full));
//!
//! // The next answer as a delta, and the client applying it.
//! let (added, removed) = diff(&[2, 3, 9], &[3, 4, 9]);
//! let delta = VisibleDelta { seq: 2, ack: 8, stats, added, removed, lod: None };
//! assert!(delta.fits());
//! let Ok(Frame::Delta(received)) = Frame::decode(&Frame::Delta(delta).encode()) else { panic!() };
//! let mut visible = vec![2, 3, 9];
//! apply_delta(&mut visible, &received).unwrap();
//! assert_eq!(visible, [3, 4, 9]);
//!
//! // Derived stats: a scene of 12 objects, 5 in the frustum, 3 of them visible.
//! assert_eq!(stats.culled_by_frustum(12), 7);
//! assert_eq!(received.culled_by_occlusion(visible.len()), 2);
//!
//! // A delta with no change is the header, the stats and the counts word: 44 bytes.
//! let empty = Frame::Delta(VisibleDelta { seq: 3, ack: 9, stats, ..VisibleDelta::default() });
//! assert_eq!(empty.encoded_len(), 44);
//! ```
//!
//! Files: this one holds the constants and frame types; `stats` the stats block;
//! `motion` the writer's frames; `codec` encodes, decodes and validates, with `words`
//! (the word writer and reader); `delta` computes and applies deltas; `error` says why
//! a frame was refused.

mod codec;
mod delta;
mod error;
pub mod motion;
mod region;
mod stats;
mod words;

use std::fmt;

use crate::{Pose, Stereo};

pub use delta::{apply_delta, apply_delta_with_levels, diff, diff_levels};
pub use error::FrameError;
pub use motion::{Applied, MovedObject, TransformsFrame};
pub use region::RegionFrame;
pub use stats::FrameStats;

/// First word of every frame: the bytes `48 4D 43 4C` (ASCII `HMCL`) read as a
/// little-endian `u32`.
pub const MAGIC: u32 = 0x4C43_4D48;

/// Words in the frame header: magic, `version | kind << 16`, seq, ack.
pub const HEADER_WORDS: usize = 4;

/// Bytes in the frame header.
pub const HEADER_BYTES: usize = HEADER_WORDS * 4;

/// Largest frame the decoder accepts; longer input is rejected before anything else is
/// looked at.
pub const MAX_FRAME_BYTES: usize = 16 << 20;

/// Words in the stats block of Full and Delta frames.
pub const STATS_WORDS: usize = 6;

/// Most IDs a Delta frame carries in each of its lists: both counts share one word,
/// 16 bits each. A bigger change goes out as a Full frame (see [`VisibleDelta::fits`]).
pub const MAX_DELTA_IDS: usize = 0xFFFF;

/// Words in a Pose payload.
pub const POSE_PAYLOAD_WORDS: usize = 13;

/// Bit of a Pose frame's `flags` word asking for a full frame; the only bit defined.
pub const POSE_FLAG_WANT_FULL: u32 = 1;

/// Bit of a Pose frame's flags saying that two more words follow the 13: the stereo
/// eyes' `ipd_m` and `convergence_m` (0 for none), both `f32`.
pub const POSE_FLAG_STEREO: u32 = 2;

/// Words a stereo pose adds to the Pose payload.
pub const STEREO_WORDS: usize = 2;

/// Largest level of detail a frame carries (as many levels as thresholds, plus one).
pub const MAX_LEVEL: u8 = crate::MAX_LOD_THRESHOLDS as u8;

/// What a frame is (the high 16 bits of header word 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum FrameKind {
    /// Server → client, first frame of a connection.
    Hello = 1,
    /// Client → server, a camera pose to cull.
    Pose = 2,
    /// Server → client, the whole visible set.
    Full = 3,
    /// Server → client, changes to the visible set.
    Delta = 4,
    /// Server → client, something went wrong.
    Error = 5,
    /// Server → client, the whole visible set with a level of detail per object.
    FullLod = 6,
    /// Server → client, changes to the visible set and to levels of detail.
    DeltaLod = 7,
    /// Client → server, objects moved by a writer.
    Transforms = 8,
    /// Server → client, a writer's update applied: the scene version it made.
    Applied = 9,
    Region = 10,
}

impl FrameKind {
    /// All kinds, in wire-code order.
    pub const ALL: [FrameKind; 10] = [
        FrameKind::Hello,
        FrameKind::Pose,
        FrameKind::Full,
        FrameKind::Delta,
        FrameKind::Error,
        FrameKind::FullLod,
        FrameKind::DeltaLod,
        FrameKind::Transforms,
        FrameKind::Applied,
        FrameKind::Region,
    ];

    /// The kind with wire code `code`, if any.
    pub fn from_u32(code: u32) -> Option<FrameKind> {
        FrameKind::ALL.into_iter().find(|k| *k as u32 == code)
    }

    /// Lowercase name (`hello`, `pose`, `full`, `delta`, `error`, `full_lod`,
    /// `delta_lod`, `transforms`, `applied`).
    pub fn name(self) -> &'static str {
        match self {
            FrameKind::Hello => "hello",
            FrameKind::Pose => "pose",
            FrameKind::Full => "full",
            FrameKind::Delta => "delta",
            FrameKind::Error => "error",
            FrameKind::FullLod => "full_lod",
            FrameKind::DeltaLod => "delta_lod",
            FrameKind::Transforms => "transforms",
            FrameKind::Applied => "applied",
            FrameKind::Region => "region",
        }
    }
}

impl fmt::Display for FrameKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Error codes carried by [`ErrorFrame`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum ErrorCode {
    /// The peer sent a frame that does not decode.
    MalformedFrame = 1,
    /// The peer speaks another protocol version.
    UnsupportedVersion = 2,
    /// The pose decoded but its numbers are unusable (NaN, zero quaternion, bad planes...).
    InvalidPose = 3,
    /// The server is too busy to answer.
    Overloaded = 4,
    /// A bug or failure on the server.
    Internal = 5,
    /// The scene the connection refers to does not exist (any more).
    UnknownScene = 6,
    /// A writer's update was refused (unknown object, bad numbers, too many...).
    InvalidTransform = 7,
    /// A writer's update needs the write token on the stream's upgrade request.
    Unauthorized = 8,
}

impl ErrorCode {
    /// All codes, in wire-code order.
    pub const ALL: [ErrorCode; 8] = [
        ErrorCode::MalformedFrame,
        ErrorCode::UnsupportedVersion,
        ErrorCode::InvalidPose,
        ErrorCode::Overloaded,
        ErrorCode::Internal,
        ErrorCode::UnknownScene,
        ErrorCode::InvalidTransform,
        ErrorCode::Unauthorized,
    ];

    /// The code with wire value `code`, if any.
    pub fn from_u32(code: u32) -> Option<ErrorCode> {
        ErrorCode::ALL.into_iter().find(|c| *c as u32 == code)
    }

    /// The snake_case name (`malformed_frame`, `unsupported_version`, `invalid_pose`,
    /// `overloaded`, `internal`, `unknown_scene`, `invalid_transform`, `unauthorized`).
    pub fn name(self) -> &'static str {
        match self {
            ErrorCode::MalformedFrame => "malformed_frame",
            ErrorCode::UnsupportedVersion => "unsupported_version",
            ErrorCode::InvalidPose => "invalid_pose",
            ErrorCode::Overloaded => "overloaded",
            ErrorCode::Internal => "internal",
            ErrorCode::UnknownScene => "unknown_scene",
            ErrorCode::InvalidTransform => "invalid_transform",
            ErrorCode::Unauthorized => "unauthorized",
        }
    }
}

impl fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// First frame of a connection (server → client). Its `ack` is always 0.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Hello {
    /// The server's frame counter for this client.
    pub seq: u32,
    /// Objects in the scene (IDs are `0..object_count`).
    pub object_count: u32,
    /// JSON the codec does not look into (scene info and the like).
    pub info_json: String,
}

/// A camera pose to cull (client → server). Its `ack` is always 0.
///
/// The numbers are carried bit-exactly; `PartialEq` compares them as floats (so a frame
/// holding NaN is not equal to itself), compare [`Frame::encode`] output for bit equality.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseFrame {
    /// The client's pose sequence number, echoed as `ack` by the answer.
    pub seq: u32,
    /// Ask for a [`VisibleFull`] rather than a delta.
    pub want_full: bool,
    /// Eye position in metres, world space.
    pub position: [f32; 3],
    /// Orientation as a quaternion `[x, y, z, w]`.
    pub rotation: [f32; 4],
    /// Vertical field of view in degrees.
    pub fov_y_deg: f32,
    /// Viewport `[width, height]` in pixels.
    pub viewport: [u32; 2],
    /// Near plane distance in metres.
    pub near: f32,
    /// Far plane distance in metres.
    pub far: f32,
    /// Both eyes of a stereo display ([`POSE_FLAG_STEREO`] and two more words).
    pub stereo: Option<Stereo>,
}

impl PoseFrame {
    /// The pose this frame carries, with `rotation` set and `look_at`, `up` unset.
    pub fn to_pose(&self) -> Pose {
        Pose {
            position: self.position,
            rotation: Some(self.rotation),
            look_at: None,
            up: None,
            fov_y_deg: self.fov_y_deg,
            viewport: self.viewport,
            near: self.near,
            far: self.far,
            stereo: self.stereo,
            region: None,
        }
    }

    /// A frame carrying `pose`, or `None` if the pose uses `look_at` or `up` (the binary
    /// frame carries only quaternions) or a region (no frame of this protocol version
    /// carries one). A pose with neither `rotation` nor `look_at` looks along −Z, which
    /// is the identity quaternion `[0, 0, 0, 1]`.
    pub fn from_pose(seq: u32, want_full: bool, pose: &Pose) -> Option<PoseFrame> {
        if pose.look_at.is_some() || pose.up.is_some() || pose.region.is_some() {
            return None;
        }
        Some(PoseFrame {
            seq,
            want_full,
            position: pose.position,
            rotation: pose.rotation.unwrap_or([0.0, 0.0, 0.0, 1.0]),
            fov_y_deg: pose.fov_y_deg,
            viewport: pose.viewport,
            near: pose.near,
            far: pose.far,
            stereo: pose.stereo,
        })
    }
}

/// The whole visible set (server → client).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct VisibleFull {
    /// The server's frame counter for this client.
    pub seq: u32,
    /// The pose sequence number this frame answers (0 if none).
    pub ack: u32,
    /// What the cull did.
    pub stats: FrameStats,
    /// Visible object IDs, strictly ascending.
    pub ids: Vec<u32>,
    /// With levels of detail (kind 6, [`FrameKind::FullLod`]): the level of each ID, in
    /// the order of `ids`, each at most [`MAX_LEVEL`]. `None` is kind 3.
    pub levels: Option<Vec<u8>>,
}

impl VisibleFull {
    /// Objects removed by the frustum test, given the scene's object count (the Hello's
    /// `object_count`).
    pub fn culled_by_frustum(&self, objects: u32) -> u32 {
        self.stats.culled_by_frustum(objects)
    }

    /// In-frustum objects removed by the occlusion test: `candidates − ids.len()`.
    pub fn culled_by_occlusion(&self) -> u32 {
        self.stats.culled_by_occlusion(self.ids.len())
    }
}

/// The levels of detail a [`VisibleDelta`] carries: of every added ID, and of every ID
/// visible before and after whose level changed.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LodChanges {
    /// The level of each added ID, in the order of [`VisibleDelta::added`].
    pub added: Vec<u8>,
    /// IDs kept in the set whose level changed, strictly ascending, none of them added
    /// or removed.
    pub changed: Vec<u32>,
    /// Their new levels, in the order of `changed`.
    pub changed_levels: Vec<u8>,
}

/// Changes to the visible set since the previous Full/Delta to the same client
/// (server → client).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct VisibleDelta {
    /// The server's frame counter for this client.
    pub seq: u32,
    /// The pose sequence number this frame answers (0 if none).
    pub ack: u32,
    /// What the cull did.
    pub stats: FrameStats,
    /// IDs that became visible, strictly ascending.
    pub added: Vec<u32>,
    /// IDs that stopped being visible, strictly ascending, none of them in `added`.
    pub removed: Vec<u32>,
    /// With levels of detail (kind 7, [`FrameKind::DeltaLod`]): the levels of the added
    /// IDs and of the IDs kept whose level changed. `None` is kind 4.
    pub lod: Option<LodChanges>,
}

impl VisibleDelta {
    /// Whether this change can travel as a Delta frame: each list holds at most
    /// [`MAX_DELTA_IDS`] IDs. [`Frame::encode`] panics on a delta that does not fit, and
    /// [`Frame::validate`] reports it; send a [`VisibleFull`] instead.
    pub fn fits(&self) -> bool {
        self.added.len() <= MAX_DELTA_IDS && self.removed.len() <= MAX_DELTA_IDS
    }

    /// Objects removed by the frustum test, given the scene's object count (the Hello's
    /// `object_count`).
    pub fn culled_by_frustum(&self, objects: u32) -> u32 {
        self.stats.culled_by_frustum(objects)
    }

    /// In-frustum objects removed by the occlusion test, given the size of the visible set
    /// once this delta is applied.
    pub fn culled_by_occlusion(&self, visible: usize) -> u32 {
        self.stats.culled_by_occlusion(visible)
    }
}

/// An error report (server → client).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ErrorFrame {
    /// The server's frame counter for this client.
    pub seq: u32,
    /// The pose sequence number this error answers (0 if none).
    pub ack: u32,
    /// What went wrong.
    pub code: ErrorCode,
    /// Human-readable details.
    pub message: String,
}

/// Any frame.
#[derive(Debug, Clone, PartialEq)]
pub enum Frame {
    /// Kind 1, server → client.
    Hello(Hello),
    /// Kind 2, client → server.
    Pose(PoseFrame),
    /// Kind 3, server → client.
    Full(VisibleFull),
    /// Kind 4, server → client.
    Delta(VisibleDelta),
    /// Kind 5, server → client.
    Error(ErrorFrame),
    /// Kind 8, client → server.
    Transforms(TransformsFrame),
    /// Kind 9, server → client.
    Applied(Applied),
    Region(RegionFrame),
}

impl From<Hello> for Frame {
    fn from(f: Hello) -> Frame {
        Frame::Hello(f)
    }
}

impl From<PoseFrame> for Frame {
    fn from(f: PoseFrame) -> Frame {
        Frame::Pose(f)
    }
}

impl From<VisibleFull> for Frame {
    fn from(f: VisibleFull) -> Frame {
        Frame::Full(f)
    }
}

impl From<VisibleDelta> for Frame {
    fn from(f: VisibleDelta) -> Frame {
        Frame::Delta(f)
    }
}

impl From<ErrorFrame> for Frame {
    fn from(f: ErrorFrame) -> Frame {
        Frame::Error(f)
    }
}
