//! Writer frames (kinds 8 and 9) the decoder refuses, shared with `reject.rs`'s list of
//! every rejected input.

use homcull_proto::frame::motion::NO_VALUE;
use homcull_proto::frame::{FrameError, FrameKind};

use super::{frame, moved_objects};

/// Transforms and Applied frames that the decoder refuses.
pub fn transforms_cases() -> Vec<(&'static str, Vec<u8>, FrameError)> {
    use FrameError as E;
    vec![
        (
            "transforms with an ack",
            frame(8, 1, 4, &[NO_VALUE, 0]),
            E::NonZeroAck {
                kind: FrameKind::Transforms,
                ack: 4,
            },
        ),
        (
            "transforms without its count",
            frame(8, 1, 0, &[NO_VALUE]),
            E::PayloadSize {
                kind: FrameKind::Transforms,
                expected: 2,
                actual: 1,
            },
        ),
        (
            "transforms one object word short",
            frame(8, 1, 0, &[NO_VALUE, 1, 5, 0, 0, 0]),
            E::PayloadSize {
                kind: FrameKind::Transforms,
                expected: 22,
                actual: 6,
            },
        ),
        (
            "transforms ids not ascending",
            frame(8, 1, 0, &moved_objects(&[9, 3])),
            E::NotAscending {
                list: "transforms",
                index: 1,
                prev: 9,
                id: 3,
            },
        ),
        (
            "applied without its count",
            frame(9, 1, 2, &[3, 0]),
            E::PayloadSize {
                kind: FrameKind::Applied,
                expected: 3,
                actual: 2,
            },
        ),
    ]
}
