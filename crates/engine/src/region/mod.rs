//! Visibility from a region: answers that hold for every eye in a ball (or box) of
//! eyes and every view direction within a turn of the pose's, at every pixel grid.
//!
//! A union of point answers from sampled eyes is not such an answer (it misses what
//! shows between the samples), and neither is HOM's map with its coverage shrunk and
//! its depth widened: two walls whose silhouettes meet in the centre's image leave a
//! slit that an eye beside the centre sees through, though every pixel near it is
//! covered. The test here is built on one argument instead, from the centre `p` of a
//! ball of radius `r` ([`map`]):
//!
//! Let `D(v)` be the view depth of the first drawn occluder along direction `v` from
//! `p`. Take an eye `q` (|q − p| ≤ r) and a point `z` of a tested box at view depth
//! `ζ`, and follow the segment from `q` to `z`: where its view depth has passed
//! `z_lo`, every point of it lies within `r` of the ray from `p` to `z`, so its
//! direction stays in the box's image dilated by `r·√(1+t²)/z_lo` in tangent units
//! on each axis, `t` the largest tangent of the box's image there (`N`). Suppose, over `N`, that every direction is covered, `D ≥ z_lo > r`, and `D`
//! is continuous; and that `ζ > D` over the box's own image. Then `g = depth − D`
//! along the segment goes from `≤ 0` (at depth `z_lo`) to `> 0` (at `z`) without a
//! jump, so it is `0` somewhere before `z`: the segment meets a drawn occluder
//! triangle, which the exact oracle at `q` draws too (it is in `q`'s view, in front
//! of `z`, beyond its near plane). So no eye of the region sees `z`, whatever it
//! looks at and whatever its pixel grid.
//!
//! `D` can only jump where the first drawn surface ends: at an edge of a drawn
//! triangle that no other drawn triangle facing the same way shares (welded by exact
//! position, `scene::edges`) and no other drawn triangle holds (the edge lies on it,
//! crossing its inside or along its edge on the other side: there the surface goes on
//! without a jump). Those edges, where the map cannot prove them hidden, are
//! drawn into a leak mask; `N` must hold none and every cell of it must be touched.
//! Depth bounds per cell are conservative over the whole cell (not sampled at pixel
//! centres), so the argument holds between samples too.
//!
//! A box region is culled from its centre with the ball that holds it, each bound
//! taken from the box where that is less: on each of a map's axes an eye's offset is
//! at most the box's extent there, so the dilation is `(e_x + t·e_z)/z_lo` (and
//! `z_lo` must pass `e_z`, not `r`) when that is below the ball's. Every
//! direction (`all_directions`, or a turn too wide for one map) takes six maps of a cube,
//! any one of which may prove a box hidden (hiding does not depend on the direction
//! looked in). The per-pixel refinement is not adapted to regions: region answers are
//! the box test's. `exact` takes no region.

mod clip;
pub mod map;
mod raster;
mod spans;
#[cfg(test)]
mod tests;

use std::time::Instant;

use glam::{Mat4, Vec3};
use homcull_proto::CullStats;

pub use crate::camera::Region;
use crate::camera::{Camera, look_at_rh};
use crate::cull::{CullSettings, Passes, PoseResult, PreparedScene, select_occluders};
pub use map::{RegionMap, Verdict};

/// Widest half-angle (degrees) of one planar map; wider views use the cube's six.
/// (A box's dilation grows with the tangents of its own image only, so a wide map
/// costs cells at its borders, not tightness at its centre.)
const MAX_MAP_HALF_DEG: f32 = 75.0;
/// Half-angle (degrees) of each face of the cube: wider than 45° so that a box near a
/// face's border fits in one of them.
const CUBE_FACE_HALF_DEG: f32 = 60.0;
/// Margin around the view in each map, degrees: room for the dilation at its border.
const MAP_MARGIN_DEG: f32 = 3.0;
/// The least cell of a map, degrees at its centre. The answer holds at any cell
/// size (its bounds hold over whole cells), so finer cells buy only tightness: on
/// the street, cells half as wide keep 0–5 % fewer triangles for about 3× the time
/// (docs/algorithm.md).
const MAP_CELL_DEG: f32 = 0.2;
/// Longest side of one map in pixels.
const MAX_MAP_SIDE: u32 = 4096;

/// The answer for `cam`'s region: every candidate (an object in the frustum of some
/// eye of the region, looking some way it allows) that no map proves hidden. Methods
/// without an occlusion pass answer the candidates; `s` must not ask for `exact`.
pub fn cull(prep: &PreparedScene, cam: &Camera, region: &Region, s: &CullSettings) -> PoseResult {
    let started = Instant::now();
    let scene = &prep.scene;
    let occludes = matches!(s.passes(), Some(Passes::Occlusion { .. }));
    let (candidates, visible, occluders_used, occluder_triangles) = if occludes {
        let (judged, maps) = judge(prep, cam, region, s);
        let candidates = judged.iter().map(|&(id, _)| id).collect();
        let visible = judged
            .iter()
            .filter(|(_, v)| v.is_some())
            .map(|&(id, _)| id)
            .collect();
        let used = maps.iter().map(|m| m.occluders).max().unwrap_or(0);
        let tris = maps.iter().map(|m| m.triangles).max().unwrap_or(0);
        (candidates, visible, used, tris)
    } else {
        let (candidates, _) = candidates(prep, cam, region);
        (candidates.clone(), candidates, 0, 0)
    };
    let objects = scene.objects.len() as u32;
    let ms = started.elapsed().as_secs_f64() * 1e3;
    PoseResult {
        stats: CullStats {
            objects,
            candidates: candidates.len() as u32,
            culled_by_frustum: objects - candidates.len() as u32,
            culled_by_occlusion: (candidates.len() - visible.len()) as u32,
            occluders_used,
            occluder_triangles,
            gpu_ms: ms,
            total_ms: ms,
            scene_version: 0,
        },
        visible,
        candidates,
        placed: None,
    }
}

/// Each candidate of `cam`'s region with why the maps keep it (`None`: they hide
/// it), for diagnostics: what a tighter map would have to change. `s` must ask for
/// an occlusion pass.
pub fn explain(
    prep: &PreparedScene,
    cam: &Camera,
    region: &Region,
    s: &CullSettings,
) -> Vec<(u32, Option<Verdict>)> {
    judge(prep, cam, region, s).0
}

/// Every candidate with its verdict, and the maps that gave them: what [`cull`] and
/// [`explain`] share, so that the diagnostic explains the answer served.
fn judge(
    prep: &PreparedScene,
    cam: &Camera,
    region: &Region,
    s: &CullSettings,
) -> (Vec<(u32, Option<Verdict>)>, Vec<RegionMap>) {
    let (candidates, union) = candidates(prep, cam, region);
    let maps = draw_maps(prep, cam, region, s);
    let judged = candidates
        .into_iter()
        .map(|id| (id, why_kept(prep, &maps, union.as_ref(), id)))
        .collect();
    (judged, maps)
}

/// The maps of the region, each with the occluders chosen for it (public for the
/// region test's images of them).
pub fn draw_maps(
    prep: &PreparedScene,
    cam: &Camera,
    region: &Region,
    s: &CullSettings,
) -> Vec<RegionMap> {
    // The largest angle between an eye's axis and a ray it sees.
    let (tx, ty) = half_tangents(cam);
    let off_axis = tx.hypot(ty).atan() + region.turn;
    let mut maps = Vec::new();
    for m in map_cameras(cam, region) {
        let chosen = select_occluders(prep, &m, s, &[]);
        maps.push(RegionMap::draw(prep, &m, region, off_axis, &chosen.ids));
        if !region.all_directions {
            continue;
        }
        let large: Vec<u32> = chosen
            .ids
            .iter()
            .copied()
            .filter(|&id| prep.scene.objects[id as usize].aabb.diagonal() >= LARGE_OCCLUDER_M)
            .collect();
        if !large.is_empty() && large.len() < chosen.ids.len() {
            maps.push(RegionMap::draw(prep, &m, region, off_axis, &large));
        }
    }
    maps
}

/// The six faces of a cube map: each face's view direction and up.
pub const CUBE_FACES: [(Vec3, Vec3); 6] = [
    (Vec3::X, Vec3::Y),
    (Vec3::NEG_X, Vec3::Y),
    (Vec3::Y, Vec3::Z),
    (Vec3::NEG_Y, Vec3::Z),
    (Vec3::Z, Vec3::Y),
    (Vec3::NEG_Z, Vec3::Y),
];

/// Objects at least this large (box diagonal, metres) are drawn again into a second
/// map without the small ones: a box behind a wall whose image a tree's silhouette
/// crosses is proven hidden by the wall alone. Only for regions of every direction
/// (view cells, offline): it halves a region's speed, and on the demo city keeps a
/// fifth fewer objects per cell, but 12 % fewer triangles for turn-limited regions
/// and none on the other shared scenes (docs/experiments.md).
const LARGE_OCCLUDER_M: f32 = 10.0;

/// Why object `id` is kept: the furthest verdict any map gives its first box that no
/// map hides; `None` when every box in view is hidden by some map. A box outside
/// every eye's frustum (`union`) shows nothing.
fn why_kept(
    prep: &PreparedScene,
    maps: &[RegionMap],
    union: Option<&Camera>,
    id: u32,
) -> Option<Verdict> {
    prep.scene
        .boxes_of(id)
        .iter()
        .filter(|b| union.is_none_or(|u| u.intersects(&b.aabb)))
        .find_map(|b| {
            let verdicts = maps.iter().map(|m| m.judge(&b.aabb));
            let mut furthest = None;
            for v in verdicts {
                if v == Verdict::Hidden {
                    return None;
                }
                furthest = furthest.max(Some(v));
            }
            Some(furthest.unwrap_or(Verdict::Near))
        })
}

/// Tangents of the camera's half-angles: `(horizontal, vertical)`, the horizontal one
/// taking an off-axis shift's wider side.
fn half_tangents(cam: &Camera) -> (f32, f32) {
    ((1.0 + cam.shift.abs()) / cam.scale[0], 1.0 / cam.scale[1])
}

/// Objects that some eye of the region may have in view, ascending, and the frustum
/// that holds every eye's where there is one: a square pyramid whose half-angle is the
/// pose's half-diagonal plus the turn, its apex set back so that each side plane
/// clears the ball. Without one (every direction, or a turn too wide), the objects
/// within the far distance of the ball.
fn candidates(prep: &PreparedScene, cam: &Camera, region: &Region) -> (Vec<u32>, Option<Camera>) {
    let (tx, ty) = half_tangents(cam);
    let half = (tx.hypot(ty)).atan() + region.turn;
    let reach = cam.far + region.radius;
    let ids = prep.scene.objects.iter().map(|o| o.id);
    if region.all_directions || half >= 80f32.to_radians() {
        let near_ball = |id: &u32| {
            let b = &prep.scene.objects[*id as usize].aabb;
            !b.is_empty() && b.min.max(b.max.min(region.centre)).distance(region.centre) <= reach
        };
        return (ids.filter(near_ball).collect(), None);
    }
    let (forward, up) = (cam.forward(), cam.up());
    let back = region.radius / half.sin();
    let apex = region.centre - forward * back;
    let union = Camera::from_view(
        apex,
        look_at_rh(apex, apex + forward, up),
        2.0 * half.to_degrees(),
        1,
        1,
        1e-3,
        reach + back,
    );
    let mut found = Vec::new();
    prep.bvh.frustum_query(&union, |i| found.push(i));
    found.sort_unstable();
    (found, Some(union))
}

/// What a region map's pixel counts for beside a point pose's in a request's work
/// budget. A region map is drawn with whole-cell bounds, edges and summed-area tables
/// in scalar code, tens of times a point pixel's time on the native backend (a street
/// region of 0.5 m turning 10° at 960×540: about 40 ms on one core, against under a
/// millisecond for the point pose); 16 keeps one every-direction region at 960×540
/// within the default budget.
pub const WORK_PER_MAP_PIXEL: u64 = 16;

/// The work a camera asks for, in point-pose pixels: its viewport, or for a region
/// camera the pixels of its maps times [`WORK_PER_MAP_PIXEL`]. What a request's work
/// budget counts, so that region poses cannot hold the cull worker for long.
pub fn pixels(cam: &Camera) -> u64 {
    match &cam.region {
        Some(r) => map_cameras(cam, r)
            .iter()
            .map(|m| m.width as u64 * m.height as u64 * WORK_PER_MAP_PIXEL)
            .sum(),
        None => cam.width as u64 * cam.height as u64,
    }
}

/// The cameras of the maps drawn from the region's centre: one with the pose's view
/// widened by the turn and a margin, at the pose's pixel size or [`MAP_CELL_DEG`], or the six faces of a
/// cube (each 120° wide, so that boxes near a face's border fit in one of them).
pub fn map_cameras(cam: &Camera, region: &Region) -> Vec<Camera> {
    let (tx, ty) = half_tangents(cam);
    // The map's cell in tangent units at the centre of its view: the pose's pixel,
    // or the least cell, whichever is larger.
    let pixel = (2.0 * ty / cam.height as f32).max(MAP_CELL_DEG.to_radians());
    let widen = region.turn + MAP_MARGIN_DEG.to_radians();
    let (hx, hy) = (tx.atan() + widen, ty.atan() + widen);
    let limit = MAX_MAP_HALF_DEG.to_radians();
    let centre = region.centre;
    let sized = |half: f32| ((2.0 * half.tan() / pixel).ceil() as u32).clamp(1, MAX_MAP_SIDE);
    let camera = |view: Mat4, hx: f32, hy: f32| {
        Camera::from_view(
            centre,
            view,
            2.0 * hy.to_degrees(),
            sized(hx),
            sized(hy),
            cam.near,
            cam.far,
        )
    };
    if !region.all_directions && hx <= limit && hy <= limit {
        let (forward, up) = (cam.forward(), cam.up());
        return vec![camera(look_at_rh(centre, centre + forward, up), hx, hy)];
    }
    CUBE_FACES
        .iter()
        .map(|&(f, up)| {
            let half = CUBE_FACE_HALF_DEG.to_radians();
            camera(look_at_rh(centre, centre + f, up), half, half)
        })
        .collect()
}
