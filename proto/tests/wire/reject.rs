//! Every `FrameError` variant, produced by a hand-crafted input.

use crate::common;

use std::collections::BTreeSet;

use common::*;

use homcull_proto::PROTOCOL_VERSION;
use homcull_proto::frame::{
    ErrorCode, Frame, FrameError, FrameKind, FrameStats, HEADER_BYTES, MAGIC, MAX_DELTA_IDS,
    MAX_FRAME_BYTES, VisibleDelta, apply_delta,
};

/// Every rejected input with the error it must produce.
fn cases() -> Vec<(&'static str, Vec<u8>, FrameError)> {
    use FrameError as E;
    let mut long = vec![0u8; MAX_FRAME_BYTES + 4];
    long[..4].copy_from_slice(&MAGIC.to_le_bytes());
    let mut unaligned = full(&[1, 2]);
    unaligned.push(0);
    let mut cases = vec![
        ("empty", vec![], E::TooShort { len: 0 }),
        (
            "header minus a word",
            frame(3, 0, 0, &[])[..12].to_vec(),
            E::TooShort { len: 12 },
        ),
        (
            "over the limit, checked first",
            long,
            E::TooLong {
                len: MAX_FRAME_BYTES + 4,
            },
        ),
        (
            "over the limit by a byte",
            vec![0xFF; MAX_FRAME_BYTES + 1],
            E::TooLong {
                len: MAX_FRAME_BYTES + 1,
            },
        ),
        ("a stray byte", unaligned, E::NotWordAligned { len: 53 }),
        (
            "big-endian magic",
            bytes(&[0x484D_434C, version_kind(2, 3), 0, 0]),
            E::BadMagic { found: 0x484D_434C },
        ),
        ("zero magic", vec![0; 16], E::BadMagic { found: 0 }),
        (
            "a version 1 full frame (version word 1, kind in word 2, payload length in word 5)",
            bytes(&[MAGIC, 1, 3, 2, 42, 9, 1234, 10, 1224, 4, 2, 1, 850, 1200, 0]),
            E::UnsupportedVersion {
                found: 1,
                supported: PROTOCOL_VERSION,
            },
        ),
        (
            "version 3 (before the scene version word and the writer's frames)",
            bytes(&[MAGIC, version_kind(3, 3), 0, 0]),
            E::UnsupportedVersion {
                found: 3,
                supported: PROTOCOL_VERSION,
            },
        ),
        (
            "version 0",
            bytes(&[MAGIC, version_kind(0, 3), 0, 0]),
            E::UnsupportedVersion {
                found: 0,
                supported: PROTOCOL_VERSION,
            },
        ),
        (
            "version and kind swapped",
            bytes(&[MAGIC, version_kind(3, 4), 0, 0]),
            E::UnsupportedVersion {
                found: 3,
                supported: PROTOCOL_VERSION,
            },
        ),
        ("kind 0", frame(0, 0, 0, &[]), E::UnknownKind { kind: 0 }),
        ("kind 11", frame(11, 0, 0, &[]), E::UnknownKind { kind: 11 }),
        (
            "kind 0xffff",
            frame(0xFFFF, 0, 0, &[]),
            E::UnknownKind { kind: 0xFFFF },
        ),
        (
            "hello with an ack",
            frame(1, 1, 9, &text_payload(5, b"{}", 0)),
            E::NonZeroAck {
                kind: FrameKind::Hello,
                ack: 9,
            },
        ),
        (
            "pose with an ack",
            {
                let mut p = pose(0);
                p[12..16].copy_from_slice(&3u32.to_le_bytes());
                p
            },
            E::NonZeroAck {
                kind: FrameKind::Pose,
                ack: 3,
            },
        ),
        (
            "pose one word short",
            frame(2, 0, 0, &[0; 12]),
            E::PayloadSize {
                kind: FrameKind::Pose,
                expected: 13,
                actual: 12,
            },
        ),
        (
            "pose one word long",
            frame(2, 0, 0, &[0; 14]),
            E::PayloadSize {
                kind: FrameKind::Pose,
                expected: 13,
                actual: 14,
            },
        ),
        (
            "full without its count",
            frame(3, 0, 0, &stats()),
            E::PayloadSize {
                kind: FrameKind::Full,
                expected: 7,
                actual: 6,
            },
        ),
        (
            "full count larger than its ids",
            {
                let mut p = stats().to_vec();
                p.extend([5, 1, 2, 3]);
                frame(3, 0, 0, &p)
            },
            E::PayloadSize {
                kind: FrameKind::Full,
                expected: 12,
                actual: 10,
            },
        ),
        (
            "full count u32::MAX (must not allocate it)",
            {
                let mut p = stats().to_vec();
                p.extend([u32::MAX, 1]);
                frame(3, 0, 0, &p)
            },
            E::PayloadSize {
                kind: FrameKind::Full,
                expected: 7 + u64::from(u32::MAX),
                actual: 8,
            },
        ),
        (
            "delta counts both 65535 (must not allocate them)",
            {
                let mut p = stats().to_vec();
                p.extend([u32::MAX, 1]);
                frame(4, 0, 0, &p)
            },
            E::PayloadSize {
                kind: FrameKind::Delta,
                expected: 7 + 2 * 65535,
                actual: 8,
            },
        ),
        (
            "delta counts word: 1 added in the low half, 1 removed in the high half",
            {
                let mut p = stats().to_vec();
                p.extend([0x0001_0001, 5]);
                frame(4, 0, 0, &p)
            },
            E::PayloadSize {
                kind: FrameKind::Delta,
                expected: 9,
                actual: 8,
            },
        ),
        (
            "delta with its counts read as v1 (two words)",
            {
                let mut p = stats().to_vec();
                p.extend([1, 1, 5, 6]);
                frame(4, 0, 0, &p)
            },
            E::PayloadSize {
                kind: FrameKind::Delta,
                expected: 8,
                actual: 10,
            },
        ),
        (
            "delta without its counts",
            frame(4, 0, 0, &[0; 6]),
            E::PayloadSize {
                kind: FrameKind::Delta,
                expected: 7,
                actual: 6,
            },
        ),
        (
            "hello JSON longer than the payload",
            frame(1, 0, 0, &[3, u32::MAX, 0x2020_7B7B]),
            E::PayloadSize {
                kind: FrameKind::Hello,
                expected: 2 + u64::from(u32::MAX).div_ceil(4),
                actual: 3,
            },
        ),
        (
            "hello with a trailing word",
            {
                let mut p = text_payload(3, b"{}", 0);
                p.push(0);
                frame(1, 0, 0, &p)
            },
            E::PayloadSize {
                kind: FrameKind::Hello,
                expected: 3,
                actual: 4,
            },
        ),
        (
            "hello without its length",
            frame(1, 0, 0, &[3]),
            E::PayloadSize {
                kind: FrameKind::Hello,
                expected: 2,
                actual: 1,
            },
        ),
        (
            "error message shorter than its length",
            frame(5, 0, 0, &[1, 9, 0x6161_6161, 0x6161_6161]),
            E::PayloadSize {
                kind: FrameKind::Error,
                expected: 5,
                actual: 4,
            },
        ),
        (
            "full ids repeated",
            full(&[1, 4, 4]),
            E::NotAscending {
                list: "full",
                index: 2,
                prev: 4,
                id: 4,
            },
        ),
        (
            "full ids descending",
            full(&[9, 2]),
            E::NotAscending {
                list: "full",
                index: 1,
                prev: 9,
                id: 2,
            },
        ),
        (
            "delta added descending",
            delta(&[1, 7, 3], &[]),
            E::NotAscending {
                list: "added",
                index: 2,
                prev: 7,
                id: 3,
            },
        ),
        (
            "delta removed repeated",
            delta(&[], &[0, 0]),
            E::NotAscending {
                list: "removed",
                index: 1,
                prev: 0,
                id: 0,
            },
        ),
        (
            "delta id in both lists",
            delta(&[1, 2, 8], &[0, 8]),
            E::IdInBothLists { id: 8 },
        ),
        ("pose flag bit 2", pose(4), E::BadFlags { flags: 4 }),
        (
            "stereo pose without its two words",
            pose(2),
            E::PayloadSize {
                kind: FrameKind::Pose,
                expected: 15,
                actual: 13,
            },
        ),
        (
            "pose flag bit 31",
            pose(0x8000_0001),
            E::BadFlags { flags: 0x8000_0001 },
        ),
        (
            "hello JSON not UTF-8",
            frame(1, 0, 0, &text_payload(3, b"{\"a\":\"\xff\"}", 0)),
            E::InvalidUtf8 {
                field: "hello JSON",
            },
        ),
        (
            "error message with a truncated UTF-8 sequence",
            frame(5, 0, 0, &text_payload(5, b"deg \xc2", 0)),
            E::InvalidUtf8 {
                field: "error message",
            },
        ),
        (
            "hello padding not zero",
            frame(1, 0, 0, &text_payload(3, b"{}", b' ')),
            E::NonZeroPadding {
                field: "hello JSON",
            },
        ),
        (
            "error padding not zero",
            frame(5, 0, 0, &text_payload(4, b"busy!", 1)),
            E::NonZeroPadding {
                field: "error message",
            },
        ),
        (
            "error code 0",
            frame(5, 0, 0, &text_payload(0, b"x", 0)),
            E::UnknownErrorCode { code: 0 },
        ),
        (
            "error code 9",
            frame(5, 0, 0, &text_payload(9, b"x", 0)),
            E::UnknownErrorCode { code: 9 },
        ),
    ];
    cases.extend(levels::lod_cases());
    cases.extend(motion::transforms_cases());
    cases.push((
        "delta removed repeated after a non-empty added list",
        delta(&[5], &[6, 6]),
        E::NotAscending {
            list: "removed",
            index: 1,
            prev: 6,
            id: 6,
        },
    ));
    cases
}

#[test]
fn every_crafted_input_is_rejected_as_expected() {
    for (what, input, expected) in cases() {
        let got = Frame::decode(&input);
        assert_eq!(got, Err(expected.clone()), "{what}");
        assert!(!expected.to_string().is_empty());
    }
}

/// `apply_delta`'s own errors, with the inputs that produce them.
fn apply_cases() -> Vec<(&'static str, Vec<u32>, VisibleDelta, FrameError)> {
    let d = |added: &[u32], removed: &[u32]| VisibleDelta {
        seq: 1,
        ack: 1,
        stats: FrameStats::default(),
        added: added.to_vec(),
        removed: removed.to_vec(),
        lod: None,
    };
    vec![
        (
            "removed id absent",
            vec![1, 5, 9],
            d(&[], &[4]),
            FrameError::RemovedAbsent { id: 4 },
        ),
        (
            "removed id past the end",
            vec![1, 5, 9],
            d(&[2], &[9, 12]),
            FrameError::RemovedAbsent { id: 12 },
        ),
        (
            "removed from the empty set",
            vec![],
            d(&[], &[0]),
            FrameError::RemovedAbsent { id: 0 },
        ),
        (
            "added id present",
            vec![1, 5, 9],
            d(&[0, 5], &[]),
            FrameError::AddedPresent { id: 5 },
        ),
        (
            "set not ascending",
            vec![3, 1],
            d(&[], &[]),
            FrameError::NotAscending {
                list: "set",
                index: 1,
                prev: 3,
                id: 1,
            },
        ),
        (
            "added not ascending",
            vec![],
            d(&[2, 2], &[]),
            FrameError::NotAscending {
                list: "added",
                index: 1,
                prev: 2,
                id: 2,
            },
        ),
        (
            "id in both lists",
            vec![4],
            d(&[4], &[4]),
            FrameError::IdInBothLists { id: 4 },
        ),
    ]
}

#[test]
fn apply_delta_rejects_and_leaves_the_set_alone() {
    for (what, set, delta, expected) in apply_cases() {
        let mut s = set.clone();
        assert_eq!(apply_delta(&mut s, &delta), Err(expected), "{what}");
        assert_eq!(s, set, "{what}: set changed on error");
    }
}

/// Frames that `Frame::validate` refuses (and `Frame::encode` must not be given).
fn validate_cases() -> Vec<(&'static str, Frame, FrameError)> {
    let d = |added: u32, removed: u32| {
        Frame::Delta(VisibleDelta {
            added: (0..added).collect(),
            removed: (added..added + removed).collect(),
            ..VisibleDelta::default()
        })
    };
    let max = MAX_DELTA_IDS as u32;
    vec![
        (
            "delta adding 65536 ids",
            d(max + 1, 0),
            FrameError::DeltaTooLarge {
                added: MAX_DELTA_IDS + 1,
                removed: 0,
            },
        ),
        (
            "delta removing 65536 ids",
            d(3, max + 1),
            FrameError::DeltaTooLarge {
                added: 3,
                removed: MAX_DELTA_IDS + 1,
            },
        ),
    ]
}

#[test]
fn validate_rejects_deltas_that_do_not_fit() {
    for (what, frame, expected) in validate_cases() {
        assert_eq!(frame.validate(), Err(expected.clone()), "{what}");
        let Frame::Delta(d) = &frame else {
            unreachable!()
        };
        assert!(!d.fits(), "{what}");
        assert_eq!(expected.code(), ErrorCode::MalformedFrame);
        assert!(expected.to_string().contains("65535"), "{expected}");
    }
    // The largest delta that fits, both lists full: 16 + 4 * (6 + 1 + 2 * 65535) bytes.
    let max = MAX_DELTA_IDS as u32;
    let full = VisibleDelta {
        added: (0..max).collect(),
        removed: (max..2 * max).collect(),
        ..VisibleDelta::default()
    };
    assert!(full.fits());
    let frame = Frame::Delta(full);
    assert_eq!(frame.validate(), Ok(()));
    let bytes = frame.encode();
    assert_eq!(bytes.len(), 16 + 4 * (6 + 1 + 2 * MAX_DELTA_IDS));
    assert_eq!(
        &bytes[40..44],
        &[0xFF; 4],
        "both 16-bit counts at their maximum"
    );
    assert_eq!(Frame::decode(&bytes), Ok(frame));
}

#[test]
#[should_panic(expected = "at most 65535 ids per list")]
fn encoding_a_delta_that_does_not_fit_panics() {
    let (_, frame, _) = validate_cases().remove(0);
    let _ = frame.encode();
}

#[test]
fn every_variant_has_a_rejection_test() {
    let mut seen: BTreeSet<&str> = cases().iter().map(|(_, _, e)| variant(e)).collect();
    seen.extend(["LevelCount"]); // reject_levels.rs
    seen.extend(apply_cases().iter().map(|(_, _, _, e)| variant(e)));
    seen.extend(validate_cases().iter().map(|(_, _, e)| variant(e)));
    let all: BTreeSet<&str> = ALL_VARIANTS.into_iter().collect();
    assert_eq!(seen, all);
}

#[test]
fn error_codes_and_messages() {
    for (what, _, e) in cases() {
        let want = if matches!(e, FrameError::UnsupportedVersion { .. }) {
            ErrorCode::UnsupportedVersion
        } else {
            ErrorCode::MalformedFrame
        };
        assert_eq!(e.code(), want, "{what}");
    }
    let magic = FrameError::BadMagic { found: 0xDEAD_BEEF }.to_string();
    assert!(
        magic.contains("0xdeadbeef") && magic.contains("0x4c434d48"),
        "{magic}"
    );
    let version = FrameError::UnsupportedVersion {
        found: 7,
        supported: 1,
    }
    .to_string();
    assert!(version.contains('7') && version.contains('1'), "{version}");
    let long = FrameError::TooLong { len: 1 << 30 }.to_string();
    assert!(long.contains(&MAX_FRAME_BYTES.to_string()), "{long}");
    let short = FrameError::TooShort { len: 3 }.to_string();
    assert!(short.contains(&HEADER_BYTES.to_string()), "{short}");
    for code in ErrorCode::ALL {
        assert_eq!(ErrorCode::from_u32(code as u32), Some(code));
    }
    let names: Vec<_> = ErrorCode::ALL.iter().map(|c| c.name()).collect();
    assert_eq!(
        names,
        [
            "malformed_frame",
            "unsupported_version",
            "invalid_pose",
            "overloaded",
            "internal",
            "unknown_scene",
            "invalid_transform",
            "unauthorized"
        ]
    );
}
