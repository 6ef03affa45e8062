//! The writer's frames (version 4): [`TransformsFrame`] moves objects, [`Applied`]
//! answers it with the scene version it made.
//!
//! An optional `f32` travels as its bits, with the word [`NO_VALUE`] (`0xFFFFFFFF`, a
//! NaN no sender means) for "absent", so every valid frame keeps exactly one encoding.

use super::codec::check_ascending;
use super::words::{Reader, Writer};
use super::*;
use crate::{ObjectTransform, TransformsRequest};

/// The word an absent optional `f32` travels as.
pub const NO_VALUE: u32 = 0xFFFF_FFFF;

/// Words per object of a [`TransformsFrame`]: id, 12 matrix, 3 velocity, 3 angular
/// velocity, valid_ms.
pub const MOVED_OBJECT_WORDS: usize = 20;

/// Objects moved by a writer (client → server). Its `ack` is always 0.
///
/// `PartialEq` compares the numbers as floats (a frame holding NaN is not equal to
/// itself); compare [`Frame::encode`] output for bit equality.
#[derive(Debug, Clone, PartialEq)]
pub struct TransformsFrame {
    /// The writer's sequence number, echoed as `ack` by the answer.
    pub seq: u32,
    /// The horizon, ms (`None`: keep the scene's).
    pub horizon_ms: Option<f32>,
    /// Strictly ascending IDs.
    pub objects: Vec<MovedObject>,
}

/// One object of a [`TransformsFrame`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MovedObject {
    pub id: u32,
    /// The affine placement relative to the scene file: the first three rows of the
    /// column-major 4×4, column by column (`m00 m10 m20 m01 m11 m21 m02 m12 m22 m03 m13
    /// m23`; the last row is 0, 0, 0, 1).
    pub matrix: [f32; 12],
    /// Metres per second.
    pub velocity: [f32; 3],
    /// Radians per second about the vector.
    pub angular_velocity: [f32; 3],
    /// How long the motion holds, ms (`None`: until the next update).
    pub valid_ms: Option<f32>,
}

/// A writer's update applied (server → client).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Applied {
    /// The server's frame counter for this client.
    pub seq: u32,
    /// The [`TransformsFrame`]'s `seq`.
    pub ack: u32,
    /// The scene version the update made.
    pub version: u64,
    /// Objects it moved.
    pub applied: u32,
}

impl MovedObject {
    /// The same placement and motion as the REST route takes it.
    pub fn to_transform(&self) -> ObjectTransform {
        let m = self.matrix;
        let column = |c: usize, w: f32| [m[3 * c], m[3 * c + 1], m[3 * c + 2], w];
        let cols = [
            column(0, 0.0),
            column(1, 0.0),
            column(2, 0.0),
            column(3, 1.0),
        ];
        ObjectTransform {
            id: self.id,
            matrix: Some(cols.concat().try_into().expect("16 numbers")),
            velocity: Some(self.velocity),
            angular_velocity: Some(self.angular_velocity),
            valid_ms: self.valid_ms.map(f64::from),
            ..Default::default()
        }
    }
}

impl TransformsFrame {
    /// The update as `POST /v1/scenes/{id}/transforms` takes it.
    pub fn to_request(&self) -> TransformsRequest {
        TransformsRequest {
            objects: self.objects.iter().map(MovedObject::to_transform).collect(),
            horizon_ms: self.horizon_ms.map(f64::from),
        }
    }

    fn ids(&self) -> Vec<u32> {
        self.objects.iter().map(|o| o.id).collect()
    }

    pub(super) fn payload_words(&self) -> usize {
        2 + MOVED_OBJECT_WORDS * self.objects.len()
    }

    pub(super) fn validate(&self) -> Result<(), FrameError> {
        check_ascending("transforms", &self.ids())
    }

    pub(super) fn write(&self, w: &mut Writer) {
        w.word(optional(self.horizon_ms));
        w.word(words::len_u32(self.objects.len()));
        for o in &self.objects {
            w.word(o.id);
            for v in o
                .matrix
                .iter()
                .chain(&o.velocity)
                .chain(&o.angular_velocity)
            {
                w.f32(*v);
            }
            w.word(optional(o.valid_ms));
        }
    }

    pub(super) fn read(seq: u32, p: &mut Reader<'_>) -> Result<Self, FrameError> {
        let [horizon, count] = p.fixed()?;
        let tail = p.tail(u64::from(count) * MOVED_OBJECT_WORDS as u64)?;
        // `tail` holds exactly `count` objects.
        let mut objects = Vec::with_capacity(tail.len() / (4 * MOVED_OBJECT_WORDS));
        for chunk in tail.chunks_exact(4 * MOVED_OBJECT_WORDS) {
            let mut w = [0u32; MOVED_OBJECT_WORDS];
            words::fill_words(&mut w, chunk);
            let f = |k: usize| f32::from_bits(w[k]);
            objects.push(MovedObject {
                id: w[0],
                matrix: std::array::from_fn(|k| f(1 + k)),
                velocity: std::array::from_fn(|k| f(13 + k)),
                angular_velocity: std::array::from_fn(|k| f(16 + k)),
                valid_ms: read_optional(w[19]),
            });
        }
        let frame = TransformsFrame {
            seq,
            horizon_ms: read_optional(horizon),
            objects,
        };
        frame.validate()?;
        Ok(frame)
    }
}

impl Applied {
    pub(super) const PAYLOAD_WORDS: usize = 3;

    pub(super) fn write(&self, w: &mut Writer) {
        w.word(self.version as u32);
        w.word((self.version >> 32) as u32);
        w.word(self.applied);
    }

    pub(super) fn read(seq: u32, ack: u32, p: &mut Reader<'_>) -> Result<Self, FrameError> {
        let [lo, hi, applied] = p.fixed()?;
        p.tail(0)?;
        Ok(Applied {
            seq,
            ack,
            version: u64::from(lo) | (u64::from(hi) << 32),
            applied,
        })
    }
}

fn optional(v: Option<f32>) -> u32 {
    v.map_or(NO_VALUE, f32::to_bits)
}

fn read_optional(w: u32) -> Option<f32> {
    (w != NO_VALUE).then(|| f32::from_bits(w))
}

impl From<TransformsFrame> for Frame {
    fn from(f: TransformsFrame) -> Frame {
        Frame::Transforms(f)
    }
}

impl From<Applied> for Frame {
    fn from(f: Applied) -> Frame {
        Frame::Applied(f)
    }
}
