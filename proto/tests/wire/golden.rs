//! Golden byte vectors of the binary frames, shared with the JavaScript client.
//!
//! Each frame built in [`goldens`] is stored as `tests/golden/<name>.hex` (one
//! little-endian `u32` word per line, its 4 bytes in wire order as 8 lowercase hex
//! digits) and described field by field in `tests/golden/frames.json`. The tests compare
//! against those files; they never rewrite them unless `HOMCULL_BLESS=1` is set:
//!
//! ```text
//! HOMCULL_BLESS=1 cargo test -p homcull-proto --test wire golden::
//! ```
//!
//! after which the diff of `tests/golden/` is the change to review (a changed vector is a
//! wire-protocol change: bump `PROTOCOL_VERSION` and update the JS client).

use std::collections::BTreeSet;
use std::path::PathBuf;
use std::sync::Once;

use homcull_proto::PROTOCOL_VERSION;
use homcull_proto::frame::{
    Frame, FrameStats, HEADER_WORDS, MAGIC, apply_delta, apply_delta_with_levels, diff_levels,
};
use serde_json::{Value, json};

fn golden_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

use crate::golden_frames::*;

/// What a delta golden applies to, and the visible set that results.
fn delta_base(name: &str) -> Option<(&'static str, Vec<u32>)> {
    match name {
        "delta" => Some(("full.hex", AFTER_DELTA.to_vec())),
        "delta_empty" => Some(("full_empty.hex", vec![])),
        "delta_lod" => Some(("full_lod.hex", AFTER_DELTA.to_vec())),
        _ => None,
    }
}

fn stats_json(s: &FrameStats) -> Value {
    json!({
        "candidates": s.candidates,
        "occluders_used": s.occluders_used,
        "dropped_poses": s.dropped_poses,
        "gpu_us": s.gpu_us,
        "total_us": s.total_us,
        "scene_version": s.scene_version,
    })
}

/// What a client derives from the stats, the Hello's object count and the visible set.
fn derived_json(s: &FrameStats, visible: usize) -> Value {
    json!({
        "objects": OBJECTS,
        "culled_by_frustum": s.culled_by_frustum(OBJECTS),
        "culled_by_occlusion": s.culled_by_occlusion(visible),
    })
}

/// The frame's fields as frames.json lists them.
fn frame_json(name: &str, frame: &Frame) -> Value {
    let bytes = frame.encode();
    let mut v = json!({
        "file": format!("{name}.hex"),
        "kind": frame.kind().name(),
        "kind_code": frame.kind() as u32,
        "seq": frame.seq(),
        "ack": frame.ack(),
        "payload_words": bytes.len() / 4 - HEADER_WORDS,
        "byte_length": bytes.len(),
    });
    let fields = match frame {
        Frame::Hello(h) => json!({
            "object_count": h.object_count,
            "info_json": h.info_json,
            "info_json_byte_length": h.info_json.len(),
        }),
        Frame::Pose(p) => {
            let mut v = json!({
                "want_full": p.want_full,
                "position": p.position,
                "rotation": p.rotation,
                "fov_y_deg": p.fov_y_deg,
                "viewport": p.viewport,
                "near": p.near,
                "far": p.far,
            });
            if let Some(s) = p.stereo {
                v["stereo"] = json!(s);
            }
            v
        }
        Frame::Full(f) => {
            let mut v = json!({
                "stats": stats_json(&f.stats),
                "derived": derived_json(&f.stats, f.ids.len()),
                "ids": f.ids,
            });
            if let Some(levels) = &f.levels {
                v["levels"] = json!(levels);
            }
            v
        }
        Frame::Delta(d) => {
            let (base, after) = delta_base(name).expect("every delta golden has a base");
            let mut v = json!({
                "stats": stats_json(&d.stats),
                "derived": derived_json(&d.stats, after.len()),
                "added": d.added,
                "removed": d.removed,
                "base": base,
                "visible_after": after,
            });
            if let Some(l) = &d.lod {
                v["added_levels"] = json!(l.added);
                v["changed"] = json!(l.changed);
                v["changed_levels"] = json!(l.changed_levels);
                v["levels_after"] = json!(LEVELS_AFTER_DELTA);
            }
            v
        }
        Frame::Error(e) => json!({
            "code": e.code as u32,
            "code_name": e.code.name(),
            "message": e.message,
            "message_byte_length": e.message.len(),
        }),
        Frame::Transforms(t) => json!({
            "horizon_ms": t.horizon_ms,
            "objects": t.objects.iter().map(|o| json!({
                "id": o.id,
                "matrix": o.matrix,
                "velocity": o.velocity,
                "angular_velocity": o.angular_velocity,
                "valid_ms": o.valid_ms,
            })).collect::<Vec<_>>(),
        }),
        Frame::Applied(a) => json!({
            "version": a.version,
            "applied": a.applied,
        }),
        Frame::Region(r) => json!({
            "centre": r.centre,
            "radius_m": r.radius_m,
            "axis": r.axis,
            "turn_deg": r.turn_deg,
        }),
    };
    let (Value::Object(map), Value::Object(extra)) = (&mut v, fields) else {
        unreachable!("both are objects");
    };
    map.extend(extra);
    v
}

fn frames_json() -> Value {
    json!({
        "protocol_version": PROTOCOL_VERSION,
        "magic": MAGIC,
        "frames": goldens().iter().map(|(name, f)| frame_json(name, f)).collect::<Vec<_>>(),
    })
}

fn to_hex(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(bytes.len() / 4 * 9);
    for word in bytes.chunks(4) {
        for b in word {
            s.push_str(&format!("{b:02x}"));
        }
        s.push('\n');
    }
    s
}

/// Parses the strict golden format: lines of exactly 8 lowercase hex digits.
fn from_hex(name: &str, text: &str) -> Vec<u8> {
    let mut bytes = Vec::new();
    for (i, line) in text.lines().enumerate() {
        assert!(
            line.len() == 8
                && line
                    .bytes()
                    .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b)),
            "{name}.hex line {}: `{line}` is not 8 lowercase hex digits",
            i + 1
        );
        for k in 0..4 {
            bytes.push(u8::from_str_radix(&line[2 * k..2 * k + 2], 16).unwrap());
        }
    }
    bytes
}

fn read(name: &str) -> String {
    let path = golden_dir().join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "cannot read {}: {e} (generate with HOMCULL_BLESS=1)",
            path.display()
        )
    })
}

/// Writes the golden files when `HOMCULL_BLESS=1`, once per test run.
fn bless() {
    static BLESS: Once = Once::new();
    BLESS.call_once(|| {
        if std::env::var("HOMCULL_BLESS").as_deref() != Ok("1") {
            return;
        }
        let dir = golden_dir();
        std::fs::create_dir_all(&dir).unwrap();
        for (name, frame) in goldens() {
            std::fs::write(dir.join(format!("{name}.hex")), to_hex(&frame.encode())).unwrap();
        }
        let mut json = serde_json::to_string_pretty(&frames_json()).unwrap();
        json.push('\n');
        std::fs::write(dir.join("frames.json"), json).unwrap();
    });
}

#[test]
fn encode_matches_golden_bytes() {
    bless();
    for (name, frame) in goldens() {
        let text = read(&format!("{name}.hex"));
        let bytes = from_hex(name, &text);
        let encoded = frame.encode();
        assert_eq!(
            to_hex(&encoded),
            text,
            "{name}: encode differs from {name}.hex (a wire change? see the module docs)"
        );
        assert_eq!(encoded, bytes, "{name}");
        assert_eq!(frame.encoded_len(), bytes.len(), "{name}");
        assert!(text.starts_with("484d434c\n"), "{name}: magic line");
        let version_kind = PROTOCOL_VERSION | ((frame.kind() as u32) << 16);
        assert_eq!(
            text.lines().nth(1),
            Some(to_hex(&version_kind.to_le_bytes()).trim_end()),
            "{name}: version and kind line"
        );
    }
}

#[test]
fn decode_of_golden_bytes_gives_the_frame() {
    bless();
    for (name, frame) in goldens() {
        let bytes = from_hex(name, &read(&format!("{name}.hex")));
        let decoded = Frame::decode(&bytes).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(decoded, frame, "{name}");
        assert_eq!(frame.validate(), Ok(()), "{name}");
    }
}

#[test]
fn frames_json_describes_the_goldens() {
    bless();
    let on_disk: Value = serde_json::from_str(&read("frames.json")).expect("frames.json parses");
    assert_eq!(on_disk, frames_json());
    // Every f32 listed must be exactly representable, so that the JS side can compare
    // Math.fround(x) === x and get the same bits as the .hex file.
    for (name, frame) in goldens() {
        if let Frame::Pose(p) = frame {
            let floats =
                p.position
                    .iter()
                    .chain(&p.rotation)
                    .chain([&p.fov_y_deg, &p.near, &p.far]);
            let stereo = p
                .stereo
                .iter()
                .flat_map(|s| [s.ipd_m, s.convergence_m.unwrap_or(0.0)])
                .collect::<Vec<_>>();
            for &x in floats.chain(&stereo) {
                let parsed: f64 = serde_json::to_string(&x).unwrap().parse().unwrap();
                assert_eq!(parsed, f64::from(x), "{name}: {x} does not print exactly");
            }
        }
    }
}

#[test]
fn the_levels_of_delta_lod_applied_to_full_lod_are_levels_after() {
    let (Frame::Full(full), Frame::Delta(delta)) = (
        Frame::decode(&from_hex("full_lod", &read("full_lod.hex"))).unwrap(),
        Frame::decode(&from_hex("delta_lod", &read("delta_lod.hex"))).unwrap(),
    ) else {
        panic!("full_lod.hex is a full frame and delta_lod.hex a delta");
    };
    let (mut set, mut levels) = (full.ids.clone(), full.levels.clone().unwrap());
    apply_delta_with_levels(&mut set, &mut levels, &delta).unwrap();
    assert_eq!(
        (&set[..], &levels[..]),
        (&AFTER_DELTA[..], &LEVELS_AFTER_DELTA[..])
    );
    // And the delta is what the sender computes from the two sets.
    let lod = diff_levels(&full.ids, full.levels.as_ref().unwrap(), &set, &levels);
    assert_eq!(Some(lod), delta.lod);
}

#[test]
fn golden_dir_holds_exactly_the_listed_files() {
    bless();
    let mut expected: BTreeSet<String> = goldens()
        .iter()
        .map(|(name, _)| format!("{name}.hex"))
        .collect();
    expected.insert("frames.json".into());
    expected.insert("README.md".into());
    let found: BTreeSet<String> = std::fs::read_dir(golden_dir())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert_eq!(found, expected);
    let readme = read("README.md");
    for (name, _) in goldens() {
        assert!(
            readme.contains(&format!("`{name}.hex`")),
            "README.md does not describe {name}.hex"
        );
    }
}

#[test]
fn golden_strings_need_padding() {
    // The string goldens exercise UTF-8 beyond ASCII and non-empty zero padding.
    for s in [HELLO_JSON, ERROR_MESSAGE] {
        assert!(!s.is_ascii(), "{s}");
        assert_ne!(s.len() % 4, 0, "{s}: {} bytes", s.len());
    }
}

#[test]
fn golden_deltas_apply_to_their_bases() {
    let frames = goldens();
    let find = |file: &str| {
        frames
            .iter()
            .find(|(name, _)| format!("{name}.hex") == file)
            .map(|(_, f)| f.clone())
            .unwrap()
    };
    for (name, frame) in &frames {
        let Frame::Delta(delta) = frame else { continue };
        let (base, after) = delta_base(name).unwrap();
        let Frame::Full(full) = find(base) else {
            panic!("{base} is not a full frame")
        };
        let mut set = full.ids.clone();
        apply_delta(&mut set, delta).unwrap();
        assert_eq!(set, after, "{name}");
    }
    let Frame::Full(full) = find("full.hex") else {
        panic!("full.hex is not a full frame")
    };
    assert_eq!(full.ids, FULL_IDS);
    // The derived stats of the session: what version 1 sent as words.
    assert_eq!(
        (full.culled_by_frustum(OBJECTS), full.culled_by_occlusion()),
        (1224, 4)
    );
    let Frame::Delta(delta) = find("delta.hex") else {
        panic!("delta.hex is not a delta frame")
    };
    assert_eq!(
        (
            delta.culled_by_frustum(OBJECTS),
            delta.culled_by_occlusion(AFTER_DELTA.len())
        ),
        (1225, 2)
    );
}
