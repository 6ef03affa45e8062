//! One object's placement and declared motion, checked on arrival: an update either
//! turns into a [`Placement`] the snapshot can apply without further checks, or into a
//! [`TransformError`] that says which object and what is wrong with it.

use glam::{Mat4, Quat, Vec3};
use homcull_proto::ObjectTransform;

use crate::geom::Aabb;

/// Largest coordinate, translation or matrix element accepted, metres: far beyond any
/// scene, small enough that f32 arithmetic on it stays meaningful.
pub const MAX_COORDINATE: f32 = 1.0e6;
/// Fastest declared motion accepted: metres per second, radians per second.
pub const MAX_SPEED: f32 = 1.0e4;
/// Longest horizon, ms.
pub const MAX_HORIZON_MS: f64 = 10_000.0;
/// The horizon a scene starts with, ms: one round trip of an interactive client.
pub const DEFAULT_HORIZON_MS: f64 = 100.0;

/// Where an object is, relative to where its file put it, and how it may move.
/// Serialized (a journal's snapshot) with its floats as they are, so that a placement
/// read back is the very one written.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Placement {
    /// Applied in world space to the object's loaded vertices.
    pub matrix: Mat4,
    /// Metres per second.
    pub velocity: Vec3,
    /// Radians per second about its direction, about the centre of the placed bounds.
    pub angular_velocity: Vec3,
    /// How long the motion holds, seconds (infinite: until the next update; `null`
    /// when serialized, JSON having no infinity).
    #[serde(with = "infinite_as_null")]
    pub motion_s: f32,
}

/// An `f32` that may be infinite, as JSON can hold it: `null` for +∞.
mod infinite_as_null {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    pub fn serialize<S: Serializer>(v: &f32, s: S) -> Result<S::Ok, S::Error> {
        (*v != f32::INFINITY).then_some(*v).serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f32, D::Error> {
        Ok(Option::<f32>::deserialize(d)?.unwrap_or(f32::INFINITY))
    }
}

impl Placement {
    /// Whether the object is where its file put it and declares no motion.
    pub fn is_identity(&self) -> bool {
        self.matrix == Mat4::IDENTITY && !self.has_motion()
    }

    /// Whether the object declares a motion that lasts.
    pub fn has_motion(&self) -> bool {
        self.motion_s > 0.0 && (self.velocity != Vec3::ZERO || self.angular_velocity != Vec3::ZERO)
    }

    /// How long the object's motion is bounded for under `horizon_s`.
    pub fn sweep_s(&self, horizon_s: f32) -> f32 {
        if self.has_motion() {
            horizon_s.min(self.motion_s)
        } else {
            0.0
        }
    }

    /// The region `b` (a part of the placed object whose bounds are `whole`) may reach
    /// within `t` seconds: the box at the start and after the translation `v·t`,
    /// widened by the longest chord a point at distance `r` from the centre of
    /// rotation travels, `2r·sin(θ/2) ≤ r·min(θ, 2)` for the angle `θ = |ω|·t`.
    /// A point's path `c + v·s + R(ω·s)(p − c)` stays within that chord of
    /// `p + v·s`, and the box of the segment's two ends holds every `p + v·s`.
    pub fn swept(&self, b: Aabb, whole: Aabb, t: f32) -> Aabb {
        if t <= 0.0 || b.is_empty() {
            return b;
        }
        let shift = self.velocity * t;
        let moved = b.union(Aabb::new(b.min + shift, b.max + shift));
        let angle = self.angular_velocity.length() * t;
        if angle == 0.0 {
            return moved;
        }
        let c = whole.center();
        let r = b
            .corners()
            .iter()
            .map(|&p| p.distance(c))
            .fold(0.0f32, f32::max);
        let chord = r * angle.min(2.0);
        Aabb::new(
            moved.min - Vec3::splat(chord),
            moved.max + Vec3::splat(chord),
        )
    }
}

/// Why an update was refused. Nothing of a refused request is applied.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TransformError {
    #[error("object {id} does not exist (the scene has {objects} objects)")]
    UnknownObject { id: u32, objects: u32 },
    #[error("object {id} appears twice in one update")]
    Repeated { id: u32 },
    #[error("object {id}: {why}")]
    Invalid { id: u32, why: String },
    #[error("object {id} shares vertices with another object, so it cannot move alone")]
    SharedVertices { id: u32 },
    #[error("{count} objects in one update; at most {max}")]
    TooMany { count: usize, max: usize },
    #[error("horizon_ms must be a number from 0 to {MAX_HORIZON_MS}, not {0}")]
    Horizon(f64),
}

impl Placement {
    /// Checks one update against the object's loaded bounds `loaded` (the pivot of
    /// `rotation` and `scale`).
    pub fn from_update(t: &ObjectTransform, loaded: Aabb) -> Result<Placement, TransformError> {
        let bad = |why: String| TransformError::Invalid { id: t.id, why };
        let finite = |name: &str, v: &[f32], max: f32| {
            if v.iter().all(|x| x.is_finite() && x.abs() <= max) {
                Ok(())
            } else {
                Err(bad(format!(
                    "`{name}` must hold finite numbers of magnitude at most {max}"
                )))
            }
        };
        let trs = t.translation.is_some() || t.rotation.is_some() || t.scale.is_some();
        let matrix = match t.matrix {
            Some(_) if trs => {
                return Err(bad(
                    "give either `matrix` or `translation`/`rotation`/`scale`, not both".into(),
                ));
            }
            Some(m) => {
                finite("matrix", &m, MAX_COORDINATE)?;
                if m[3] != 0.0 || m[7] != 0.0 || m[11] != 0.0 || m[15] != 1.0 {
                    return Err(bad(
                        "`matrix` must be affine: its last row (elements 3, 7, 11, 15 in \
                         column-major order) must be 0, 0, 0, 1"
                            .into(),
                    ));
                }
                Mat4::from_cols_array(&m)
            }
            None => {
                let translation = t.translation.unwrap_or([0.0; 3]);
                finite("translation", &translation, MAX_COORDINATE)?;
                let scale = t.scale.unwrap_or([1.0; 3]);
                finite("scale", &scale, MAX_COORDINATE)?;
                let q = t.rotation.unwrap_or([0.0, 0.0, 0.0, 1.0]);
                finite("rotation", &q, MAX_COORDINATE)?;
                let q = Quat::from_array(q);
                if q.length() < 1e-6 {
                    return Err(bad("`rotation` must be a non-zero quaternion".into()));
                }
                let pivot = if loaded.is_empty() {
                    Vec3::ZERO
                } else {
                    loaded.center()
                };
                Mat4::from_translation(pivot + Vec3::from(translation))
                    * Mat4::from_scale_rotation_translation(
                        Vec3::from(scale),
                        q.normalize(),
                        Vec3::ZERO,
                    )
                    * Mat4::from_translation(-pivot)
            }
        };
        // The linear part must keep volumes: a flattened object's bounds, sub-bounds and
        // triangles would be degenerate.
        let det = glam::Mat3::from_mat4(matrix).determinant();
        if !det.is_finite() || det.abs() < 1e-9 {
            return Err(bad("the transform is not invertible".into()));
        }
        let velocity = t.velocity.unwrap_or([0.0; 3]);
        finite("velocity", &velocity, MAX_SPEED)?;
        let angular = t.angular_velocity.unwrap_or([0.0; 3]);
        finite("angular_velocity", &angular, MAX_SPEED)?;
        let motion_s = match t.valid_ms {
            None => f32::INFINITY,
            Some(ms) if ms.is_finite() && ms >= 0.0 => (ms / 1e3) as f32,
            Some(ms) => return Err(bad(format!("`valid_ms` must be 0 or more, not {ms}"))),
        };
        Ok(Placement {
            matrix,
            velocity: Vec3::from(velocity),
            angular_velocity: Vec3::from(angular),
            motion_s,
        })
    }
}

/// A horizon in ms, checked, as seconds.
pub fn horizon_s(ms: f64) -> Result<f32, TransformError> {
    if ms.is_finite() && (0.0..=MAX_HORIZON_MS).contains(&ms) {
        Ok((ms / 1e3) as f32)
    } else {
        Err(TransformError::Horizon(ms))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn update(id: u32) -> ObjectTransform {
        ObjectTransform {
            id,
            ..Default::default()
        }
    }

    #[test]
    fn rotation_and_scale_turn_about_the_loaded_centre() {
        let loaded = Aabb::new(Vec3::new(9.0, 0.0, 0.0), Vec3::new(11.0, 2.0, 2.0));
        let p = Placement::from_update(
            &ObjectTransform {
                rotation: Some(Quat::from_rotation_y(1.0).to_array()),
                scale: Some([2.0; 3]),
                translation: Some([0.0, 5.0, 0.0]),
                ..update(0)
            },
            loaded,
        )
        .unwrap();
        let c = p.matrix.transform_point3(loaded.center());
        assert!(
            (c - (loaded.center() + Vec3::Y * 5.0)).length() < 1e-5,
            "{c}"
        );
    }

    #[test]
    fn bad_updates_say_what_is_wrong() {
        let loaded = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let refused = |t: ObjectTransform| Placement::from_update(&t, loaded).unwrap_err();
        let nan = refused(ObjectTransform {
            translation: Some([f32::NAN, 0.0, 0.0]),
            ..update(3)
        });
        assert!(nan.to_string().contains("object 3") && nan.to_string().contains("finite"));
        let flat = refused(ObjectTransform {
            scale: Some([1.0, 0.0, 1.0]),
            ..update(1)
        });
        assert!(flat.to_string().contains("not invertible"), "{flat}");
        let projective = {
            let mut m = Mat4::IDENTITY.to_cols_array();
            m[3] = 0.5;
            refused(ObjectTransform {
                matrix: Some(m),
                ..update(1)
            })
        };
        assert!(projective.to_string().contains("affine"), "{projective}");
        let both = refused(ObjectTransform {
            matrix: Some(Mat4::IDENTITY.to_cols_array()),
            translation: Some([1.0; 3]),
            ..update(1)
        });
        assert!(both.to_string().contains("not both"), "{both}");
        let zero_q = refused(ObjectTransform {
            rotation: Some([0.0; 4]),
            ..update(1)
        });
        assert!(zero_q.to_string().contains("quaternion"), "{zero_q}");
        let fast = refused(ObjectTransform {
            velocity: Some([1e9, 0.0, 0.0]),
            ..update(1)
        });
        assert!(fast.to_string().contains("velocity"), "{fast}");
        assert!(horizon_s(-1.0).is_err() && horizon_s(f64::NAN).is_err());
    }

    #[test]
    fn a_swept_box_holds_the_object_along_its_motion() {
        // Points of a box moving and spinning, sampled over the interval, stay inside.
        let b = Aabb::new(Vec3::new(1.0, 0.0, -1.0), Vec3::new(3.0, 1.0, 0.5));
        let p = Placement {
            matrix: Mat4::IDENTITY,
            velocity: Vec3::new(4.0, 0.0, -2.0),
            angular_velocity: Vec3::new(0.0, 3.0, 1.0),
            motion_s: f32::INFINITY,
        };
        let t = 0.4;
        let swept = p.swept(b, b, t);
        let c = b.center();
        for k in 0..=40 {
            let s = t * k as f32 / 40.0;
            let rot = Quat::from_scaled_axis(p.angular_velocity * s);
            for q in b.corners() {
                let at = c + p.velocity * s + rot * (q - c);
                assert!(
                    swept.min.cmple(at + 1e-5).all() && swept.max.cmpge(at - 1e-5).all(),
                    "{at} outside {swept:?} at {s} s"
                );
            }
        }
        // Still: no growth.
        let still = Placement {
            velocity: Vec3::ZERO,
            angular_velocity: Vec3::ZERO,
            ..p
        };
        assert_eq!(still.swept(b, b, t), b);
        assert_eq!(p.sweep_s(0.1), 0.1);
        assert_eq!(
            Placement {
                motion_s: 0.05,
                ..p
            }
            .sweep_s(0.1),
            0.05
        );
    }
}
