//! Encoding, decoding and validation of frames: little-endian words, checked lengths,
//! no panics and no allocation beyond what the input justifies.

use super::*;
use crate::PROTOCOL_VERSION;

impl Frame {
    /// What this frame is.
    pub fn kind(&self) -> FrameKind {
        match self {
            Frame::Hello(_) => FrameKind::Hello,
            Frame::Pose(_) => FrameKind::Pose,
            Frame::Full(_) => FrameKind::Full,
            Frame::Delta(_) => FrameKind::Delta,
            Frame::Error(_) => FrameKind::Error,
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
        }
    }

    /// Header word 3: the pose sequence number answered (always 0 for Hello and Pose).
    pub fn ack(&self) -> u32 {
        match self {
            Frame::Hello(_) | Frame::Pose(_) => 0,
            Frame::Full(f) => f.ack,
            Frame::Delta(f) => f.ack,
            Frame::Error(f) => f.ack,
        }
    }

    /// Words after the header.
    fn payload_words(&self) -> usize {
        match self {
            Frame::Hello(h) => 2 + h.info_json.len().div_ceil(4),
            Frame::Pose(_) => POSE_PAYLOAD_WORDS,
            Frame::Full(f) => STATS_WORDS + 1 + f.ids.len(),
            Frame::Delta(d) => STATS_WORDS + 1 + d.added.len() + d.removed.len(),
            Frame::Error(e) => 2 + e.message.len().div_ceil(4),
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
            Frame::Full(f) => check_ascending("full", &f.ids),
            Frame::Delta(d) => {
                check_ascending("added", &d.added)?;
                check_ascending("removed", &d.removed)?;
                check_disjoint(&d.added, &d.removed)
            }
            Frame::Hello(_) | Frame::Pose(_) | Frame::Error(_) => Ok(()),
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
    /// list), or a string or ID list has more than `u32::MAX` elements (the frame could
    /// not describe it, and would be far beyond [`MAX_FRAME_BYTES`] anyway).
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
                w.word(if p.want_full { POSE_FLAG_WANT_FULL } else { 0 });
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
            }
            Frame::Full(f) => {
                w.words(&f.stats.to_words());
                w.word(len_u32(f.ids.len()));
                w.words(&f.ids);
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
                w.words(&d.added);
                w.words(&d.removed);
            }
            Frame::Error(e) => {
                w.word(e.code as u32);
                w.text(&e.message);
            }
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
        if matches!(kind, FrameKind::Hello | FrameKind::Pose) && ack != 0 {
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
                if flags & !POSE_FLAG_WANT_FULL != 0 {
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
                })
            }
            FrameKind::Full => {
                let stats = FrameStats::from_words(p.fixed()?);
                let [count] = p.fixed()?;
                let ids = decode_ids("full", p.tail(u64::from(count))?)?;
                Frame::Full(VisibleFull {
                    seq,
                    ack,
                    stats,
                    ids,
                })
            }
            FrameKind::Delta => {
                let stats = FrameStats::from_words(p.fixed()?);
                let [counts] = p.fixed()?;
                let (added_count, removed_count) = (counts & 0xFFFF, counts >> 16);
                let tail = p.tail(u64::from(added_count) + u64::from(removed_count))?;
                // `tail` holds exactly added_count + removed_count words, so this fits.
                let split = usize::try_from(added_count)
                    .ok()
                    .and_then(|n| n.checked_mul(4))
                    .and_then(|at| tail.split_at_checked(at));
                let Some((added, removed)) = split else {
                    return Err(p.size_error(u64::from(added_count) + u64::from(removed_count)));
                };
                let added = decode_ids("added", added)?;
                let removed = decode_ids("removed", removed)?;
                check_disjoint(&added, &removed)?;
                Frame::Delta(VisibleDelta {
                    seq,
                    ack,
                    stats,
                    added,
                    removed,
                })
            }
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

pub(super) fn len_u32(n: usize) -> u32 {
    u32::try_from(n).expect("frame field longer than u32::MAX elements")
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

/// Fills `out` with the little-endian words of `bytes` (as many as both have).
pub(super) fn fill_words(out: &mut [u32], bytes: &[u8]) {
    for (o, c) in out.iter_mut().zip(bytes.chunks_exact(4)) {
        *o = u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
    }
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

struct Writer(Vec<u8>);

impl Writer {
    fn word(&mut self, w: u32) {
        self.0.extend_from_slice(&w.to_le_bytes());
    }

    fn words(&mut self, ws: &[u32]) {
        for &w in ws {
            self.word(w);
        }
    }

    fn f32(&mut self, v: f32) {
        self.word(v.to_bits());
    }

    /// `[byte_len]`, the bytes, zero padding to a word.
    fn text(&mut self, s: &str) {
        self.word(len_u32(s.len()));
        self.0.extend_from_slice(s.as_bytes());
        let pad = s.len().next_multiple_of(4) - s.len();
        self.0.extend_from_slice(&[0; 3][..pad]);
    }
}

/// The payload of one frame, consumed front to back.
struct Reader<'a> {
    kind: FrameKind,
    rest: &'a [u8],
    /// Words in the whole payload.
    words: usize,
}

impl<'a> Reader<'a> {
    fn consumed(&self) -> u64 {
        (self.words - self.rest.len() / 4) as u64
    }

    /// The payload does not have the `expected` words its fields call for.
    fn size_error(&self, expected_after_consumed: u64) -> FrameError {
        FrameError::PayloadSize {
            kind: self.kind,
            expected: self.consumed().saturating_add(expected_after_consumed),
            actual: self.words,
        }
    }

    /// The next `N` words, which must be there.
    fn fixed<const N: usize>(&mut self) -> Result<[u32; N], FrameError> {
        let Some((head, rest)) = self.rest.split_at_checked(N * 4) else {
            return Err(self.size_error(N as u64));
        };
        self.rest = rest;
        let mut out = [0; N];
        fill_words(&mut out, head);
        Ok(out)
    }

    /// All the remaining words, which must be exactly `n`.
    fn tail(&mut self, n: u64) -> Result<&'a [u8], FrameError> {
        if (self.rest.len() / 4) as u64 != n {
            return Err(self.size_error(n));
        }
        Ok(std::mem::take(&mut self.rest))
    }

    /// The rest of the payload as `byte_len` bytes of UTF-8 plus zero padding to a word.
    fn text(&mut self, field: &'static str, byte_len: u32) -> Result<String, FrameError> {
        let n = u64::from(byte_len);
        let padded = self.tail(n.div_ceil(4))?;
        let split = usize::try_from(byte_len)
            .ok()
            .and_then(|at| padded.split_at_checked(at));
        let Some((text, padding)) = split else {
            return Err(self.size_error(n.div_ceil(4)));
        };
        if padding.iter().any(|&b| b != 0) {
            return Err(FrameError::NonZeroPadding { field });
        }
        match std::str::from_utf8(text) {
            Ok(s) => Ok(s.to_owned()),
            Err(_) => Err(FrameError::InvalidUtf8 { field }),
        }
    }
}
