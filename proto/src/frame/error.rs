//! Why a frame did not decode, validate, or apply.

use super::*;

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
    #[error("unknown frame kind {kind} (expected 1 to 9)")]
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
    #[error("pose flags {flags:#x} set bits other than bit 0 (want_full) and bit 1 (stereo)")]
    BadFlags { flags: u32 },
    #[error("{field} is not valid UTF-8")]
    InvalidUtf8 { field: &'static str },
    #[error("padding after {field} is not zero")]
    NonZeroPadding { field: &'static str },
    #[error("unknown error code {code} (expected 1 to 8)")]
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
    #[error("level of detail {level} is above the largest, {max}", max = MAX_LEVEL)]
    BadLevel { level: u8 },
    #[error("delta changes the level of id {id}, which it also adds or removes")]
    ChangedNotKept { id: u32 },
    #[error("{ids} ids but {levels} levels of detail")]
    LevelCount { ids: usize, levels: usize },
}

impl FrameError {
    /// The code to answer this error with: [`ErrorCode::UnsupportedVersion`] for a version
    /// mismatch, [`ErrorCode::MalformedFrame`] otherwise.
    #[allow(
        clippy::wildcard_enum_match_arm,
        reason = "every other error is a malformed frame, new ones included"
    )]
    pub fn code(&self) -> ErrorCode {
        match self {
            FrameError::UnsupportedVersion { .. } => ErrorCode::UnsupportedVersion,
            _ => ErrorCode::MalformedFrame,
        }
    }
}
