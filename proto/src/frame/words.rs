//! The word-level writer and reader every frame's encoding and decoding is made of:
//! little-endian words, zero-padded bytes and strings, payload sizes checked before
//! anything is read.

use super::*;

pub(super) struct Writer(pub(super) Vec<u8>);

impl Writer {
    pub(super) fn word(&mut self, w: u32) {
        self.0.extend_from_slice(&w.to_le_bytes());
    }

    pub(super) fn words(&mut self, ws: &[u32]) {
        for &w in ws {
            self.word(w);
        }
    }

    /// The bytes, zero padding to a word.
    pub(super) fn bytes(&mut self, b: &[u8]) {
        self.0.extend_from_slice(b);
        self.0.resize(self.0.len().next_multiple_of(4), 0);
    }

    pub(super) fn f32(&mut self, v: f32) {
        self.word(v.to_bits());
    }

    /// `[byte_len]`, the bytes, zero padding to a word.
    pub(super) fn text(&mut self, s: &str) {
        self.word(len_u32(s.len()));
        self.0.extend_from_slice(s.as_bytes());
        let pad = s.len().next_multiple_of(4) - s.len();
        self.0.extend_from_slice(&[0; 3][..pad]);
    }
}

/// The payload of one frame, consumed front to back.
pub(super) struct Reader<'a> {
    pub(super) kind: FrameKind,
    pub(super) rest: &'a [u8],
    /// Words in the whole payload.
    pub(super) words: usize,
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
    pub(super) fn fixed<const N: usize>(&mut self) -> Result<[u32; N], FrameError> {
        let Some((head, rest)) = self.rest.split_at_checked(N * 4) else {
            return Err(self.size_error(N as u64));
        };
        self.rest = rest;
        let mut out = [0; N];
        fill_words(&mut out, head);
        Ok(out)
    }

    /// All the remaining words, which must be exactly `n`.
    pub(super) fn tail(&mut self, n: u64) -> Result<&'a [u8], FrameError> {
        if (self.rest.len() / 4) as u64 != n {
            return Err(self.size_error(n));
        }
        Ok(std::mem::take(&mut self.rest))
    }

    /// The rest of the payload as `byte_len` bytes of UTF-8 plus zero padding to a word.
    pub(super) fn text(
        &mut self,
        field: &'static str,
        byte_len: u32,
    ) -> Result<String, FrameError> {
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

/// A length as the u32 a frame field carries.
pub(super) fn len_u32(n: usize) -> u32 {
    u32::try_from(n).expect("frame field longer than u32::MAX elements")
}

/// Fills `out` with the little-endian words of `bytes` (as many as both have).
pub(super) fn fill_words(out: &mut [u32], bytes: &[u8]) {
    for (o, c) in out.iter_mut().zip(bytes.chunks_exact(4)) {
        *o = u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
    }
}
