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
//! | 1    | `version \| kind << 16` | low 16 bits: [`PROTOCOL_VERSION`] (currently 2); high 16 bits: [`FrameKind`], 1 Hello, 2 Pose, 3 Full, 4 Delta, 5 Error |
//! | 2    | `seq`            | the sender's sequence number (see below)                      |
//! | 3    | `ack`            | Full/Delta/Error: the pose `seq` answered, 0 if none; Hello and Pose: always 0 |
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
//! | 2 Pose    | client → server | `[flags][px][py][pz][qx][qy][qz][qw][fov_y_deg][width][height][near][far]` (13 words) |
//! | 3 Full    | server → client | stats (5 words) `[count]` `ids[count]`                                   |
//! | 4 Delta   | server → client | stats (5 words) `[added_count \| removed_count << 16]` `added[added_count]` `removed[removed_count]` |
//! | 5 Error   | server → client | `[code][byte_len]` message bytes (UTF-8, zero-padded to a word)          |
//!
//! - **Hello**: the JSON is opaque to the codec (the server puts its `SceneInfo` and the
//!   like there); the decoder only checks that it is UTF-8. `object_count` is also what
//!   the derived stats below need.
//! - **Pose**: all fields are `f32` except `flags`, `width` and `height` (`u32`). Bit 0 of
//!   `flags` asks for a full frame instead of a delta ([`POSE_FLAG_WANT_FULL`]); the other
//!   bits must be 0. The codec carries the numbers bit-exactly and does not judge them
//!   (NaN, a zero quaternion and so on are the server's business).
//! - **Full**: the visible object IDs, strictly ascending.
//! - **Delta**: the IDs that became visible and those that stopped being visible since the
//!   previous Full/Delta sent to the same client; each list strictly ascending, and no ID
//!   in both. Both counts share one word, 16 bits each, so a delta carries at most
//!   [`MAX_DELTA_IDS`] (65535) IDs per list; a sender whose change is bigger sends a Full
//!   frame instead ([`VisibleDelta::fits`]). [`apply_delta`] applies one, [`diff`]
//!   computes one.
//! - **Error**: an [`ErrorCode`] and a human-readable message.
//!
//! The stats block of Full and Delta is 5 `u32` words ([`FrameStats`]):
//!
//! | word | field            | meaning                                                       |
//! |-----:|------------------|---------------------------------------------------------------|
//! | 0    | `candidates`     | objects whose bounds intersect the view frustum               |
//! | 1    | `occluders_used` | occluders rendered into the occlusion map                     |
//! | 2    | `dropped_poses`  | superseded poses dropped since the previous frame sent to this client |
//! | 3    | `gpu_us`         | GPU time in microseconds (saturating)                         |
//! | 4    | `total_us`       | total cull time in microseconds (saturating)                  |
//!
//! The rest is derived by the client and not sent: the scene's object count is the
//! Hello's `object_count`, objects culled by the frustum test are `object_count −
//! candidates` ([`FrameStats::culled_by_frustum`]), and in-frustum objects culled by the
//! occlusion test are `candidates − visible` where `visible` is the size of the visible
//! set once the frame is applied ([`FrameStats::culled_by_occlusion`]).
//!
//! Error codes ([`ErrorCode`]): 1 `malformed_frame`, 2 `unsupported_version`,
//! 3 `invalid_pose`, 4 `overloaded`, 5 `internal`, 6 `unknown_scene`.
//!
//! # Why this shape
//!
//! - **A fixed header** lets a receiver dispatch on `kind` and match `ack` to its pose
//!   without parsing the rest of the frame.
//! - **Small deltas**: at walking speed most deltas change nothing or a few IDs, so the
//!   fixed part dominates their size. Version 2 dropped everything a client can derive or
//!   read off the message length (version 1 had a separate kind word, a payload-length
//!   word, three derivable stats words and two count words): an empty delta is 40 bytes
//!   instead of 64, against 440 bytes for a full frame of 100 visible IDs.
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
//! let full = Frame::Full(VisibleFull { seq: 1, ack: 7, stats, ids: vec![2, 3, 9] });
//! let bytes = full.encode();
//! assert_eq!(&bytes[..4], b"HMCL");
//! assert_eq!(bytes.len(), 16 + 4 * (5 + 1 + 3));
//! assert_eq!(Frame::decode(&bytes), Ok(full));
//!
//! // The next answer as a delta, and the client applying it.
//! let (added, removed) = diff(&[2, 3, 9], &[3, 4, 9]);
//! let delta = VisibleDelta { seq: 2, ack: 8, stats, added, removed };
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
//! // A delta with no change is the header, the stats and the counts word: 40 bytes.
//! let empty = Frame::Delta(VisibleDelta { seq: 3, ack: 9, stats, ..VisibleDelta::default() });
//! assert_eq!(empty.encoded_len(), 40);
//! ```

use std::fmt;

use crate::{PROTOCOL_VERSION, Pose};

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
pub const STATS_WORDS: usize = 5;

/// Most IDs a Delta frame carries in each of its lists: both counts share one word,
/// 16 bits each. A bigger change goes out as a Full frame (see [`VisibleDelta::fits`]).
pub const MAX_DELTA_IDS: usize = 0xFFFF;

/// Words in a Pose payload.
pub const POSE_PAYLOAD_WORDS: usize = 13;

/// Bit of a Pose frame's `flags` word asking for a full frame; the only bit defined.
pub const POSE_FLAG_WANT_FULL: u32 = 1;

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
}

impl FrameKind {
    /// All kinds, in wire-code order.
    pub const ALL: [FrameKind; 5] = [
        FrameKind::Hello,
        FrameKind::Pose,
        FrameKind::Full,
        FrameKind::Delta,
        FrameKind::Error,
    ];

    /// The kind with wire code `code`, if any.
    pub fn from_u32(code: u32) -> Option<FrameKind> {
        FrameKind::ALL.into_iter().find(|k| *k as u32 == code)
    }

    /// Lowercase name (`hello`, `pose`, `full`, `delta`, `error`).
    pub fn name(self) -> &'static str {
        match self {
            FrameKind::Hello => "hello",
            FrameKind::Pose => "pose",
            FrameKind::Full => "full",
            FrameKind::Delta => "delta",
            FrameKind::Error => "error",
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
}

impl ErrorCode {
    /// All codes, in wire-code order.
    pub const ALL: [ErrorCode; 6] = [
        ErrorCode::MalformedFrame,
        ErrorCode::UnsupportedVersion,
        ErrorCode::InvalidPose,
        ErrorCode::Overloaded,
        ErrorCode::Internal,
        ErrorCode::UnknownScene,
    ];

    /// The code with wire value `code`, if any.
    pub fn from_u32(code: u32) -> Option<ErrorCode> {
        ErrorCode::ALL.into_iter().find(|c| *c as u32 == code)
    }

    /// The snake_case name (`malformed_frame`, `unsupported_version`, `invalid_pose`,
    /// `overloaded`, `internal`, `unknown_scene`).
    pub fn name(self) -> &'static str {
        match self {
            ErrorCode::MalformedFrame => "malformed_frame",
            ErrorCode::UnsupportedVersion => "unsupported_version",
            ErrorCode::InvalidPose => "invalid_pose",
            ErrorCode::Overloaded => "overloaded",
            ErrorCode::Internal => "internal",
            ErrorCode::UnknownScene => "unknown_scene",
        }
    }
}

impl fmt::Display for ErrorCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The 5-word statistics block of Full and Delta frames, in wire order.
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

    fn to_words(self) -> [u32; STATS_WORDS] {
        [
            self.candidates,
            self.occluders_used,
            self.dropped_poses,
            self.gpu_us,
            self.total_us,
        ]
    }

    fn from_words(w: [u32; STATS_WORDS]) -> FrameStats {
        let [candidates, occluders_used, dropped_poses, gpu_us, total_us] = w;
        FrameStats {
            candidates,
            occluders_used,
            dropped_poses,
            gpu_us,
            total_us,
        }
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
        }
    }

    /// A frame carrying `pose`, or `None` if the pose uses `look_at` or `up`: the binary
    /// frame carries only quaternions. A pose with neither `rotation` nor `look_at` looks
    /// along −Z, which is the identity quaternion `[0, 0, 0, 1]`.
    pub fn from_pose(seq: u32, want_full: bool, pose: &Pose) -> Option<PoseFrame> {
        if pose.look_at.is_some() || pose.up.is_some() {
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
}

/// Why a frame did not decode (or a delta did not apply).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    #[error("frame too short: {len} bytes, the header alone is {header} bytes", header = HEADER_BYTES)]
    TooShort { len: usize },
    #[error("frame too long: {len} bytes, the limit is {max} bytes", max = MAX_FRAME_BYTES)]
    TooLong { len: usize },
    #[error("frame length {len} bytes is not a multiple of 4")]
    NotWordAligned { len: usize },
    #[error("bad magic {found:#010x}, expected {magic:#010x} (bytes 48 4d 43 4c, \"HMCL\")", magic = MAGIC)]
    BadMagic { found: u32 },
    #[error("unsupported protocol version {found}, this build supports version {supported}")]
    UnsupportedVersion { found: u32, supported: u32 },
    #[error("unknown frame kind {kind} (expected 1 to 5)")]
    UnknownKind { kind: u32 },
    #[error("{kind} frame has ack {ack}, it must be 0")]
    NonZeroAck { kind: FrameKind, ack: u32 },
    #[error("{kind} payload has {actual} words, its fields need {expected}")]
    PayloadSize {
        kind: FrameKind,
        expected: u64,
        actual: usize,
    },
    #[error("{list} ids not strictly ascending: {id} at index {index} follows {prev}")]
    NotAscending {
        list: &'static str,
        index: usize,
        prev: u32,
        id: u32,
    },
    #[error("id {id} is both in the added and in the removed list of a delta")]
    IdInBothLists { id: u32 },
    #[error("pose flags {flags:#x} set bits other than bit 0 (want_full)")]
    BadFlags { flags: u32 },
    #[error("{field} is not valid UTF-8")]
    InvalidUtf8 { field: &'static str },
    #[error("padding after {field} is not zero")]
    NonZeroPadding { field: &'static str },
    #[error("unknown error code {code} (expected 1 to 6)")]
    UnknownErrorCode { code: u32 },
    #[error("delta removes id {id}, which is not in the visible set")]
    RemovedAbsent { id: u32 },
    #[error("delta adds id {id}, which is already in the visible set")]
    AddedPresent { id: u32 },
    #[error(
        "delta lists too long: {added} added and {removed} removed ids, a delta frame carries at most {max} per list (send a full frame)",
        max = MAX_DELTA_IDS
    )]
    DeltaTooLarge { added: usize, removed: usize },
}

impl FrameError {
    /// The code to answer this error with: [`ErrorCode::UnsupportedVersion`] for a version
    /// mismatch, [`ErrorCode::MalformedFrame`] otherwise.
    pub fn code(&self) -> ErrorCode {
        match self {
            FrameError::UnsupportedVersion { .. } => ErrorCode::UnsupportedVersion,
            _ => ErrorCode::MalformedFrame,
        }
    }
}

impl Frame {
    /// What this frame is.
    pub fn kind(&self) -> FrameKind {
        match self {
            Frame::Hello(_) => FrameKind::Hello,
            Frame::Pose(_) => FrameKind::Pose,
            Frame::Full(_) => FrameKind::Full,
            Frame::Delta(_) => FrameKind::Delta,
            Frame::Error(_) => FrameKind::Error,
        }
    }

    /// Header word 2: the sender's sequence number.
    pub fn seq(&self) -> u32 {
        match self {
            Frame::Hello(f) => f.seq,
            Frame::Pose(f) => f.seq,
            Frame::Full(f) => f.seq,
            Frame::Delta(f) => f.seq,
            Frame::Error(f) => f.seq,
        }
    }

    /// Header word 3: the pose sequence number answered (always 0 for Hello and Pose).
    pub fn ack(&self) -> u32 {
        match self {
            Frame::Hello(_) | Frame::Pose(_) => 0,
            Frame::Full(f) => f.ack,
            Frame::Delta(f) => f.ack,
            Frame::Error(f) => f.ack,
        }
    }

    /// Words after the header.
    fn payload_words(&self) -> usize {
        match self {
            Frame::Hello(h) => 2 + h.info_json.len().div_ceil(4),
            Frame::Pose(_) => POSE_PAYLOAD_WORDS,
            Frame::Full(f) => STATS_WORDS + 1 + f.ids.len(),
            Frame::Delta(d) => STATS_WORDS + 1 + d.added.len() + d.removed.len(),
            Frame::Error(e) => 2 + e.message.len().div_ceil(4),
        }
    }

    /// Length in bytes of [`Frame::encode`]'s output.
    pub fn encoded_len(&self) -> usize {
        (HEADER_WORDS + self.payload_words()) * 4
    }

    /// Checks what [`Frame::encode`] does not: that the ID lists are strictly ascending
    /// (and disjoint, for a delta), a delta's lists fit ([`VisibleDelta::fits`]) and the
    /// frame fits in [`MAX_FRAME_BYTES`]. A frame that passes encodes to bytes that
    /// [`Frame::decode`] accepts and decodes to an equal frame.
    pub fn validate(&self) -> Result<(), FrameError> {
        if let Frame::Delta(d) = self {
            if !d.fits() {
                return Err(FrameError::DeltaTooLarge {
                    added: d.added.len(),
                    removed: d.removed.len(),
                });
            }
        }
        let len = self.encoded_len();
        if len > MAX_FRAME_BYTES {
            return Err(FrameError::TooLong { len });
        }
        match self {
            Frame::Full(f) => check_ascending("full", &f.ids),
            Frame::Delta(d) => {
                check_ascending("added", &d.added)?;
                check_ascending("removed", &d.removed)?;
                check_disjoint(&d.added, &d.removed)
            }
            Frame::Hello(_) | Frame::Pose(_) | Frame::Error(_) => Ok(()),
        }
    }

    /// The frame's bytes.
    ///
    /// Writes the fields as they are: ID lists that are not strictly ascending produce a
    /// frame that [`Frame::decode`] rejects (see [`Frame::validate`]).
    ///
    /// # Panics
    ///
    /// If a delta does not [fit](VisibleDelta::fits) (more than [`MAX_DELTA_IDS`] IDs in a
    /// list), or a string or ID list has more than `u32::MAX` elements (the frame could
    /// not describe it, and would be far beyond [`MAX_FRAME_BYTES`] anyway).
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer(Vec::with_capacity(self.encoded_len()));
        w.word(MAGIC);
        w.word(PROTOCOL_VERSION | ((self.kind() as u32) << 16));
        w.word(self.seq());
        w.word(self.ack());
        match self {
            Frame::Hello(h) => {
                w.word(h.object_count);
                w.text(&h.info_json);
            }
            Frame::Pose(p) => {
                w.word(if p.want_full { POSE_FLAG_WANT_FULL } else { 0 });
                for v in p
                    .position
                    .into_iter()
                    .chain(p.rotation)
                    .chain([p.fov_y_deg])
                {
                    w.f32(v);
                }
                w.word(p.viewport[0]);
                w.word(p.viewport[1]);
                w.f32(p.near);
                w.f32(p.far);
            }
            Frame::Full(f) => {
                w.words(&f.stats.to_words());
                w.word(len_u32(f.ids.len()));
                w.words(&f.ids);
            }
            Frame::Delta(d) => {
                assert!(
                    d.fits(),
                    "a delta frame carries at most {MAX_DELTA_IDS} ids per list, got {} added and {} removed: send a full frame",
                    d.added.len(),
                    d.removed.len()
                );
                w.words(&d.stats.to_words());
                // Both fit in 16 bits (checked above).
                w.word(len_u32(d.added.len()) | (len_u32(d.removed.len()) << 16));
                w.words(&d.added);
                w.words(&d.removed);
            }
            Frame::Error(e) => {
                w.word(e.code as u32);
                w.text(&e.message);
            }
        }
        debug_assert_eq!(w.0.len(), self.encoded_len());
        w.0
    }

    /// Parses one frame. Never panics; see the [module docs](self) for what is checked.
    pub fn decode(bytes: &[u8]) -> Result<Frame, FrameError> {
        let len = bytes.len();
        if len > MAX_FRAME_BYTES {
            return Err(FrameError::TooLong { len });
        }
        let Some((header, payload)) = bytes.split_at_checked(HEADER_BYTES) else {
            return Err(FrameError::TooShort { len });
        };
        if !len.is_multiple_of(4) {
            return Err(FrameError::NotWordAligned { len });
        }
        let mut h = [0u32; HEADER_WORDS];
        fill_words(&mut h, header);
        let [magic, version_kind, seq, ack] = h;
        if magic != MAGIC {
            return Err(FrameError::BadMagic { found: magic });
        }
        let (version, kind) = (version_kind & 0xFFFF, version_kind >> 16);
        if version != PROTOCOL_VERSION {
            return Err(FrameError::UnsupportedVersion {
                found: version,
                supported: PROTOCOL_VERSION,
            });
        }
        let kind = FrameKind::from_u32(kind).ok_or(FrameError::UnknownKind { kind })?;
        if matches!(kind, FrameKind::Hello | FrameKind::Pose) && ack != 0 {
            return Err(FrameError::NonZeroAck { kind, ack });
        }
        let mut p = Reader {
            kind,
            rest: payload,
            words: payload.len() / 4,
        };
        Ok(match kind {
            FrameKind::Hello => {
                let [object_count, byte_len] = p.fixed()?;
                let info_json = p.text("hello JSON", byte_len)?;
                Frame::Hello(Hello {
                    seq,
                    object_count,
                    info_json,
                })
            }
            FrameKind::Pose => {
                let w: [u32; POSE_PAYLOAD_WORDS] = p.fixed()?;
                p.tail(0)?;
                let [
                    flags,
                    px,
                    py,
                    pz,
                    qx,
                    qy,
                    qz,
                    qw,
                    fov,
                    width,
                    height,
                    near,
                    far,
                ] = w;
                if flags & !POSE_FLAG_WANT_FULL != 0 {
                    return Err(FrameError::BadFlags { flags });
                }
                let f = f32::from_bits;
                Frame::Pose(PoseFrame {
                    seq,
                    want_full: flags & POSE_FLAG_WANT_FULL != 0,
                    position: [f(px), f(py), f(pz)],
                    rotation: [f(qx), f(qy), f(qz), f(qw)],
                    fov_y_deg: f(fov),
                    viewport: [width, height],
                    near: f(near),
                    far: f(far),
                })
            }
            FrameKind::Full => {
                let stats = FrameStats::from_words(p.fixed()?);
                let [count] = p.fixed()?;
                let ids = decode_ids("full", p.tail(u64::from(count))?)?;
                Frame::Full(VisibleFull {
                    seq,
                    ack,
                    stats,
                    ids,
                })
            }
            FrameKind::Delta => {
                let stats = FrameStats::from_words(p.fixed()?);
                let [counts] = p.fixed()?;
                let (added_count, removed_count) = (counts & 0xFFFF, counts >> 16);
                let tail = p.tail(u64::from(added_count) + u64::from(removed_count))?;
                // `tail` holds exactly added_count + removed_count words, so this fits.
                let split = usize::try_from(added_count)
                    .ok()
                    .and_then(|n| n.checked_mul(4))
                    .and_then(|at| tail.split_at_checked(at));
                let Some((added, removed)) = split else {
                    return Err(p.size_error(u64::from(added_count) + u64::from(removed_count)));
                };
                let added = decode_ids("added", added)?;
                let removed = decode_ids("removed", removed)?;
                check_disjoint(&added, &removed)?;
                Frame::Delta(VisibleDelta {
                    seq,
                    ack,
                    stats,
                    added,
                    removed,
                })
            }
            FrameKind::Error => {
                let [code, byte_len] = p.fixed()?;
                let code =
                    ErrorCode::from_u32(code).ok_or(FrameError::UnknownErrorCode { code })?;
                let message = p.text("error message", byte_len)?;
                Frame::Error(ErrorFrame {
                    seq,
                    ack,
                    code,
                    message,
                })
            }
        })
    }
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

/// Applies `delta` to the strictly ascending visible set `set`, keeping it ascending.
///
/// Fails, leaving `set` untouched, if a removed ID is not in the set, an added ID already
/// is, an ID is in both lists, or `set` or one of the lists is not strictly ascending.
pub fn apply_delta(set: &mut Vec<u32>, delta: &VisibleDelta) -> Result<(), FrameError> {
    check_ascending("set", set)?;
    check_ascending("added", &delta.added)?;
    check_ascending("removed", &delta.removed)?;
    check_disjoint(&delta.added, &delta.removed)?;
    let (added, removed) = (&delta.added[..], &delta.removed[..]);
    let mut out = Vec::with_capacity((set.len() + added.len()).saturating_sub(removed.len()));
    let (mut a, mut r) = (0, 0);
    for &id in set.iter() {
        while let Some(&x) = added.get(a) {
            if x > id {
                break;
            }
            if x == id {
                return Err(FrameError::AddedPresent { id });
            }
            out.push(x);
            a += 1;
        }
        match removed.get(r) {
            Some(&x) if x < id => return Err(FrameError::RemovedAbsent { id: x }),
            Some(&x) if x == id => r += 1,
            _ => out.push(id),
        }
    }
    if let Some(&x) = removed.get(r) {
        return Err(FrameError::RemovedAbsent { id: x });
    }
    out.extend_from_slice(added.get(a..).unwrap_or_default());
    *set = out;
    Ok(())
}

/// The delta from `old` to `new` as `(added, removed)`, both strictly ascending.
///
/// Both inputs must be strictly ascending (otherwise the result is meaningless, though
/// this never panics). `apply_delta` of the result to `old` gives `new`.
pub fn diff(old: &[u32], new: &[u32]) -> (Vec<u32>, Vec<u32>) {
    let (mut added, mut removed) = (Vec::new(), Vec::new());
    let (mut i, mut j) = (0, 0);
    loop {
        match (old.get(i), new.get(j)) {
            (Some(&o), Some(&n)) => {
                if o < n {
                    removed.push(o);
                    i += 1;
                } else if n < o {
                    added.push(n);
                    j += 1;
                } else {
                    i += 1;
                    j += 1;
                }
            }
            (Some(&o), None) => {
                removed.push(o);
                i += 1;
            }
            (None, Some(&n)) => {
                added.push(n);
                j += 1;
            }
            (None, None) => break,
        }
    }
    (added, removed)
}

fn len_u32(n: usize) -> u32 {
    u32::try_from(n).expect("frame field longer than u32::MAX elements")
}

fn check_ascending(list: &'static str, ids: &[u32]) -> Result<(), FrameError> {
    for (index, pair) in ids.windows(2).enumerate() {
        if let [prev, id] = *pair {
            if id <= prev {
                return Err(FrameError::NotAscending {
                    list,
                    index: index + 1,
                    prev,
                    id,
                });
            }
        }
    }
    Ok(())
}

/// First ID common to two ascending lists, as an error.
fn check_disjoint(a: &[u32], b: &[u32]) -> Result<(), FrameError> {
    let (mut i, mut j) = (0, 0);
    while let (Some(&x), Some(&y)) = (a.get(i), b.get(j)) {
        if x == y {
            return Err(FrameError::IdInBothLists { id: x });
        }
        if x < y {
            i += 1;
        } else {
            j += 1;
        }
    }
    Ok(())
}

/// Fills `out` with the little-endian words of `bytes` (as many as both have).
fn fill_words(out: &mut [u32], bytes: &[u8]) {
    for (o, c) in out.iter_mut().zip(bytes.chunks_exact(4)) {
        *o = u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
    }
}

/// Strictly ascending IDs from a whole number of words.
fn decode_ids(list: &'static str, bytes: &[u8]) -> Result<Vec<u32>, FrameError> {
    // Allocation bounded by the input: one u32 per four input bytes.
    let mut ids = Vec::with_capacity(bytes.len() / 4);
    for c in bytes.chunks_exact(4) {
        let id = u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
        if let Some(&prev) = ids.last() {
            if id <= prev {
                return Err(FrameError::NotAscending {
                    list,
                    index: ids.len(),
                    prev,
                    id,
                });
            }
        }
        ids.push(id);
    }
    Ok(ids)
}

struct Writer(Vec<u8>);

impl Writer {
    fn word(&mut self, w: u32) {
        self.0.extend_from_slice(&w.to_le_bytes());
    }

    fn words(&mut self, ws: &[u32]) {
        for &w in ws {
            self.word(w);
        }
    }

    fn f32(&mut self, v: f32) {
        self.word(v.to_bits());
    }

    /// `[byte_len]`, the bytes, zero padding to a word.
    fn text(&mut self, s: &str) {
        self.word(len_u32(s.len()));
        self.0.extend_from_slice(s.as_bytes());
        let pad = s.len().next_multiple_of(4) - s.len();
        self.0.extend_from_slice(&[0; 3][..pad]);
    }
}

/// The payload of one frame, consumed front to back.
struct Reader<'a> {
    kind: FrameKind,
    rest: &'a [u8],
    /// Words in the whole payload.
    words: usize,
}

impl<'a> Reader<'a> {
    fn consumed(&self) -> u64 {
        (self.words - self.rest.len() / 4) as u64
    }

    /// The payload does not have the `expected` words its fields call for.
    fn size_error(&self, expected_after_consumed: u64) -> FrameError {
        FrameError::PayloadSize {
            kind: self.kind,
            expected: self.consumed().saturating_add(expected_after_consumed),
            actual: self.words,
        }
    }

    /// The next `N` words, which must be there.
    fn fixed<const N: usize>(&mut self) -> Result<[u32; N], FrameError> {
        let Some((head, rest)) = self.rest.split_at_checked(N * 4) else {
            return Err(self.size_error(N as u64));
        };
        self.rest = rest;
        let mut out = [0; N];
        fill_words(&mut out, head);
        Ok(out)
    }

    /// All the remaining words, which must be exactly `n`.
    fn tail(&mut self, n: u64) -> Result<&'a [u8], FrameError> {
        if (self.rest.len() / 4) as u64 != n {
            return Err(self.size_error(n));
        }
        Ok(std::mem::take(&mut self.rest))
    }

    /// The rest of the payload as `byte_len` bytes of UTF-8 plus zero padding to a word.
    fn text(&mut self, field: &'static str, byte_len: u32) -> Result<String, FrameError> {
        let n = u64::from(byte_len);
        let padded = self.tail(n.div_ceil(4))?;
        let split = usize::try_from(byte_len)
            .ok()
            .and_then(|at| padded.split_at_checked(at));
        let Some((text, padding)) = split else {
            return Err(self.size_error(n.div_ceil(4)));
        };
        if padding.iter().any(|&b| b != 0) {
            return Err(FrameError::NonZeroPadding { field });
        }
        match std::str::from_utf8(text) {
            Ok(s) => Ok(s.to_owned()),
            Err(_) => Err(FrameError::InvalidUtf8 { field }),
        }
    }
}
