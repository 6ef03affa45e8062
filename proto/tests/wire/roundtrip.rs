//! Property tests of the frame codec: encode → decode round trips for every kind, decode
//! never panics on arbitrary or mutated input (and whatever it accepts re-encodes to the
//! same bytes), and `diff`/`apply_delta` agree.

use homcull_proto::frame::motion::NO_VALUE;
use homcull_proto::frame::{
    Applied, ErrorCode, ErrorFrame, Frame, FrameStats, HEADER_WORDS, Hello, LodChanges, MAGIC,
    MAX_LEVEL, MovedObject, PoseFrame, TransformsFrame, VisibleDelta, VisibleFull, apply_delta,
    apply_delta_with_levels, diff, diff_levels,
};
use homcull_proto::{PROTOCOL_VERSION, Pose, Stereo};
use proptest::collection::{btree_map, btree_set, vec};
use proptest::prelude::*;
use proptest::test_runner::FileFailurePersistence;

/// Any f32 bit pattern: NaNs with payloads, infinities, subnormals, −0.
fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        any::<u32>().prop_map(f32::from_bits),
        Just(f32::NAN),
        Just(-0.0f32),
        Just(f32::INFINITY),
        Just(f32::from_bits(0x7F80_0001)), // signalling NaN
        any::<f32>(),
    ]
}

fn stats() -> impl Strategy<Value = FrameStats> {
    any::<[u32; 6]>().prop_map(|w| FrameStats {
        candidates: w[0],
        occluders_used: w[1],
        dropped_poses: w[2],
        gpu_us: w[3],
        total_us: w[4],
        scene_version: w[5],
    })
}

/// Strictly ascending IDs, from a small range (dense sets) or the whole u32 range.
fn ids() -> impl Strategy<Value = Vec<u32>> {
    prop_oneof![btree_set(0u32..512, 0..200), btree_set(any::<u32>(), 0..64),]
        .prop_map(|s| s.into_iter().collect())
}

fn text() -> impl Strategy<Value = String> {
    prop_oneof![any::<String>(), "[a-z{}\":,é°]{0,9}".prop_map(String::from)]
}

fn hello() -> impl Strategy<Value = Frame> {
    (any::<u32>(), any::<u32>(), text()).prop_map(|(seq, object_count, info_json)| {
        Frame::Hello(Hello {
            seq,
            object_count,
            info_json,
        })
    })
}

fn pose() -> impl Strategy<Value = Frame> {
    (
        any::<u32>(),
        any::<bool>(),
        [any_f32(), any_f32(), any_f32()],
        [any_f32(), any_f32(), any_f32(), any_f32()],
        any_f32(),
        any::<[u32; 2]>(),
        any_f32(),
        any_f32(),
        // A stereo pose: ipd and convergence (the word 0 means none, so +0.0 is never one).
        proptest::option::of((
            any_f32(),
            proptest::option::of(any_f32().prop_filter("0 is none", |c| c.to_bits() != 0)),
        )),
    )
        .prop_map(
            |(seq, want_full, position, rotation, fov_y_deg, viewport, near, far, stereo)| {
                Frame::Pose(PoseFrame {
                    seq,
                    want_full,
                    position,
                    rotation,
                    fov_y_deg,
                    viewport,
                    near,
                    far,
                    stereo: stereo.map(|(ipd_m, convergence_m)| Stereo {
                        ipd_m,
                        convergence_m,
                    }),
                })
            },
        )
}

fn full() -> impl Strategy<Value = Frame> {
    let levels = proptest::collection::vec(0..=MAX_LEVEL, 0..200);
    (
        any::<u32>(),
        any::<u32>(),
        stats(),
        ids(),
        any::<bool>(),
        levels,
    )
        .prop_map(|(seq, ack, stats, ids, with_levels, mut levels)| {
            levels.resize(ids.len(), 1);
            Frame::Full(VisibleFull {
                seq,
                ack,
                stats,
                ids,
                levels: with_levels.then_some(levels),
            })
        })
}

fn delta() -> impl Strategy<Value = Frame> {
    // Each ID: 0 added, 1 removed, 2 kept with a changed level (with levels only);
    // and the level it gets.
    let lists = prop_oneof![
        btree_map(0u32..256, (0u8..3, 0..=MAX_LEVEL), 0..150),
        btree_map(any::<u32>(), (0u8..3, 0..=MAX_LEVEL), 0..64),
    ];
    (any::<u32>(), any::<u32>(), stats(), lists, any::<bool>()).prop_map(
        |(seq, ack, stats, lists, with_levels)| {
            let mut d = VisibleDelta {
                seq,
                ack,
                stats,
                ..VisibleDelta::default()
            };
            let mut lod = LodChanges::default();
            for (id, (what, level)) in lists {
                match what {
                    0 => {
                        d.added.push(id);
                        lod.added.push(level);
                    }
                    1 => d.removed.push(id),
                    _ if with_levels => {
                        lod.changed.push(id);
                        lod.changed_levels.push(level);
                    }
                    _ => {}
                }
            }
            d.lod = with_levels.then_some(lod);
            Frame::Delta(d)
        },
    )
}

fn error() -> impl Strategy<Value = Frame> {
    (
        any::<u32>(),
        any::<u32>(),
        proptest::sample::select(ErrorCode::ALL.to_vec()),
        text(),
    )
        .prop_map(|(seq, ack, code, message)| {
            Frame::Error(ErrorFrame {
                seq,
                ack,
                code,
                message,
            })
        })
}

/// An optional f32: any bits but the word that means "absent".
fn optional_f32() -> impl Strategy<Value = Option<f32>> {
    proptest::option::of(any_f32().prop_filter("not the absent word", |x| x.to_bits() != NO_VALUE))
}

fn transforms() -> impl Strategy<Value = Frame> {
    let object = (
        vec(any_f32(), 12),
        [any_f32(), any_f32(), any_f32()],
        [any_f32(), any_f32(), any_f32()],
        optional_f32(),
    );
    (any::<u32>(), optional_f32(), ids(), vec(object, 64)).prop_map(
        |(seq, horizon_ms, ids, objects)| {
            let objects = ids
                .into_iter()
                .zip(objects)
                .map(
                    |(id, (m, velocity, angular_velocity, valid_ms))| MovedObject {
                        id,
                        matrix: m.try_into().unwrap(),
                        velocity,
                        angular_velocity,
                        valid_ms,
                    },
                )
                .collect();
            Frame::Transforms(TransformsFrame {
                seq,
                horizon_ms,
                objects,
            })
        },
    )
}

fn applied() -> impl Strategy<Value = Frame> {
    any::<(u32, u32, u64, u32)>().prop_map(|(seq, ack, version, applied)| {
        Frame::Applied(Applied {
            seq,
            ack,
            version,
            applied,
        })
    })
}

fn any_frame() -> impl Strategy<Value = Frame> {
    prop_oneof![
        hello(),
        pose(),
        full(),
        delta(),
        error(),
        transforms(),
        applied()
    ]
}

/// The pose's fields with floats as bits, so NaN compares equal to itself.
type PoseBits = (u32, bool, Vec<u32>, [u32; 2], Option<(u32, Option<u32>)>);

fn pose_bits(p: &PoseFrame) -> PoseBits {
    let floats = p
        .position
        .iter()
        .chain(&p.rotation)
        .chain([&p.fov_y_deg, &p.near, &p.far])
        .map(|x| x.to_bits())
        .collect();
    let stereo = p
        .stereo
        .map(|s| (s.ipd_m.to_bits(), s.convergence_m.map(f32::to_bits)));
    (p.seq, p.want_full, floats, p.viewport, stereo)
}

/// Equality with floats compared bit for bit.
fn same(a: &Frame, b: &Frame) -> bool {
    match (a, b) {
        (Frame::Pose(x), Frame::Pose(y)) => pose_bits(x) == pose_bits(y),
        (Frame::Transforms(_), Frame::Transforms(_)) => a.encode() == b.encode(),
        _ => a == b,
    }
}

/// Decodes `bytes`; whatever is accepted must re-encode to exactly `bytes`.
fn decode_is_canonical(bytes: &[u8]) -> Result<(), TestCaseError> {
    if let Ok(frame) = Frame::decode(bytes) {
        prop_assert_eq!(frame.encode(), bytes.to_vec());
        prop_assert_eq!(frame.validate(), Ok(()));
    }
    Ok(())
}

/// One edit of a valid frame.
#[derive(Debug, Clone)]
enum Mutation {
    /// XOR a byte (index modulo the length) with a non-zero mask.
    Flip(usize, u8),
    /// Overwrite a word with a small value (counts, kinds, lengths).
    SetWord(usize, u32),
    /// Cut the frame to a length (modulo the length).
    Truncate(usize),
    /// Append bytes.
    Append(Vec<u8>),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 1u8..=255).prop_map(|(i, m)| Mutation::Flip(i, m)),
        (any::<usize>(), prop_oneof![0u32..16, any::<u32>()])
            .prop_map(|(i, w)| Mutation::SetWord(i, w)),
        any::<usize>().prop_map(Mutation::Truncate),
        vec(any::<u8>(), 1..9).prop_map(Mutation::Append),
    ]
}

fn mutate(bytes: &mut Vec<u8>, m: &Mutation) {
    let len = bytes.len();
    match m {
        Mutation::Flip(i, mask) if len > 0 => bytes[i % len] ^= mask,
        Mutation::SetWord(i, w) if len >= 4 => {
            let at = i % (len / 4) * 4;
            bytes[at..at + 4].copy_from_slice(&w.to_le_bytes());
        }
        Mutation::Truncate(n) => bytes.truncate(n % (len + 1)),
        Mutation::Append(extra) => bytes.extend_from_slice(extra),
        // Too short to flip or set a word in.
        Mutation::Flip(..) | Mutation::SetWord(..) => {}
    }
}

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: 1024,
        // Relative to proto/, where cargo runs the tests (the default, next to the source
        // file, cannot find it from a workspace member).
        failure_persistence: Some(Box::new(FileFailurePersistence::Direct(
            "tests/wire/roundtrip.proptest-regressions",
        ))),
        ..ProptestConfig::default()
    }
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn encode_decode_round_trips(frame in any_frame()) {
        let bytes = frame.encode();
        prop_assert_eq!(bytes.len(), frame.encoded_len());
        prop_assert_eq!(bytes.len() % 4, 0);
        prop_assert_eq!(&bytes[..4], &MAGIC.to_le_bytes());
        prop_assert_eq!(frame.validate(), Ok(()));
        let decoded = Frame::decode(&bytes).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert!(same(&decoded, &frame), "{:?} != {:?}", decoded, frame);
        prop_assert_eq!(decoded.kind(), frame.kind());
        prop_assert_eq!(decoded.encode(), bytes);
    }

    #[test]
    fn decode_of_arbitrary_bytes_never_panics(bytes in vec(any::<u8>(), 0..256)) {
        decode_is_canonical(&bytes)?;
    }

    /// Arbitrary payloads behind a correct header, so the payload parsers get exercised
    /// rather than the magic check.
    #[test]
    fn decode_of_arbitrary_payloads_never_panics(
        kind in 0u32..7,
        seq in any::<u32>(),
        ack in prop_oneof![Just(0u32), any::<u32>()],
        payload in vec(
            prop_oneof![
                0u32..12,
                // A delta's counts word: small counts in both 16-bit halves.
                (0u32..8, 0u32..8).prop_map(|(added, removed)| added | (removed << 16)),
                any::<u32>(),
            ],
            0..40,
        ),
    ) {
        let mut w = vec![MAGIC, PROTOCOL_VERSION | (kind << 16), seq, ack];
        w.extend(payload);
        let bytes: Vec<u8> = w.iter().flat_map(|x| x.to_le_bytes()).collect();
        decode_is_canonical(&bytes)?;
    }

    #[test]
    fn decode_of_mutated_frames_never_panics(
        frame in any_frame(),
        mutations in vec(mutation(), 1..4),
    ) {
        let mut bytes = frame.encode();
        for m in &mutations {
            mutate(&mut bytes, m);
        }
        decode_is_canonical(&bytes)?;
        // Decoding is canonical, so bytes that changed cannot decode to the same frame.
        if bytes != frame.encode() {
            if let Ok(other) = Frame::decode(&bytes) {
                prop_assert!(!same(&other, &frame));
            }
        }
    }

    #[test]
    fn levels_of_a_diff_applied_give_the_new_levels(
        old in btree_map(0u32..96, 0..=MAX_LEVEL, 0..64),
        new in btree_map(0u32..96, 0..=MAX_LEVEL, 0..64),
    ) {
        let (old_ids, old_levels): (Vec<u32>, Vec<u8>) = old.into_iter().unzip();
        let (new_ids, new_levels): (Vec<u32>, Vec<u8>) = new.into_iter().unzip();
        let (added, removed) = diff(&old_ids, &new_ids);
        let lod = diff_levels(&old_ids, &old_levels, &new_ids, &new_levels);
        let delta = VisibleDelta { added, removed, lod: Some(lod), ..VisibleDelta::default() };
        let frame = Frame::Delta(delta.clone());
        prop_assert_eq!(frame.validate(), Ok(()));
        prop_assert_eq!(Frame::decode(&frame.encode()), Ok(frame));
        let (mut set, mut levels) = (old_ids, old_levels);
        apply_delta_with_levels(&mut set, &mut levels, &delta)
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert_eq!((set, levels), (new_ids, new_levels));
    }

    #[test]
    fn apply_delta_of_diff_gives_new(
        old in btree_set(0u32..96, 0..64),
        new in btree_set(0u32..96, 0..64),
    ) {
        let old: Vec<u32> = old.into_iter().collect();
        let new: Vec<u32> = new.into_iter().collect();
        let (added, removed) = diff(&old, &new);
        let delta = VisibleDelta { added, removed, ..VisibleDelta::default() };
        // The diff is a valid delta frame...
        let frame = Frame::Delta(delta.clone());
        prop_assert_eq!(frame.validate(), Ok(()));
        prop_assert_eq!(Frame::decode(&frame.encode()), Ok(frame));
        // ...that turns old into new, and only changes what changed.
        let mut set = old.clone();
        apply_delta(&mut set, &delta).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert_eq!(&set, &new);
        for id in &delta.added {
            prop_assert!(!old.contains(id) && new.contains(id));
        }
        for id in &delta.removed {
            prop_assert!(old.contains(id) && !new.contains(id));
        }
        // The reverse diff undoes it.
        let (back_added, back_removed) = diff(&new, &old);
        prop_assert_eq!(&back_added, &delta.removed);
        prop_assert_eq!(&back_removed, &delta.added);
    }

    #[test]
    fn pose_conversions_round_trip(frame in pose(), want_full in any::<bool>(), seq in any::<u32>()) {
        let Frame::Pose(p) = frame else { unreachable!() };
        let pose: Pose = p.to_pose();
        prop_assert!(pose.rotation.is_some() && pose.look_at.is_none() && pose.up.is_none());
        let back = PoseFrame::from_pose(seq, want_full, &pose).expect("rotation pose converts");
        prop_assert_eq!(
            pose_bits(&back),
            pose_bits(&PoseFrame { seq, want_full, ..p })
        );
    }
}

#[test]
fn pose_from_look_at_is_none() {
    let pose = Pose::looking_at([0.0, 1.0, 2.0], [0.0, 0.0, 0.0]);
    assert_eq!(PoseFrame::from_pose(1, false, &pose), None);
    let with_up = Pose {
        rotation: Some([0.0, 0.0, 0.0, 1.0]),
        look_at: None,
        up: Some([0.0, 1.0, 0.0]),
        ..pose.clone()
    };
    assert_eq!(PoseFrame::from_pose(1, false, &with_up), None);
    let neither = Pose {
        look_at: None,
        ..pose
    };
    let p = PoseFrame::from_pose(3, true, &neither).unwrap();
    assert_eq!(p.rotation, [0.0, 0.0, 0.0, 1.0]);
    assert_eq!((p.seq, p.want_full), (3, true));
    assert_eq!(HEADER_WORDS, 4);
}
