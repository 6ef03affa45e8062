//! Decodes arbitrary bytes: must never panic, and whatever decodes must re-encode to
//! exactly the input (the encoding is canonical).
#![no_main]

use homcull_proto::frame::Frame;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(frame) = Frame::decode(data) {
        assert_eq!(frame.encode(), data, "encode(decode(x)) != x for {frame:?}");
        assert_eq!(frame.validate(), Ok(()));
    }
});
