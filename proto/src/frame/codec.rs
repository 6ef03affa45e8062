//! Encoding, decoding and validation of frames: little-endian words, checked lengths,
//! no panics and no allocation beyond what the input justifies.

use super::words::{Reader, Writer, fill_words, len_u32};
use super::*;
use crate::PROTOCOL_VERSION;

impl Frame {
    /// What this frame is.
    pub fn kind(&self) -> FrameKind {
        match self {
            Frame::Hello(_) => FrameKind::Hello,
            Frame::Pose(_) => FrameKind::Pose,
            Frame::Full(f) if f.levels.is_some() => FrameKind::FullLod,
            Frame::Full(_) => FrameKind::Full,
            Frame::Delta(d) if d.lod.is_some() => FrameKind::DeltaLod,
            Frame::Delta(_) => FrameKind::Delta,
            Frame::Error(_) => FrameKind::Error,
            Frame::Transforms(_) => FrameKind::Transforms,
            Frame::Applied(_) => FrameKind::Applied,
            Frame::Region(_) => FrameKind::Region,
        }
    }

    /// Header word 2: the sender's sequence number.
    pub fn seq(&self) -> u32 {
        match self {
            Frame::Hello(f) => f.seq,
            Frame::Pose(f) => f.seq,
            Frame::Full(f) => f.seq,
            Frame::Delta(f) => f.seq,
            Frame::Error(f) => f.seq,
            Frame::Transforms(f) => f.seq,
            Frame::Applied(f) => f.seq,
            Frame::Region(f) => f.seq,
        }
    }

    /// Header word 3: the pose (or update) sequence number answered (always 0 for
    /// Hello, Pose and Transforms).
    pub fn ack(&self) -> u32 {
        match self {
            Frame::Hello(_) | Frame::Pose(_) | Frame::Transforms(_) => 0,
            Frame::Applied(f) => f.ack,
            Frame::Region(f) => f.ack,
            Frame::Full(f) => f.ack,
            Frame::Delta(f) => f.ack,
            Frame::Error(f) => f.ack,
        }
    }

    /// Words after the header.
    fn payload_words(&self) -> usize {
        match self {
            Frame::Hello(h) => 2 + h.info_json.len().div_ceil(4),
            Frame::Pose(p) => POSE_PAYLOAD_WORDS + p.stereo.map_or(0, |_| STEREO_WORDS),
            Frame::Full(f) => {
                let levels = f.levels.as_ref().map_or(0, |l| l.len().div_ceil(4));
                STATS_WORDS + 1 + f.ids.len() + levels
            }
            Frame::Delta(d) => {
                let ids = d.added.len() + d.removed.len();
                match &d.lod {
                    None => STATS_WORDS + 1 + ids,
                    Some(l) => {
                        let levels = (l.added.len() + l.changed_levels.len()).div_ceil(4);
                        STATS_WORDS + 2 + ids + l.changed.len() + levels
                    }
                }
            }
            Frame::Error(e) => 2 + e.message.len().div_ceil(4),
            Frame::Transforms(t) => t.payload_words(),
            Frame::Applied(_) => Applied::PAYLOAD_WORDS,
            Frame::Region(_) => RegionFrame::PAYLOAD_WORDS,
        }
    }

    /// Length in bytes of [`Frame::encode`]'s output.
    pub fn encoded_len(&self) -> usize {
        (HEADER_WORDS + self.payload_words()) * 4
    }

    /// Checks what [`Frame::encode`] does not: that the ID lists are strictly ascending
    /// (and disjoint, for a delta), a delta's lists fit ([`VisibleDelta::fits`]) and the
    /// frame fits in [`MAX_FRAME_BYTES`]. A frame that passes encodes to bytes that
    /// [`Frame::decode`] accepts and decodes to an equal frame.
    pub fn validate(&self) -> Result<(), FrameError> {
        if let Frame::Delta(d) = self {
            if !d.fits() {
                return Err(FrameError::DeltaTooLarge {
                    added: d.added.len(),
                    removed: d.removed.len(),
                });
            }
        }
        let len = self.encoded_len();
        if len > MAX_FRAME_BYTES {
            return Err(FrameError::TooLong { len });
        }
        match self {
            Frame::Full(f) => {
                if let Some(levels) = &f.levels {
                    check_levels(f.ids.len(), levels)?;
                }
                check_ascending("full", &f.ids)
            }
            Frame::Delta(d) => {
                if let Some(l) = &d.lod {
                    check_levels(d.added.len(), &l.added)?;
                    check_levels(l.changed.len(), &l.changed_levels)?;
                }
                check_ascending("added", &d.added)?;
                check_ascending("removed", &d.removed)?;
                check_disjoint(&d.added, &d.removed)?;
                match &d.lod {
                    Some(l) => {
                        check_ascending("changed", &l.changed)?;
                        check_changed(&l.changed, &d.added, &d.removed)
                    }
                    None => Ok(()),
                }
            }
            Frame::Transforms(t) => t.validate(),
            Frame::Hello(_)
            | Frame::Pose(_)
            | Frame::Error(_)
            | Frame::Applied(_)
            | Frame::Region(_) => Ok(()),
        }
    }

    /// The frame's bytes.
    ///
    /// Writes the fields as they are: ID lists that are not strictly ascending produce a
    /// frame that [`Frame::decode`] rejects (see [`Frame::validate`]).
    ///
    /// # Panics
    ///
    /// If a delta does not [fit](VisibleDelta::fits) (more than [`MAX_DELTA_IDS`] IDs in a
    /// list), levels of detail are not one per ID they describe, or a string or ID list
    /// has more than `u32::MAX` elements (the frame could not describe it, and would be
    /// far beyond [`MAX_FRAME_BYTES`] anyway).
    pub fn encode(&self) -> Vec<u8> {
        let mut w = Writer(Vec::with_capacity(self.encoded_len()));
        w.word(MAGIC);
        w.word(PROTOCOL_VERSION | ((self.kind() as u32) << 16));
        w.word(self.seq());
        w.word(self.ack());
        match self {
            Frame::Hello(h) => {
                w.word(h.object_count);
                w.text(&h.info_json);
            }
            Frame::Pose(p) => {
                let want_full = if p.want_full { POSE_FLAG_WANT_FULL } else { 0 };
                let stereo = if p.stereo.is_some() {
                    POSE_FLAG_STEREO
                } else {
                    0
                };
                w.word(want_full | stereo);
                for v in p
                    .position
                    .into_iter()
                    .chain(p.rotation)
                    .chain([p.fov_y_deg])
                {
                    w.f32(v);
                }
                w.word(p.viewport[0]);
                w.word(p.viewport[1]);
                w.f32(p.near);
                w.f32(p.far);
                if let Some(s) = p.stereo {
                    w.f32(s.ipd_m);
                    w.f32(s.convergence_m.unwrap_or(0.0));
                }
            }
            Frame::Full(f) => {
                w.words(&f.stats.to_words());
                w.word(len_u32(f.ids.len()));
                w.words(&f.ids);
                if let Some(levels) = &f.levels {
                    assert_eq!(levels.len(), f.ids.len(), "one level per visible id");
                    w.bytes(levels);
                }
            }
            Frame::Delta(d) => {
                assert!(
                    d.fits(),
                    "a delta frame carries at most {MAX_DELTA_IDS} ids per list, got {} added and {} removed: send a full frame",
                    d.added.len(),
                    d.removed.len()
                );
                w.words(&d.stats.to_words());
                // Both fit in 16 bits (checked above).
                w.word(len_u32(d.added.len()) | (len_u32(d.removed.len()) << 16));
                if let Some(l) = &d.lod {
                    w.word(len_u32(l.changed.len()));
                }
                w.words(&d.added);
                w.words(&d.removed);
                if let Some(l) = &d.lod {
                    assert_eq!(l.added.len(), d.added.len(), "one level per added id");
                    assert_eq!(
                        l.changed_levels.len(),
                        l.changed.len(),
                        "one level per changed id"
                    );
                    w.words(&l.changed);
                    w.bytes(&[&l.added[..], &l.changed_levels[..]].concat());
                }
            }
            Frame::Error(e) => {
                w.word(e.code as u32);
                w.text(&e.message);
            }
            Frame::Transforms(t) => t.write(&mut w),
            Frame::Applied(a) => a.write(&mut w),
            Frame::Region(r) => r.write(&mut w),
        }
        debug_assert_eq!(w.0.len(), self.encoded_len());
        w.0
    }

    /// Parses one frame. Never panics; see the [module docs](self) for what is checked.
    pub fn decode(bytes: &[u8]) -> Result<Frame, FrameError> {
        let len = bytes.len();
        if len > MAX_FRAME_BYTES {
            return Err(FrameError::TooLong { len });
        }
        let Some((header, payload)) = bytes.split_at_checked(HEADER_BYTES) else {
            return Err(FrameError::TooShort { len });
        };
        if !len.is_multiple_of(4) {
            return Err(FrameError::NotWordAligned { len });
        }
        let mut h = [0u32; HEADER_WORDS];
        fill_words(&mut h, header);
        let [magic, version_kind, seq, ack] = h;
        if magic != MAGIC {
            return Err(FrameError::BadMagic { found: magic });
        }
        let (version, kind) = (version_kind & 0xFFFF, version_kind >> 16);
        if version != PROTOCOL_VERSION {
            return Err(FrameError::UnsupportedVersion {
                found: version,
                supported: PROTOCOL_VERSION,
            });
        }
        let kind = FrameKind::from_u32(kind).ok_or(FrameError::UnknownKind { kind })?;
        if matches!(
            kind,
            FrameKind::Hello | FrameKind::Pose | FrameKind::Transforms
        ) && ack != 0
        {
            return Err(FrameError::NonZeroAck { kind, ack });
        }
        let mut p = Reader {
            kind,
            rest: payload,
            words: payload.len() / 4,
        };
        Ok(match kind {
            FrameKind::Hello => {
                let [object_count, byte_len] = p.fixed()?;
                let info_json = p.text("hello JSON", byte_len)?;
                Frame::Hello(Hello {
                    seq,
                    object_count,
                    info_json,
                })
            }
            FrameKind::Pose => {
                let w: [u32; POSE_PAYLOAD_WORDS] = p.fixed()?;
                let stereo = if w[0] & POSE_FLAG_STEREO != 0 {
                    let [ipd, convergence] = p.fixed()?;
                    Some(Stereo {
                        ipd_m: f32::from_bits(ipd),
                        // The word 0 is "none"; any other bits are the server's to judge.
                        convergence_m: (convergence != 0).then(|| f32::from_bits(convergence)),
                    })
                } else {
                    None
                };
                p.tail(0)?;
                let [
                    flags,
                    px,
                    py,
                    pz,
                    qx,
                    qy,
                    qz,
                    qw,
                    fov,
                    width,
                    height,
                    near,
                    far,
                ] = w;
                if flags & !(POSE_FLAG_WANT_FULL | POSE_FLAG_STEREO) != 0 {
                    return Err(FrameError::BadFlags { flags });
                }
                let f = f32::from_bits;
                Frame::Pose(PoseFrame {
                    seq,
                    want_full: flags & POSE_FLAG_WANT_FULL != 0,
                    position: [f(px), f(py), f(pz)],
                    rotation: [f(qx), f(qy), f(qz), f(qw)],
                    fov_y_deg: f(fov),
                    viewport: [width, height],
                    near: f(near),
                    far: f(far),
                    stereo,
                })
            }
            FrameKind::Full | FrameKind::FullLod => {
                let stats = FrameStats::from_words(p.fixed()?);
                let [count] = p.fixed()?;
                let lod = kind == FrameKind::FullLod;
                let count = u64::from(count);
                let level_words = if lod { count.div_ceil(4) } else { 0 };
                let tail = p.tail(count + level_words)?;
                // `tail` holds exactly count + level_words words, so this fits.
                let (ids, levels) = tail.split_at(tail.len() - level_words as usize * 4);
                let ids = decode_ids("full", ids)?;
                let levels = lod.then(|| decode_levels(levels, ids.len())).transpose()?;
                Frame::Full(VisibleFull {
                    seq,
                    ack,
                    stats,
                    ids,
                    levels,
                })
            }
            FrameKind::Delta | FrameKind::DeltaLod => {
                let stats = FrameStats::from_words(p.fixed()?);
                let [counts] = p.fixed()?;
                let lod = kind == FrameKind::DeltaLod;
                let changed_count = if lod {
                    u64::from(p.fixed::<1>()?[0])
                } else {
                    0
                };
                // Each count fits in 16 bits but `changed_count`: every sum is in u64.
                let (added_count, removed_count) =
                    (u64::from(counts & 0xFFFF), u64::from(counts >> 16));
                let level_words = if lod {
                    (added_count + changed_count).div_ceil(4)
                } else {
                    0
                };
                let ids = added_count + removed_count + changed_count;
                let tail = p.tail(ids + level_words)?;
                // `tail` holds exactly that many words, so every split below fits.
                let (added, rest) = tail.split_at(added_count as usize * 4);
                let (removed, rest) = rest.split_at(removed_count as usize * 4);
                let (changed, levels) = rest.split_at(changed_count as usize * 4);
                let added = decode_ids("added", added)?;
                let removed = decode_ids("removed", removed)?;
                check_disjoint(&added, &removed)?;
                let lod = if lod {
                    let changed = decode_ids("changed", changed)?;
                    check_changed(&changed, &added, &removed)?;
                    let mut levels = decode_levels(levels, added.len() + changed.len())?;
                    let changed_levels = levels.split_off(added.len());
                    Some(LodChanges {
                        added: levels,
                        changed,
                        changed_levels,
                    })
                } else {
                    None
                };
                Frame::Delta(VisibleDelta {
                    seq,
                    ack,
                    stats,
                    added,
                    removed,
                    lod,
                })
            }
            FrameKind::Transforms => Frame::Transforms(TransformsFrame::read(seq, &mut p)?),
            FrameKind::Applied => Frame::Applied(Applied::read(seq, ack, &mut p)?),
            FrameKind::Region => Frame::Region(RegionFrame::read(seq, ack, &mut p)?),
            FrameKind::Error => {
                let [code, byte_len] = p.fixed()?;
                let code =
                    ErrorCode::from_u32(code).ok_or(FrameError::UnknownErrorCode { code })?;
                let message = p.text("error message", byte_len)?;
                Frame::Error(ErrorFrame {
                    seq,
                    ack,
                    code,
                    message,
                })
            }
        })
    }
}

pub(super) fn check_ascending(list: &'static str, ids: &[u32]) -> Result<(), FrameError> {
    for (index, pair) in ids.windows(2).enumerate() {
        if let [prev, id] = *pair {
            if id <= prev {
                return Err(FrameError::NotAscending {
                    list,
                    index: index + 1,
                    prev,
                    id,
                });
            }
        }
    }
    Ok(())
}

/// First ID common to two ascending lists, as an error.
pub(super) fn check_disjoint(a: &[u32], b: &[u32]) -> Result<(), FrameError> {
    let (mut i, mut j) = (0, 0);
    while let (Some(&x), Some(&y)) = (a.get(i), b.get(j)) {
        if x == y {
            return Err(FrameError::IdInBothLists { id: x });
        }
        if x < y {
            i += 1;
        } else {
            j += 1;
        }
    }
    Ok(())
}

/// `levels` one per ID (else [`FrameError::LevelCount`]), each at most [`MAX_LEVEL`].
pub(super) fn check_levels(ids: usize, levels: &[u8]) -> Result<(), FrameError> {
    if levels.len() != ids {
        return Err(FrameError::LevelCount {
            ids,
            levels: levels.len(),
        });
    }
    match levels.iter().find(|&&l| l > MAX_LEVEL) {
        Some(&level) => Err(FrameError::BadLevel { level }),
        None => Ok(()),
    }
}

/// The first ID of `changed` (ascending) that is also added or removed, as an error.
pub(super) fn check_changed(
    changed: &[u32],
    added: &[u32],
    removed: &[u32],
) -> Result<(), FrameError> {
    for list in [added, removed] {
        if let Err(FrameError::IdInBothLists { id }) = check_disjoint(changed, list) {
            return Err(FrameError::ChangedNotKept { id });
        }
    }
    Ok(())
}

/// `count` levels from the padded bytes of a level block: each at most [`MAX_LEVEL`],
/// the padding zero.
fn decode_levels(bytes: &[u8], count: usize) -> Result<Vec<u8>, FrameError> {
    // `bytes` is the block of count.div_ceil(4) words, so it holds `count` bytes.
    let (levels, padding) = bytes.split_at(count);
    if padding.iter().any(|&b| b != 0) {
        return Err(FrameError::NonZeroPadding { field: "levels" });
    }
    check_levels(count, levels)?;
    Ok(levels.to_vec())
}

/// Strictly ascending IDs from a whole number of words.
pub(super) fn decode_ids(list: &'static str, bytes: &[u8]) -> Result<Vec<u32>, FrameError> {
    // Allocation bounded by the input: one u32 per four input bytes.
    let mut ids = Vec::with_capacity(bytes.len() / 4);
    for c in bytes.chunks_exact(4) {
        let id = u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
        if let Some(&prev) = ids.last() {
            if id <= prev {
                return Err(FrameError::NotAscending {
                    list,
                    index: ids.len(),
                    prev,
                    id,
                });
            }
        }
        ids.push(id);
    }
    Ok(ids)
}
