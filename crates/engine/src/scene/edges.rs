//! Which triangle shares each edge of an occluder's triangles: where a region map's
//! first drawn surface continues across an edge and where it may end.
//!
//! Two triangles of one object share an edge when they have its two corners at the
//! same positions, bit for bit (meshes repeat a vertex per normal or texture seam, so
//! indices alone would split surfaces that are whole). An edge with one triangle, or
//! with three or more, has no neighbour: the map treats it as a place where the
//! surface may end, which only ever makes it cull less. Neighbours are found once per
//! scene, for the objects that may occlude, and hold for every later version of it: a
//! moved object moves its corners by one matrix, so corners that were equal stay equal.
//!
//! An edge with no neighbour may still lie on another surface: the side wall of the
//! next building along a street, the ground under a facade's foot, a T-junction. Such
//! *holders* are found once per scene too (`cull::holders`: triangles of any occluder that the edge
//! lies on within [`HOLD_TOLERANCE_M`]), as candidates only: whether a candidate holds
//! the edge, and which part of it, is decided again from the current corners each time
//! ([`held`]), so that objects moved apart stop holding each other's edges.

use std::collections::HashMap;

use super::Scene;
use glam::Vec3;

/// How far (metres) an edge may lie off a triangle's plane, and outside its edges, and
/// still count as lying on it: f32 rounding of corners a few hundred metres from the
/// origin, and no more.
pub const HOLD_TOLERANCE_M: f32 = 1e-4;
/// Most holder candidates kept per edge (more only ever makes the map cull less).
pub const MAX_HOLDERS: usize = 16;

/// No neighbour across an edge.
const NONE: u32 = u32::MAX;

/// An edge by its two corner positions (their bits), sorted.
type EdgeKey = ([u32; 3], [u32; 3]);

/// The neighbour across each edge of each triangle of the scene's occluder objects,
/// by global triangle index (`Scene::indices` / 3); edge `e` runs from corner `e` to
/// corner `e + 1`.
#[derive(Debug, Default)]
pub struct EdgeNeighbours {
    /// Three entries per triangle of the scene (`NONE` where there is none, and for
    /// every triangle of an object that was not indexed).
    across: Vec<u32>,
    /// Holder candidates of the edges with no neighbour: slot `tri * 3 + e` owns
    /// `holders[holder_start[slot] .. holder_start[slot + 1]]` (global triangle
    /// indices).
    holder_start: Vec<u32>,
    holders: Vec<u32>,
}

/// How a triangle holds part of an edge ([`held`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Hold {
    /// The part crosses the triangle's inside: the triangle lies on both sides of it.
    Inside,
    /// The part lies along the triangle's edge `k` (from corner `k` to `k + 1`): the
    /// triangle lies on one side of it only.
    Along(usize),
}

/// The part `[t0, t1]` of the edge from `a` to `b` (`a + t·(b − a)`) that lies on
/// triangle `s` within [`HOLD_TOLERANCE_M`], and how; `None` where none does (or `s`
/// has no area).
pub fn held(a: Vec3, b: Vec3, s: [Vec3; 3]) -> Option<(f32, f32, Hold)> {
    let n = (s[1] - s[0]).cross(s[2] - s[0]);
    let area = n.length();
    if area.is_nan() || area <= 1e-12 {
        return None;
    }
    let n = n / area;
    let tol = HOLD_TOLERANCE_M;
    if n.dot(a - s[0]).abs() > tol || n.dot(b - s[0]).abs() > tol {
        return None;
    }
    let (mut t0, mut t1) = (0.0f32, 1.0f32);
    let mut along = None;
    for k in 0..3 {
        let (p, q) = (s[k], s[(k + 1) % 3]);
        // In the plane, perpendicular to edge k, towards the inside.
        let inward = n.cross(q - p).normalize_or_zero();
        let (fa, fb) = (inward.dot(a - p), inward.dot(b - p));
        if fa.abs() <= tol && fb.abs() <= tol {
            along = Some(k);
            continue;
        }
        // fa + t·(fb − fa) ≥ −tol
        let (ga, gb) = (fa + tol, fb + tol);
        if ga < 0.0 && gb < 0.0 {
            return None;
        }
        if ga < 0.0 {
            t0 = t0.max(ga / (ga - gb));
        } else if gb < 0.0 {
            t1 = t1.min(ga / (ga - gb));
        }
    }
    // A part no longer than the tolerance holds nothing worth telling.
    let long = (t1 - t0) * (b - a).length() > 2.0 * tol;
    long.then(|| (t0, t1, along.map_or(Hold::Inside, Hold::Along)))
}

impl EdgeNeighbours {
    /// Indexes the triangles of `objects` (the occluder objects) of `scene`.
    pub fn build(scene: &Scene, objects: &[u32]) -> Self {
        let mut across = vec![NONE; scene.indices.len()];
        let key = |p: Vec3| p.to_array().map(f32::to_bits);
        for &id in objects {
            let o = &scene.objects[id as usize];
            let first = o.first_index / 3;
            // Edge (its corner positions, sorted) → the first two (triangle, edge)
            // slots that have it, packed as `tri * 3 + e`, and how many have it.
            let mut seen: HashMap<EdgeKey, ([u32; 2], u32)> = HashMap::new();
            for (k, corners) in scene.corners_of(o).enumerate() {
                let slot = (first + k as u32) * 3;
                for e in 0..3 {
                    let (a, b) = (key(corners[e]), key(corners[(e + 1) % 3]));
                    if a == b {
                        continue; // a degenerate edge bounds nothing
                    }
                    let edge = if a < b { (a, b) } else { (b, a) };
                    let entry = seen.entry(edge).or_insert(([NONE; 2], 0));
                    if entry.1 < 2 {
                        entry.0[entry.1 as usize] = slot + e as u32;
                    }
                    entry.1 += 1;
                }
            }
            for ([s, t], n) in seen.into_values() {
                if n == 2 {
                    across[s as usize] = t / 3;
                    across[t as usize] = s / 3;
                }
            }
        }
        EdgeNeighbours {
            across,
            holder_start: Vec::new(),
            holders: Vec::new(),
        }
    }

    /// Whether edge `e` of triangle `tri` has no neighbour.
    pub fn is_open(&self, tri: u32, e: usize) -> bool {
        self.across.get(tri as usize * 3 + e) == Some(&NONE)
    }

    /// The same neighbours with the holder candidates of each open edge, by slot
    /// (`tri * 3 + e`), ascending: what `cull::holders` finds.
    pub fn with_holders(self, found: Vec<(u32, Vec<u32>)>) -> Self {
        let mut start = vec![0u32; self.across.len() + 1];
        for (slot, hits) in &found {
            start[*slot as usize + 1] = hits.len() as u32;
        }
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        EdgeNeighbours {
            across: self.across,
            holder_start: start,
            holders: found.into_iter().flat_map(|(_, h)| h).collect(),
        }
    }

    /// Triangles that may hold edge `e` of triangle `tri` ([`held`] says whether and
    /// where they do now); empty where the edge has a neighbour.
    pub fn holders(&self, tri: u32, e: usize) -> &[u32] {
        let slot = tri as usize * 3 + e;
        match (self.holder_start.get(slot), self.holder_start.get(slot + 1)) {
            (Some(&a), Some(&b)) => &self.holders[a as usize..b as usize],
            _ => &[],
        }
    }

    /// The triangle across edge `e` of triangle `tri`, if exactly one shares it.
    pub fn of(&self, tri: u32, e: usize) -> Option<u32> {
        let n = *self.across.get(tri as usize * 3 + e)?;
        (n != NONE).then_some(n)
    }
}
