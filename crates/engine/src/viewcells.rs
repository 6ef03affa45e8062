//! View-cell PVS precomputation: for every cell of eyes in a scene, the objects
//! visible from anywhere in it looking anywhere (the baked PVS of game engines),
//! from homcull's region answers.
//!
//! A cell is covered by boxes no larger than a useful region. Each box is answered
//! as a box region of every direction ([`region::cull`]: conservative for every eye
//! in the box, whatever it looks at), so the union of the answers of the boxes that
//! cover a cell holds for the whole cell; small boxes lose far less near walls than
//! one big one would (a region's occluders must lie beyond its ball). Every box is
//! answered once, whatever cells share it, in parallel.
//!
//! Cells come from the walkable space ([`grid_cells`]: the columns of a grid that
//! hold standing eyes, eye heights 0.5–2.5 m above their floors) or from a map's vis
//! clusters ([`cluster_cells`]: the boxes of a grid over the scene that reach a leaf
//! of the cluster).

use std::sync::atomic::{AtomicUsize, Ordering};

use glam::Vec3;
use homcull_proto::{Pose, Region as WireRegion};
use rayon::prelude::*;

use crate::camera::Camera;
use crate::cull::{CullSettings, PreparedScene};
use crate::geom::Aabb;
use crate::pvs::Pvs;
use crate::region;
use crate::sampler::{EYE_HEIGHT, NEAR, PoseSampler};

/// Eye heights above a floor that a grid cell holds, metres.
pub const EYE_HEIGHTS_M: (f32, f32) = (0.5, 2.5);
/// Standing eyes tried per grid column and axis (a `k × k` lattice per column).
const LATTICE: usize = 3;

/// The cells of a scene and the boxes that cover them.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewCells {
    /// Every box, each answered once.
    pub boxes: Vec<Aabb>,
    pub cells: Vec<ViewCell>,
}

/// One cell: a name, the map's cluster it stands for (cluster cells), and the
/// indices of the boxes that cover it.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewCell {
    pub name: String,
    pub cluster: Option<i32>,
    pub boxes: Vec<u32>,
}

/// Grid cells of side `cell_m` over the walkable space: each column (x, z) where
/// the sampler finds a standing eye on a lattice of [`LATTICE`]² points, its boxes
/// spanning [`EYE_HEIGHTS_M`] above each floor found, cut into pieces at most
/// `cell_m` tall. `accept` is the sampler's extra test of an eye (a map's "not in
/// solid").
pub fn grid_cells(
    sampler: &PoseSampler,
    bounds: &Aabb,
    cell_m: f32,
    accept: &dyn Fn(Vec3) -> bool,
) -> ViewCells {
    let mut out = ViewCells {
        boxes: Vec::new(),
        cells: Vec::new(),
    };
    if bounds.is_empty() || !(cell_m.is_finite() && cell_m > 0.0) {
        return out;
    }
    let columns = |lo: f32, hi: f32| ((hi - lo) / cell_m).ceil().max(1.0) as usize;
    let (nx, nz) = (
        columns(bounds.min.x, bounds.max.x),
        columns(bounds.min.z, bounds.max.z),
    );
    for i in 0..nx {
        for j in 0..nz {
            let x0 = bounds.min.x + i as f32 * cell_m;
            let z0 = bounds.min.z + j as f32 * cell_m;
            let mut floors: Vec<f32> = Vec::new();
            for a in 0..LATTICE {
                for b in 0..LATTICE {
                    let at = |k: usize| (k as f32 + 0.5) / LATTICE as f32 * cell_m;
                    if let Some(eye) = sampler.standing_eye_at(x0 + at(a), z0 + at(b), accept) {
                        floors.push(eye.y - EYE_HEIGHT);
                    }
                }
            }
            if floors.is_empty() {
                continue;
            }
            let (lo, hi) = floors.iter().fold((f32::MAX, f32::MIN), |(lo, hi), &f| {
                (lo.min(f + EYE_HEIGHTS_M.0), hi.max(f + EYE_HEIGHTS_M.1))
            });
            let pieces = ((hi - lo) / cell_m).ceil().max(1.0) as usize;
            let step = (hi - lo) / pieces as f32;
            let first = out.boxes.len() as u32;
            for k in 0..pieces {
                let y0 = lo + k as f32 * step;
                out.boxes.push(Aabb::new(
                    Vec3::new(x0, y0, z0),
                    Vec3::new(x0 + cell_m, y0 + step, z0 + cell_m),
                ));
            }
            out.cells.push(ViewCell {
                name: format!("column_{i}_{j}"),
                cluster: None,
                boxes: (first..out.boxes.len() as u32).collect(),
            });
        }
    }
    out
}

/// One cell per vis cluster of `pvs` (those in `only` when given): the boxes of a
/// grid of side `box_m` over `bounds` that reach a leaf of the cluster
/// ([`Pvs::clusters_touching`]). Every point of a cluster lies in one of its boxes,
/// so the union of their answers holds for the cluster.
pub fn cluster_cells(pvs: &Pvs, bounds: &Aabb, box_m: f32, only: Option<&[i32]>) -> ViewCells {
    let mut out = ViewCells {
        boxes: Vec::new(),
        cells: Vec::new(),
    };
    if bounds.is_empty() || !(box_m.is_finite() && box_m > 0.0) {
        return out;
    }
    let wanted = |c: i32| only.is_none_or(|o| o.contains(&c));
    let mut by_cluster: Vec<Vec<u32>> = vec![Vec::new(); pvs.num_clusters()];
    let n = ((bounds.max - bounds.min) / box_m).ceil().max(Vec3::ONE);
    for i in 0..n.x as usize {
        for j in 0..n.y as usize {
            for k in 0..n.z as usize {
                let lo = bounds.min + Vec3::new(i as f32, j as f32, k as f32) * box_m;
                let b = Aabb::new(lo, lo + Vec3::splat(box_m));
                let reached: Vec<i32> = pvs
                    .clusters_touching(&b)
                    .into_iter()
                    .filter(|&c| wanted(c))
                    .collect();
                if reached.is_empty() {
                    continue;
                }
                let index = out.boxes.len() as u32;
                out.boxes.push(b);
                for c in reached {
                    if let Some(list) = by_cluster.get_mut(c as usize) {
                        list.push(index);
                    }
                }
            }
        }
    }
    for (c, boxes) in by_cluster.into_iter().enumerate() {
        if !boxes.is_empty() {
            out.cells.push(ViewCell {
                name: format!("cluster_{c}"),
                cluster: Some(c as i32),
                boxes,
            });
        }
    }
    out
}

/// The pose that asks for box `b`'s answer: its centre, every direction out to
/// `far`, the viewport and vertical field of view fixing the map's angular cell.
pub fn box_pose(b: &Aabb, viewport: [u32; 2], fov_y_deg: f32, far: f32) -> Pose {
    let c = b.center();
    Pose {
        position: c.to_array(),
        rotation: None,
        look_at: Some((c + Vec3::X).to_array()),
        up: Some([0.0, 1.0, 0.0]),
        fov_y_deg,
        viewport,
        near: NEAR,
        far,
        stereo: None,
        region: Some(WireRegion {
            radius_m: None,
            bounds: Some([b.min.to_array(), b.max.to_array()]),
            turn_deg: None,
            all_directions: true,
        }),
    }
}

/// Each box's answer (ascending object IDs, objects out to `far`) under settings `s` (a method with an
/// occlusion pass or `frustum`; never `exact`), in parallel; `progress(done)` after
/// each box. An error names the first box whose pose is invalid.
pub fn answer_boxes(
    prep: &PreparedScene,
    boxes: &[Aabb],
    viewport: [u32; 2],
    fov_y_deg: f32,
    far: f32,
    s: &CullSettings,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Vec<Vec<u32>>, String> {
    let done = AtomicUsize::new(0);
    boxes
        .par_iter()
        .enumerate()
        .map(|(k, b)| {
            let cam = Camera::new(&box_pose(b, viewport, fov_y_deg, far))
                .map_err(|e| format!("box {k} {:?}..{:?}: {e}", b.min, b.max))?;
            let r = cam.region.expect("a box pose carries its region");
            let visible = region::cull(prep, &cam, &r, s).visible;
            progress(done.fetch_add(1, Ordering::Relaxed) + 1);
            Ok(visible)
        })
        .collect()
}

/// A cell's set: the union of its boxes' answers, ascending.
pub fn cell_set(cell: &ViewCell, answers: &[Vec<u32>]) -> Vec<u32> {
    let mut ids: Vec<u32> = cell
        .boxes
        .iter()
        .filter_map(|&b| answers.get(b as usize))
        .flatten()
        .copied()
        .collect();
    ids.sort_unstable();
    ids.dedup();
    ids
}

/// Ascending IDs as inclusive ranges `[first, last]`: the PVS file's compact form.
pub fn ranges(ids: &[u32]) -> Vec<[u32; 2]> {
    let mut out: Vec<[u32; 2]> = Vec::new();
    for &id in ids {
        match out.last_mut() {
            Some(r) if r[1].checked_add(1) == Some(id) => r[1] = id,
            _ => out.push([id, id]),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_join_runs_and_keep_gaps() {
        assert_eq!(ranges(&[]), Vec::<[u32; 2]>::new());
        assert_eq!(ranges(&[3]), vec![[3, 3]]);
        assert_eq!(ranges(&[0, 1, 2, 5, 7, 8]), vec![[0, 2], [5, 5], [7, 8]]);
        assert_eq!(
            ranges(&[u32::MAX - 1, u32::MAX]),
            vec![[u32::MAX - 1, u32::MAX]]
        );
    }

    #[test]
    fn a_cell_set_is_the_union_of_its_boxes() {
        let cell = ViewCell {
            name: "c".into(),
            cluster: None,
            boxes: vec![0, 2],
        };
        let answers = vec![vec![1, 4], vec![9], vec![2, 4, 6]];
        assert_eq!(cell_set(&cell, &answers), vec![1, 2, 4, 6]);
    }
}
