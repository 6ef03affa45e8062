//! The native CPU backend: HOM as a span rasterizer and a tile-bounds pyramid, fast
//! enough to serve from the CPU cores alone.
//!
//! Per pose ([`NativeBackend::pose_mask`]): the selected occluders are drawn into an
//! occlusion map of the nearest `1/w` per pixel ([`map`]), in exact spans per row
//! ([`span`], four rows' span ends at a time), band by band, each band bounded per
//! 8×8 tile as it is finished and the bounds carried up a quadtree; each in-frustum
//! test box's screen rect is tested against it, and the objects whose boxes survive
//! are re-tested per pixel of their own triangles ([`refine`]), a triangle at a time
//! once the tile bounds cannot show it hidden whole. `exact` is the same spans into
//! an ID buffer. The poses of a batch run in parallel on rayon's pool (`--threads`),
//! each on a map kept per thread; a batch of fewer poses than threads (one client's
//! pose on an idle server) also splits each large pose's draw by bands of rows.
//!
//! Where the work is skipped, the answer is unchanged: an occluder or a triangle is
//! left out of the draw only when the bounds show every fragment of it losing to the
//! pixel it would fall on (the map is the per-pixel maximum, so the final map is bit
//! for bit the full draw's, tested), and the refinement passes a triangle without
//! its spans only when the bounds lie in front of its nearest vertex's `1/w`, the
//! largest any of its fragments has, by the margin.
//!
//! Why it never culls what the oracle sees:
//! 1. Coverage is the exact oracle's own: [`span::SpanTriangle::row`] accepts exactly
//!    the pixel centres that the reference rasterizer's f64 edge functions and
//!    top-left rule accept (the CPU oracle twin, `reference::oracle`), shown in its tests on
//!    random triangles. Occluders are objects' own triangles, so a covered pixel of the map
//!    is a pixel the oracle covers with one of those triangles.
//! 2. The box test culls a box only if every pixel of its screen rect holds an
//!    occluder nearer than the box's nearest depth by the margin
//!    (`cull::deb::in_front`): the per-pixel statement of HOM's conservative test at
//!    opacity 1, answered exactly by the tile bounds ([`map::OcclusionMap::rect_hidden`]).
//! 3. The refinement culls an object only if each of its fragments lies behind the
//!    map by the margin. The oracle gives a pixel to an object only if none of the
//!    fragments there is nearer, and the map holds a subset of those fragments, so a
//!    pixel the oracle gives to the object fails the comparison unless depths differ
//!    between the two computations by more than the margin (1e-5 relative); both
//!    interpolate `1/w` from the same f64 setup, within ~1e-6. A fragment closer to
//!    the map than that (a near tie: where an object meets a surface just in front of
//!    it) is decided in f64: hidden only if a drawn occluder triangle covers the pixel
//!    (the oracle's coverage) with its f64 plane in front by 1e-6, a gap no oracle's
//!    single rounding to f32 closes (`refine::RESOLVE_MARGIN`).
//! 4. Objects that are exact copies of earlier objects (`cull::copies`) are left out
//!    of refined answers by the caller: the oracle gives their every pixel to the
//!    earlier copy.
//!
//! What it does not do natively: approximate thresholds (below 1.0) and the `hzb`
//! baseline, which need the averaged opacity pyramid; those build the reference
//! pyramid from this backend's map and use the reference's test, so they are correct
//! and as slow as the reference's test. The CPU reference (`core::reference`) stays the
//! test oracle of every pass here.

mod descent;
pub mod map;
#[cfg(feature = "experimental")]
pub mod masked;
pub mod refine;
pub mod span;
#[cfg(test)]
mod test_triangles;

use std::cell::RefCell;

use homcull_proto::DebVariant;
use rayon::prelude::*;

use crate::camera::ScreenRect;
use crate::cull::deb::DEPTH_MARGIN;
use crate::cull::{
    BoxTest, CullError, CullSettings, Culler, Passes, PosePlan, PreparedScene, clear_bit, has_bit,
};
use crate::reference::{ReferenceBackend, pyramid};
use map::OcclusionMap;
use refine::IdBuffer;

/// Per-thread buffers, kept from pose to pose (a 960×540 map is 2 MB).
#[derive(Default)]
struct Scratch {
    map: OcclusionMap,
    ids: IdBuffer,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// Viewports from this size up draw one pose's bands in parallel when the batch leaves
/// threads idle. Smaller maps gain nothing: on a 2-core VM, one pose on two threads
/// (refined, four scenes) took 0.98–1.17× the time of the unsplit pose at 960×540 (the
/// map's cache lines move between the cores that clear, draw and test it; munich:
/// 0.94× at 1920×1080, 0.49× at 3840×2160).
const SPLIT_MIN_PIXELS: u64 = 1920 * 1080;

/// The native CPU backend.
#[derive(Default)]
pub struct NativeBackend;

/// The widest SIMD this CPU runs the span kernels with.
pub fn simd_level() -> &'static str {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        return "AVX2";
    }
    #[cfg(target_arch = "aarch64")]
    return "NEON";
    #[allow(unreachable_code)]
    "SSE2"
}

impl NativeBackend {
    /// The visibility bitmask of one planned pose.
    pub fn pose_mask(prep: &PreparedScene, p: &PosePlan, s: &CullSettings) -> Vec<u32> {
        Self::pose_mask_split(prep, p, s, false)
    }

    /// [`NativeBackend::pose_mask`], drawing the map's bands in parallel on rayon's
    /// pool with `split` (for a pose with cores to spare: a batch smaller than the
    /// pool).
    pub fn pose_mask_split(
        prep: &PreparedScene,
        p: &PosePlan,
        s: &CullSettings,
        split: bool,
    ) -> Vec<u32> {
        SCRATCH.with_borrow_mut(|sc| match s.passes() {
            None => s.method.mask_from_plan(prep, &p.cam, &p.candidates),
            Some(Passes::Exact) => refine::exact(&mut sc.ids, &prep.scene, &p.cam, &p.candidates),
            Some(Passes::Occlusion { test, refine }) => {
                Self::occlusion(&mut sc.map, prep, p, s, test, refine, split)
            }
        })
    }

    /// The occlusion passes: draw, box test `test`, and the refinement with `refine`.
    fn occlusion(
        map: &mut OcclusionMap,
        prep: &PreparedScene,
        p: &PosePlan,
        s: &CullSettings,
        test: BoxTest,
        refine: bool,
        split: bool,
    ) -> Vec<u32> {
        let scene = &prep.scene;
        map.reset(p.cam.width, p.cam.height);
        map.bands_in_parallel = split;
        // Drawing leaves the map bounded: the box test and the refinement read them.
        map.draw_occluders(scene, &p.cam, &p.occluders.ids);
        let mut mask = match test {
            BoxTest::Hom if s.options.threshold >= 1.0 => Self::test_boxes(map, prep, p, s),
            BoxTest::Hom | BoxTest::Hzb => Self::reference_test(map, p, s, prep),
        };
        if refine {
            refine_survivors(&mut mask, prep, p, |c| {
                refine::hidden_per_pixel(map, scene, &p.cam, c)
            });
        }
        mask
    }

    /// The conservative box test (threshold 1) on the map's tile bounds.
    pub fn test_boxes(
        map: &OcclusionMap,
        prep: &PreparedScene,
        p: &PosePlan,
        s: &CullSettings,
    ) -> Vec<u32> {
        box_test(map, prep, p, s.options.deb == DebVariant::Raster)
    }

    /// Approximate thresholds and HZB: the reference pyramid and test on this map.
    fn reference_test(
        map: &OcclusionMap,
        p: &PosePlan,
        s: &CullSettings,
        prep: &PreparedScene,
    ) -> Vec<u32> {
        let depth: Vec<f32> = map
            .pixels()
            .iter()
            .map(|&v| if v > 0.0 { 1.0 / v } else { 0.0 })
            .collect();
        let layout = pyramid::LevelLayout::new(p.cam.width, p.cam.height);
        let (opacity, depth) = pyramid::build(&layout, &depth);
        ReferenceBackend::test_boxes(&prep.scene, p, s, &layout, &opacity, &depth)
    }
}

/// Clears from `mask` each candidate of `p` that survived the box test and `hidden`
/// proves hidden per pixel. A moving object is left as the box test answered: its
/// boxes bound its motion, its triangles do not.
pub(crate) fn refine_survivors(
    mask: &mut [u32],
    prep: &PreparedScene,
    p: &PosePlan,
    mut hidden: impl FnMut(u32) -> bool,
) {
    for &c in &p.candidates {
        if has_bit(mask, c) && !prep.is_moving(c) && hidden(c) {
            clear_bit(mask, c);
        }
    }
}

/// [`NativeBackend::test_boxes`], compiled per SIMD level; its AVX2 clone projects the
/// boxes in AVX lanes ([`crate::camera::Camera::project_box_avx`]: the same rects).
#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
fn box_test(map: &OcclusionMap, prep: &PreparedScene, p: &PosePlan, raster: bool) -> Vec<u32> {
    let hidden = |r: &ScreenRect| {
        if raster {
            map.rect_hidden(r, (1.0 + DEPTH_MARGIN) / r.near)
        } else {
            p.deb.all_in_front(r, r.near) && map.rect_hidden(r, 0.0)
        }
    };
    multiversion::target::match_target! {
        "x86_64+avx2+fma" => p.box_test_projecting(&prep.scene, |b| p.cam.project_box_avx(b), hidden),
        _ => p.box_test(&prep.scene, hidden),
    }
}

impl Culler for NativeBackend {
    fn name(&self) -> &'static str {
        "cpu"
    }

    fn describe(&self) -> String {
        format!(
            "native CPU ({}, {} threads)",
            simd_level(),
            rayon::current_num_threads()
        )
    }

    fn visibility(
        &mut self,
        prep: &PreparedScene,
        plans: &[PosePlan],
        s: &CullSettings,
    ) -> Result<Vec<Vec<u32>>, CullError> {
        // Fewer poses than threads: each large pose's draw splits into bands too.
        let spare = plans.len() < rayon::current_num_threads();
        Ok(plans
            .par_iter()
            .map(|p| {
                let large = p.cam.width as u64 * p.cam.height as u64 >= SPLIT_MIN_PIXELS;
                Self::pose_mask_split(prep, p, s, spare && large)
            })
            .collect())
    }
}
