//! Hand-crafted frames for the rejection tests: raw words, headers, and the payloads of
//! each frame kind.
#![allow(dead_code)]

pub mod levels;
pub mod motion;

use homcull_proto::PROTOCOL_VERSION;
use homcull_proto::frame::{FrameError, MAGIC};

/// Name of each variant; the exhaustive match makes a new variant fail to compile here
/// until it gets a rejection test.
pub fn variant(e: &FrameError) -> &'static str {
    match e {
        FrameError::TooShort { .. } => "TooShort",
        FrameError::TooLong { .. } => "TooLong",
        FrameError::NotWordAligned { .. } => "NotWordAligned",
        FrameError::BadMagic { .. } => "BadMagic",
        FrameError::UnsupportedVersion { .. } => "UnsupportedVersion",
        FrameError::UnknownKind { .. } => "UnknownKind",
        FrameError::NonZeroAck { .. } => "NonZeroAck",
        FrameError::PayloadSize { .. } => "PayloadSize",
        FrameError::NotAscending { .. } => "NotAscending",
        FrameError::IdInBothLists { .. } => "IdInBothLists",
        FrameError::BadFlags { .. } => "BadFlags",
        FrameError::InvalidUtf8 { .. } => "InvalidUtf8",
        FrameError::NonZeroPadding { .. } => "NonZeroPadding",
        FrameError::UnknownErrorCode { .. } => "UnknownErrorCode",
        FrameError::RemovedAbsent { .. } => "RemovedAbsent",
        FrameError::AddedPresent { .. } => "AddedPresent",
        FrameError::DeltaTooLarge { .. } => "DeltaTooLarge",
        FrameError::BadLevel { .. } => "BadLevel",
        FrameError::ChangedNotKept { .. } => "ChangedNotKept",
        FrameError::LevelCount { .. } => "LevelCount",
    }
}

pub const ALL_VARIANTS: [&str; 20] = [
    "TooShort",
    "TooLong",
    "NotWordAligned",
    "BadMagic",
    "UnsupportedVersion",
    "UnknownKind",
    "NonZeroAck",
    "PayloadSize",
    "NotAscending",
    "IdInBothLists",
    "BadFlags",
    "InvalidUtf8",
    "NonZeroPadding",
    "UnknownErrorCode",
    "RemovedAbsent",
    "AddedPresent",
    "DeltaTooLarge",
    "BadLevel",
    "ChangedNotKept",
    "LevelCount",
];

pub fn bytes(words: &[u32]) -> Vec<u8> {
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}

/// Header word 1: the version in the low 16 bits, the kind in the high 16 bits.
pub fn version_kind(version: u32, kind: u32) -> u32 {
    version | (kind << 16)
}

/// A frame with a correct header around `payload`.
pub fn frame(kind: u32, seq: u32, ack: u32, payload: &[u32]) -> Vec<u8> {
    let mut w = vec![MAGIC, version_kind(PROTOCOL_VERSION, kind), seq, ack];
    w.extend_from_slice(payload);
    bytes(&w)
}

pub fn stats() -> [u32; 6] {
    [9, 3, 0, 100, 200, 7]
}

/// A Transforms payload (horizon absent) moving objects `ids` to the identity, still.
pub fn moved_objects(ids: &[u32]) -> Vec<u32> {
    let mut p = vec![homcull_proto::frame::motion::NO_VALUE, ids.len() as u32];
    for &id in ids {
        p.push(id);
        p.extend(
            [
                1.0f32, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0,
            ]
            .map(f32::to_bits),
        );
        p.extend([0u32; 6]);
        p.push(homcull_proto::frame::motion::NO_VALUE);
    }
    p
}

pub fn full(ids: &[u32]) -> Vec<u8> {
    let mut p = stats().to_vec();
    p.push(ids.len() as u32);
    p.extend_from_slice(ids);
    frame(3, 1, 1, &p)
}

pub fn delta(added: &[u32], removed: &[u32]) -> Vec<u8> {
    let mut p = stats().to_vec();
    p.push(added.len() as u32 | ((removed.len() as u32) << 16));
    p.extend_from_slice(added);
    p.extend_from_slice(removed);
    frame(4, 1, 1, &p)
}

/// A full frame with levels (kind 6): `ids`, then `level_words` as given.
pub fn full_lod(ids: &[u32], level_words: &[u32]) -> Vec<u8> {
    let mut p = stats().to_vec();
    p.push(ids.len() as u32);
    p.extend_from_slice(ids);
    p.extend_from_slice(level_words);
    frame(6, 1, 1, &p)
}

/// A delta with levels (kind 7): the lists, then `level_words` as given.
pub fn delta_lod(added: &[u32], removed: &[u32], changed: &[u32], level_words: &[u32]) -> Vec<u8> {
    let mut p = stats().to_vec();
    p.push(added.len() as u32 | ((removed.len() as u32) << 16));
    p.push(changed.len() as u32);
    for list in [added, removed, changed] {
        p.extend_from_slice(list);
    }
    p.extend_from_slice(level_words);
    frame(7, 1, 1, &p)
}

/// `[a][byte_len]` and the bytes padded with `pad` bytes.
pub fn text_payload(first: u32, text: &[u8], pad: u8) -> Vec<u32> {
    let mut b = text.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(pad);
    }
    let mut p = vec![first, text.len() as u32];
    p.extend(
        b.chunks(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])),
    );
    p
}

pub fn pose(flags: u32) -> Vec<u8> {
    let mut p = vec![flags];
    p.extend([0.0f32, 1.0, 2.0, 0.0, 0.0, 0.0, 1.0, 60.0].map(f32::to_bits));
    p.extend([960, 540]);
    p.extend([0.1f32, 100.0].map(f32::to_bits));
    frame(2, 7, 0, &p)
}
