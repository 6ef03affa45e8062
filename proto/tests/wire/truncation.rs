//! Truncated frames never decode, and `Frame::validate` refuses what decoding would.

use crate::common;

use common::{delta, frame, full, pose, text_payload};
use homcull_proto::frame::{Frame, FrameError, MAX_FRAME_BYTES, VisibleDelta, VisibleFull};

#[test]
fn truncations_of_valid_frames_are_rejected() {
    let valid = [
        full(&[1, 2, 3]),
        delta(&[1, 4], &[2]),
        pose(1),
        frame(1, 1, 0, &text_payload(3, "{\"é\":1}".as_bytes(), 0)),
        frame(5, 1, 0, &text_payload(4, b"overloaded", 0)),
    ];
    for f in valid {
        assert!(Frame::decode(&f).is_ok());
        for cut in 0..f.len() {
            assert!(Frame::decode(&f[..cut]).is_err(), "cut at {cut}");
        }
    }
}

#[test]
fn validate_catches_what_decode_rejects() {
    let bad_full = Frame::Full(VisibleFull {
        ids: vec![2, 1],
        ..VisibleFull::default()
    });
    assert!(matches!(
        Frame::decode(&bad_full.encode()),
        Err(FrameError::NotAscending { .. })
    ));
    assert_eq!(
        bad_full.validate(),
        Frame::decode(&bad_full.encode()).map(|_| ())
    );
    let bad_delta = Frame::Delta(VisibleDelta {
        added: vec![3],
        removed: vec![3],
        ..VisibleDelta::default()
    });
    assert_eq!(
        bad_delta.validate(),
        Err(FrameError::IdInBothLists { id: 3 })
    );
    assert_eq!(
        bad_delta.validate(),
        Frame::decode(&bad_delta.encode()).map(|_| ())
    );
    let huge = Frame::Full(VisibleFull {
        ids: (0..(MAX_FRAME_BYTES / 4) as u32).collect(),
        ..VisibleFull::default()
    });
    let len = huge.encoded_len();
    assert_eq!(huge.validate(), Err(FrameError::TooLong { len }));
    assert_eq!(
        Frame::decode(&huge.encode()),
        Err(FrameError::TooLong { len })
    );
}
