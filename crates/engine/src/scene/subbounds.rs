//! Sub-bounds: split an object's triangles into spatially compact groups, each with its
//! own AABB ("loose bounds").
//!
//! An AABB test can only cull an object whose whole box is hidden; a building whose
//! walls are one object, or a game map's vis-cluster, has a box far bigger than its
//! surfaces. Testing several tight boxes instead, and culling the object only when all
//! of them are hidden, stays conservative (every triangle lies in its group's box) and
//! wins back much of that loss. Groups are made by recursive median splits of triangle
//! centroids along the widest axis, like a shallow BVH build.

use glam::Vec3;

use crate::geom::Aabb;

/// How finely objects are split. Costs: more boxes mean more per-object tests.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SubBoundsParams {
    /// Stop splitting a group at or below this many triangles.
    pub max_triangles_per_group: usize,
    /// Never make more groups than this per object.
    pub max_groups: usize,
    /// Stop splitting a group whose box diagonal is below this many metres.
    pub min_diagonal: f32,
}

impl Default for SubBoundsParams {
    fn default() -> Self {
        SubBoundsParams {
            max_triangles_per_group: 32,
            max_groups: 64,
            min_diagonal: 0.5,
        }
    }
}

impl SubBoundsParams {
    /// One box per object: the plain object AABB.
    pub const WHOLE: SubBoundsParams = SubBoundsParams {
        max_triangles_per_group: usize::MAX,
        max_groups: 1,
        min_diagonal: f32::INFINITY,
    };
}

fn tri_box(tri: &[u32], pos: &[Vec3]) -> Aabb {
    Aabb::from_points(tri.iter().map(|&i| &pos[i as usize]))
}

/// Splits a triangle list (index triples into `pos`) into group boxes. Returns at least
/// one box when there is at least one triangle, none otherwise.
pub fn split_into_groups(tris: &[u32], pos: &[Vec3], params: &SubBoundsParams) -> Vec<Aabb> {
    let mut items: Vec<(Vec3, Aabb)> = tris
        .chunks_exact(3)
        .map(|t| {
            let b = tri_box(t, pos);
            (b.center(), b)
        })
        .collect();
    if items.is_empty() {
        return Vec::new();
    }
    // Work list of slices, split the largest first until the group cap is reached.
    let mut groups: Vec<(usize, usize)> = vec![(0, items.len())];
    let mut done: Vec<(usize, usize)> = Vec::new();
    while let Some((a, b)) = groups.pop() {
        let slice = &mut items[a..b];
        let bounds = slice.iter().fold(Aabb::EMPTY, |acc, it| acc.union(it.1));
        let can_split = slice.len() > params.max_triangles_per_group
            && bounds.diagonal() > params.min_diagonal
            && groups.len() + done.len() + 2 <= params.max_groups;
        if !can_split {
            done.push((a, b));
            continue;
        }
        let cb = Aabb::from_points(slice.iter().map(|it| &it.0));
        let axis = cb.extent().max_position();
        let mid = slice.len() / 2;
        slice.select_nth_unstable_by(mid, |p, q| p.0[axis].total_cmp(&q.0[axis]));
        // Larger half first on the stack's top keeps splits balanced.
        groups.insert(0, (a, a + mid));
        groups.insert(0, (a + mid, b));
    }
    done.sort_unstable();
    done.into_iter()
        .map(|(a, b)| {
            items[a..b]
                .iter()
                .fold(Aabb::EMPTY, |acc, it| acc.union(it.1))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn groups_cover_every_triangle() {
        // A row of 100 small triangles along x.
        let mut pos = Vec::new();
        let mut idx = Vec::new();
        for i in 0..100 {
            let x = i as f32;
            let b = pos.len() as u32;
            pos.extend([
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x + 0.5, 0.0, 0.0),
                Vec3::new(x, 1.0, 0.0),
            ]);
            idx.extend([b, b + 1, b + 2]);
        }
        let p = SubBoundsParams {
            max_triangles_per_group: 8,
            max_groups: 64,
            min_diagonal: 0.0,
        };
        let groups = split_into_groups(&idx, &pos, &p);
        assert!(groups.len() > 8 && groups.len() <= 64);
        for t in idx.chunks_exact(3) {
            let b = tri_box(t, &pos);
            assert!(
                groups
                    .iter()
                    .any(|g| g.contains(b.min) && g.contains(b.max))
            );
        }
        let total: f32 = groups.iter().map(|g| g.extent().x).sum();
        assert!(total < 99.0, "groups must be tighter than the whole box");
        assert_eq!(
            split_into_groups(&idx, &pos, &SubBoundsParams::WHOLE).len(),
            1
        );
        assert!(split_into_groups(&[], &pos, &p).is_empty());
    }
}
