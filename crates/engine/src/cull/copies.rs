//! Objects that are exact copies of earlier objects: the exact oracle never shows them.
//!
//! Scenes exported from level editors hold objects twice (a brush model placed over
//! its own geometry, a wall saved once per room that shares it). Such a copy is hidden
//! in the exact oracle at every pose, and no depth comparison with a margin can prove
//! it: its fragments tie with the original's to the last bit. The refinement is
//! therefore told which objects are copies ([`Copies`]) and culls them.
//!
//! **Why a copy is never visible.** Object `x` is a copy when every one of its
//! triangles is also a triangle of an object with a lower ID, corner for corner: the
//! same three positions, bit for bit, in the same order (in the shared scenes, a door
//! or platform saved both on its own and inside the level's main mesh). Each oracle
//! computes the same coverage and depth for two such triangles (the same inputs
//! through the same arithmetic: the CPU twin's f64 raster, the native ID buffer's
//! spans, the GPU's invariant vertex stage and its fixed raster), and each draws the
//! candidates in ascending ID with a strict depth test (nearest wins, the first on
//! ties). So at each pixel of `x` the earlier object's fragment was drawn first at
//! the same depth, and `x` never owns a pixel. The earlier object is a candidate
//! whenever the triangle has a fragment in view: its box holds the triangle, and the
//! frustum test keeps every box that reaches into the view. Leaving `x` out of the
//! answer changes no pixel of the picture a client draws.
//!
//! **Moving objects.** The relation holds for the geometry it was found on. An object
//! marked dynamic is never part of it, and a scene version that places a copy or one
//! of its originals anew drops that copy for good ([`Copies::without_moved`]), even if a later placement
//! puts it back: conservative, and cheap to keep right.

use super::mask::{empty_mask, has_bit, set_bit};
use crate::scene::Scene;

/// A triangle's corners as the bits of their coordinates, in the index buffer's order.
type TriangleBits = [[u32; 3]; 3];

/// Scenes up to this many triangles are searched for copies (16 bytes each while
/// searching; larger scenes keep none).
pub const MAX_TRIANGLES: usize = 1 << 23;

/// The copies of a scene and what each copies.
#[derive(Clone, Debug, Default)]
pub struct Copies {
    /// `(copy, original)` for each object the copy's triangles come from, ascending;
    /// `original < copy`.
    pairs: Vec<(u32, u32)>,
    /// Bitmask of the copies (empty when there are none).
    mask: Vec<u32>,
}

impl Copies {
    /// Finds the copies of `scene` (module docs). Scenes of more than
    /// [`MAX_TRIANGLES`] triangles are not searched: no copies, which is conservative.
    pub fn find(scene: &Scene) -> Self {
        let triangles = scene.indices.len() / 3;
        if triangles > MAX_TRIANGLES {
            return Self::default();
        }
        // Every triangle of a static object as (hash of its corners, owner, first
        // index), sorted: equal triangles end up next to each other, lowest owner first.
        let mut all: Vec<(u64, u32, u32)> = Vec::with_capacity(triangles);
        for (id, o) in scene.objects.iter().enumerate() {
            if o.dynamic {
                continue;
            }
            for k in (o.first_index..o.first_index + o.index_count).step_by(3) {
                all.push((hash(&corner_bits(scene, k)), id as u32, k));
            }
        }
        all.sort_unstable();
        // For each triangle, the lowest other owner of the same triangle (corner for
        // corner), if that owner is a lower ID.
        let mut original = vec![u32::MAX; triangles];
        for run in all.chunk_by(|a, b| a.0 == b.0) {
            for (j, &(_, owner, k)) in run.iter().enumerate() {
                let bits = corner_bits(scene, k);
                if let Some(&(_, w, _)) = run[..j]
                    .iter()
                    .find(|&&(_, w, i)| w < owner && corner_bits(scene, i) == bits)
                {
                    original[k as usize / 3] = w;
                }
            }
        }
        let mut pairs = Vec::new();
        for (id, o) in scene.objects.iter().enumerate() {
            let tris = o.first_index as usize / 3..(o.first_index + o.index_count) as usize / 3;
            if o.dynamic || tris.is_empty() || original[tris.clone()].contains(&u32::MAX) {
                continue;
            }
            let mut of: Vec<u32> = original[tris].to_vec();
            of.sort_unstable();
            of.dedup();
            pairs.extend(of.into_iter().map(|w| (id as u32, w)));
        }
        Self::from_pairs(scene.objects.len(), pairs)
    }

    fn from_pairs(objects: usize, pairs: Vec<(u32, u32)>) -> Self {
        let mut mask = Vec::new();
        if !pairs.is_empty() {
            mask = empty_mask(objects);
            for &(copy, _) in &pairs {
                set_bit(&mut mask, copy);
            }
        }
        Copies { pairs, mask }
    }

    /// Whether the scene has no copies.
    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }

    /// The copies, ascending (each once, however many objects its triangles come
    /// from).
    pub fn ids(&self) -> impl Iterator<Item = u32> + '_ {
        self.pairs.chunk_by(|a, b| a.0 == b.0).map(|of| of[0].0)
    }

    /// The number of copies.
    pub fn len(&self) -> usize {
        self.ids().count()
    }

    /// Whether object `id` is a copy.
    pub fn is_copy(&self, id: u32) -> bool {
        !self.mask.is_empty() && has_bit(&self.mask, id)
    }

    /// `(copy, original)` pairs, ascending by copy.
    pub fn pairs(&self) -> &[(u32, u32)] {
        &self.pairs
    }

    /// The relation after objects `moved` were placed anew: every pair with a moved
    /// member is dropped.
    pub fn without_moved(&self, objects: usize, moved: impl IntoIterator<Item = u32>) -> Self {
        if self.is_empty() {
            return self.clone();
        }
        let mut gone = empty_mask(objects);
        for id in moved {
            set_bit(&mut gone, id);
        }
        let pairs = self
            .pairs
            .chunk_by(|a, b| a.0 == b.0)
            .filter(|of| {
                of.iter()
                    .all(|&(c, w)| !has_bit(&gone, c) && !has_bit(&gone, w))
            })
            .flatten()
            .copied()
            .collect();
        Self::from_pairs(objects, pairs)
    }

    /// Clears the bits of the copies in a visibility bitmask.
    pub fn hide_in(&self, visible: &mut [u32]) {
        for (v, m) in visible.iter_mut().zip(&self.mask) {
            *v &= !m;
        }
    }
}

/// The corners of the triangle at index `k` of the index buffer, as bits.
fn corner_bits(scene: &Scene, k: u32) -> TriangleBits {
    let k = k as usize;
    [0, 1, 2].map(|c| {
        scene.positions[scene.indices[k + c] as usize]
            .to_array()
            .map(f32::to_bits)
    })
}

/// FNV-1a over the corners' bits: equal triangles hash alike (collisions are
/// compared corner for corner).
fn hash(t: &TriangleBits) -> u64 {
    t.iter().flatten().fold(0xcbf2_9ce4_8422_2325, |h, &w| {
        (h ^ w as u64).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::scene::SceneBuilder;

    /// A scene of unit cubes at the given corners (12 triangles each), the flagged
    /// ones marked dynamic.
    fn scene_of(cubes: &[(Vec3, bool)]) -> Scene {
        let mut b = SceneBuilder::default();
        for (i, &(at, dynamic)) in cubes.iter().enumerate() {
            let c: Vec<Vec3> = (0..8)
                .map(|k| at + Vec3::new((k & 1) as f32, (k >> 1 & 1) as f32, (k >> 2) as f32))
                .collect();
            let idx = [
                0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2,
                4, 6, 1, 3, 5, 3, 7, 5,
            ];
            let extras = dynamic.then(|| serde_json::json!({"homcull": {"dynamic": true}}));
            b.push(format!("cube_{i}"), &c, &idx, extras);
        }
        b.build("cubes")
    }

    #[test]
    fn finds_exact_copies_and_only_those() {
        let a = Vec3::new(0.0, 0.0, 0.0);
        let b = Vec3::new(5.0, 0.0, 0.0);
        let s = scene_of(&[(a, false), (b, false), (a, false), (a, false), (b, true)]);
        let c = Copies::find(&s);
        assert_eq!(c.pairs(), &[(2, 0), (3, 0)]);
        assert!(c.is_copy(2) && c.is_copy(3));
        assert!(!c.is_copy(0) && !c.is_copy(1) && !c.is_copy(4));
        let mut visible = vec![!0u32];
        c.hide_in(&mut visible);
        assert_eq!(visible[0] & 0b11111, 0b10011);
    }

    #[test]
    fn a_copy_of_two_originals_is_one_copy() {
        let (a, b) = (Vec3::ZERO, Vec3::new(5.0, 0.0, 0.0));
        let mut s = scene_of(&[(a, false), (b, false), (a, false)]);
        // Object 2's second half of triangles taken from object 1 instead of object 0.
        let (f1, f2) = (
            s.objects[1].first_index as usize,
            s.objects[2].first_index as usize,
        );
        let from_1: Vec<u32> = s.indices[f1 + 18..f1 + 36].to_vec();
        s.indices[f2 + 18..f2 + 36].copy_from_slice(&from_1);
        let c = Copies::find(&s);
        assert_eq!(c.pairs(), &[(2, 0), (2, 1)]);
        assert_eq!(c.ids().collect::<Vec<_>>(), [2]);
        assert_eq!(c.len(), 1);
        // Either original placed anew drops the copy.
        assert!(c.without_moved(3, [1]).is_empty());
    }

    #[test]
    fn the_same_triangles_in_another_corner_order_are_not_a_copy() {
        let mut s = scene_of(&[(Vec3::ZERO, false), (Vec3::ZERO, false)]);
        // Rotate the corners of the second box's first triangle: the same triangle,
        // other arithmetic.
        let o = &s.objects[1];
        let f = o.first_index as usize;
        s.indices[f..f + 3].rotate_left(1);
        assert!(Copies::find(&s).is_empty());
    }

    #[test]
    fn a_moved_member_drops_its_pair() {
        let a = Vec3::ZERO;
        let s = scene_of(&[(a, false), (a, false), (a, false)]);
        let c = Copies::find(&s);
        assert_eq!(c.len(), 2);
        let after = c.without_moved(3, [0]);
        assert!(after.is_empty());
        let after = c.without_moved(3, [2]);
        assert_eq!(after.pairs(), &[(1, 0)]);
        assert!(!after.is_copy(2));
    }
}
