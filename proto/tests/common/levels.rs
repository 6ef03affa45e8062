//! Frames with levels of detail (kinds 6 and 7) the decoder refuses, shared with
//! `reject.rs`'s list of every rejected input.

use homcull_proto::frame::{FrameError, FrameKind};

use super::{delta_lod, full_lod};

/// Frames with levels of detail (kinds 6 and 7) that the decoder refuses.
pub fn lod_cases() -> Vec<(&'static str, Vec<u8>, FrameError)> {
    use FrameError as E;
    vec![
        (
            "full_lod without its level word",
            full_lod(&[1, 2], &[]),
            E::PayloadSize {
                kind: FrameKind::FullLod,
                expected: 6 + 1 + 3,
                actual: 6 + 1 + 2,
            },
        ),
        (
            "full_lod with level 9",
            full_lod(&[1, 2], &[u32::from_le_bytes([0, 9, 0, 0])]),
            E::BadLevel { level: 9 },
        ),
        (
            "full_lod padding not zero",
            full_lod(&[1, 2], &[u32::from_le_bytes([0, 1, 0, 1])]),
            E::NonZeroPadding { field: "levels" },
        ),
        (
            "full_lod ids not ascending",
            full_lod(&[2, 1], &[0]),
            E::NotAscending {
                list: "full",
                index: 1,
                prev: 2,
                id: 1,
            },
        ),
        (
            "delta_lod one level word short",
            delta_lod(&[4], &[], &[7], &[]),
            E::PayloadSize {
                kind: FrameKind::DeltaLod,
                expected: 6 + 2 + 2 + 1,
                actual: 6 + 2 + 2,
            },
        ),
        (
            "delta_lod changed not ascending",
            delta_lod(&[], &[], &[7, 3], &[0]),
            E::NotAscending {
                list: "changed",
                index: 1,
                prev: 7,
                id: 3,
            },
        ),
        (
            "delta_lod changes an id it adds",
            delta_lod(&[3, 7], &[], &[7], &[0]),
            E::ChangedNotKept { id: 7 },
        ),
        (
            "delta_lod changes an id it removes",
            delta_lod(&[], &[5], &[5], &[0]),
            E::ChangedNotKept { id: 5 },
        ),
        (
            "delta_lod with level 255",
            delta_lod(&[3], &[], &[], &[u32::from_le_bytes([255, 0, 0, 0])]),
            E::BadLevel { level: 255 },
        ),
    ]
}
