//! Axis-aligned boxes and planes: the small geometry every other module shares.
//!
//! `glam` gives vectors and matrices; this adds the two shapes culling is made of,
//! with the exact semantics the conservativeness argument relies on (closed boxes,
//! planes whose positive side is "inside").

use glam::{Vec3, Vec4};
use serde::{Deserialize, Serialize};

/// A closed axis-aligned box. An empty box has `min > max` on some axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    /// The empty box: the identity of [`Aabb::union`].
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn new(min: Vec3, max: Vec3) -> Self {
        Aabb { min, max }
    }

    /// The smallest box holding every point.
    pub fn from_points<'a>(points: impl IntoIterator<Item = &'a Vec3>) -> Self {
        points.into_iter().fold(Aabb::EMPTY, |b, p| b.including(*p))
    }

    pub fn including(self, p: Vec3) -> Self {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    pub fn union(self, o: Aabb) -> Self {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    pub fn extent(&self) -> Vec3 {
        (self.max - self.min).max(Vec3::ZERO)
    }

    /// Length of the diagonal, 0 for an empty box.
    pub fn diagonal(&self) -> f32 {
        if self.is_empty() {
            0.0
        } else {
            self.extent().length()
        }
    }

    /// The eight corners, bit i of the index picking max on axis i.
    pub fn corners(&self) -> [Vec3; 8] {
        std::array::from_fn(|i| {
            Vec3::new(
                if i & 1 == 0 { self.min.x } else { self.max.x },
                if i & 2 == 0 { self.min.y } else { self.max.y },
                if i & 4 == 0 { self.min.z } else { self.max.z },
            )
        })
    }

    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    pub fn to_obvhs(self) -> obvhs::aabb::Aabb {
        obvhs::aabb::Aabb::new(self.min.into(), self.max.into())
    }
}

/// A plane `n·p + d = 0`; points with `n·p + d ≥ 0` are on its inner side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane(pub Vec4);

impl Plane {
    /// A plane from unnormalized coefficients, normalized so distances are metres.
    pub fn normalized(v: Vec4) -> Self {
        let len = v.truncate().length();
        Plane(if len > 0.0 { v / len } else { v })
    }

    pub fn distance(&self, p: Vec3) -> f32 {
        self.0.truncate().dot(p) + self.0.w
    }

    /// Signed distance of the box corner farthest along the normal: negative means the
    /// whole box lies outside.
    pub fn max_distance(&self, b: &Aabb) -> f32 {
        let n = self.0.truncate();
        let p = Vec3::select(n.cmpge(Vec3::ZERO), b.max, b.min);
        self.distance(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn union_and_empty() {
        assert!(Aabb::EMPTY.is_empty());
        let b = Aabb::from_points(&[Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0)]);
        assert!(!b.is_empty());
        assert_eq!(b.union(Aabb::EMPTY), b);
        assert_eq!(b.corners()[7], Vec3::new(1.0, 2.0, 3.0));
        assert!(b.contains(Vec3::new(0.5, 1.0, 3.0)));
        assert!(!b.contains(Vec3::new(0.5, 1.0, 3.1)));
    }

    #[test]
    fn plane_box_distance() {
        let p = Plane::normalized(Vec4::new(0.0, 2.0, 0.0, -2.0)); // y >= 1
        let below = Aabb::new(Vec3::ZERO, Vec3::splat(0.5));
        let across = Aabb::new(Vec3::ZERO, Vec3::splat(2.0));
        assert!(p.max_distance(&below) < 0.0);
        assert!(p.max_distance(&across) > 0.0);
    }
}
