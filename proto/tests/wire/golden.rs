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

use homcull_proto::frame::{
    Applied, ErrorCode, ErrorFrame, Frame, FrameStats, HEADER_WORDS, Hello, LodChanges, MAGIC,
    MovedObject, PoseFrame, TransformsFrame, VisibleDelta, VisibleFull, apply_delta,
    apply_delta_with_levels, diff_levels,
};
use homcull_proto::{PROTOCOL_VERSION, Stereo};
use serde_json::{Value, json};

fn golden_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

const HELLO_JSON: &str = r#"{"scene":{"id":"demo","name":"Démo city","objects":1234}}"#;
const ERROR_MESSAGE: &str = "fov_y_deg must be in (0°, 180°), got 200";

/// The visible set after `full.hex`, then after `delta.hex` is applied to it.
const FULL_IDS: [u32; 6] = [3, 17, 256, 1000, 1001, 1233];
const AFTER_DELTA: [u32; 7] = [3, 5, 17, 256, 700, 1000, 1001];
/// The levels of `full_lod.hex`, then of the set after `delta_lod.hex`.
const FULL_LEVELS: [u8; 6] = [0, 1, 1, 4, 2, 3];
const LEVELS_AFTER_DELTA: [u8; 7] = [0, 3, 2, 1, 0, 4, 8];

/// The golden frames, in file order.
fn goldens() -> Vec<(&'static str, Frame)> {
    vec![
        (
            "hello",
            Frame::Hello(Hello {
                seq: 1,
                object_count: OBJECTS,
                info_json: HELLO_JSON.to_owned(),
            }),
        ),
        (
            "pose",
            Frame::Pose(PoseFrame {
                seq: 42,
                want_full: true,
                position: [1.5, -2.0, 0.25],
                rotation: [0.5, -0.5, 0.5, 0.5],
                fov_y_deg: 60.0,
                viewport: [960, 540],
                near: 0.125,
                far: 5000.0,
                stereo: None,
            }),
        ),
        (
            "pose_stereo",
            Frame::Pose(PoseFrame {
                seq: 49,
                want_full: false,
                position: [1.5, -2.0, 0.25],
                rotation: [0.5, -0.5, 0.5, 0.5],
                fov_y_deg: 90.0,
                viewport: [1280, 720],
                near: 0.125,
                far: 5000.0,
                stereo: Some(Stereo {
                    ipd_m: 0.0625,
                    convergence_m: Some(2.5),
                }),
            }),
        ),
        (
            "full",
            Frame::Full(VisibleFull {
                seq: 2,
                ack: 42,
                stats: FrameStats {
                    candidates: 10,
                    occluders_used: 2,
                    dropped_poses: 1,
                    gpu_us: 850,
                    total_us: 1200,
                    scene_version: 7,
                },
                ids: FULL_IDS.to_vec(),
                levels: None,
            }),
        ),
        (
            "delta",
            Frame::Delta(VisibleDelta {
                seq: 3,
                ack: 43,
                stats: FrameStats {
                    candidates: 9,
                    occluders_used: 2,
                    dropped_poses: 0,
                    gpu_us: 790,
                    total_us: 1100,
                    scene_version: 7,
                },
                added: vec![5, 700],
                removed: vec![1233],
                lod: None,
            }),
        ),
        (
            "full_empty",
            Frame::Full(VisibleFull {
                seq: 4,
                ack: 44,
                stats: FrameStats {
                    candidates: 0,
                    occluders_used: 0,
                    dropped_poses: 0,
                    gpu_us: 0,
                    total_us: 35,
                    scene_version: 7,
                },
                ids: vec![],
                levels: None,
            }),
        ),
        (
            "delta_empty",
            Frame::Delta(VisibleDelta {
                seq: 5,
                ack: 45,
                stats: FrameStats {
                    candidates: 0,
                    occluders_used: 0,
                    dropped_poses: 3,
                    gpu_us: 0,
                    total_us: 40,
                    scene_version: 7,
                },
                added: vec![],
                removed: vec![],
                lod: None,
            }),
        ),
        (
            "full_lod",
            Frame::Full(VisibleFull {
                seq: 7,
                ack: 47,
                stats: FrameStats {
                    candidates: 10,
                    occluders_used: 2,
                    dropped_poses: 0,
                    gpu_us: 850,
                    total_us: 1200,
                    scene_version: 7,
                },
                ids: FULL_IDS.to_vec(),
                levels: Some(FULL_LEVELS.to_vec()),
            }),
        ),
        (
            "delta_lod",
            Frame::Delta(VisibleDelta {
                seq: 8,
                ack: 48,
                stats: FrameStats {
                    candidates: 9,
                    occluders_used: 2,
                    dropped_poses: 0,
                    gpu_us: 790,
                    total_us: 1100,
                    scene_version: 7,
                },
                added: vec![5, 700],
                removed: vec![1233],
                lod: Some(LodChanges {
                    added: vec![3, 0],
                    changed: vec![17, 1001],
                    changed_levels: vec![2, 8],
                }),
            }),
        ),
        (
            "error",
            Frame::Error(ErrorFrame {
                seq: 6,
                ack: 46,
                code: ErrorCode::InvalidPose,
                message: ERROR_MESSAGE.to_owned(),
            }),
        ),
        (
            "transforms",
            Frame::Transforms(TransformsFrame {
                seq: 12,
                horizon_ms: Some(100.0),
                objects: vec![
                    MovedObject {
                        id: 5,
                        // A quarter turn about +Y, then 2 m along +X and 0.5 m up.
                        matrix: [0.0, 0.0, -1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 2.0, 0.5, 0.0],
                        velocity: [1.5, 0.0, -0.25],
                        angular_velocity: [0.0, 0.5, 0.0],
                        valid_ms: Some(50.0),
                    },
                    MovedObject {
                        id: 700,
                        matrix: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
                        velocity: [0.0; 3],
                        angular_velocity: [0.0; 3],
                        valid_ms: None,
                    },
                ],
            }),
        ),
        (
            "transforms_keep_horizon",
            Frame::Transforms(TransformsFrame {
                seq: 13,
                horizon_ms: None,
                objects: vec![],
            }),
        ),
        (
            "applied",
            Frame::Applied(Applied {
                seq: 7,
                ack: 12,
                version: (1 << 32) + 3,
                applied: 2,
            }),
        ),
    ]
}

/// Objects in the scene of the golden session (the Hello's `object_count`).
const OBJECTS: u32 = 1234;

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
