//! The native backend on the masked map, [`MaskedBackend`]: the conservative test
//! (threshold 1, raster DEB) draws, tests and refines on [`MaskedMap`]; every other
//! setting reads the per-pixel map as [`NativeBackend`] does. Built with the
//! `experimental` cargo feature only: it is tested against the oracle beside the
//! served backend, not served.

use std::cell::RefCell;

use homcull_proto::DebVariant;
use rayon::prelude::*;

use super::MaskedMap;
use crate::camera::{Camera, ScreenRect};
use crate::cull::deb::DEPTH_MARGIN;
use crate::cull::{BoxTest, CullError, CullSettings, Culler, PosePlan, PreparedScene};
use crate::native::map::front_facing;
use crate::native::refine::REFINE_MARGIN;
use crate::native::span::span_triangles;
use crate::native::{NativeBackend, refine_survivors, simd_level};
use crate::scene::Scene;

thread_local! {
    /// Per-thread masked map, kept from pose to pose.
    static MASKED: RefCell<MaskedMap> = RefCell::new(MaskedMap::default());
}

/// The native backend on the masked map (the [`super`] module: a coverage bitmask and two depth
/// bounds per row of a 32×8 tile, per-pixel depth only in the tiles the refinement
/// reads) for the conservative test, the per-pixel map for every other setting. Not
/// the served path: on the shared scenes it culls the same share of hidden objects as
/// [`NativeBackend`] after the refinement, but its box test alone is weaker (a row's
/// bound is the least of a plane over up to 32 pixels), and the refinement of the
/// extra survivors costs what the cheaper draw saves (`cargo run --release --example
/// masked_vs_per_pixel`).
#[derive(Default)]
pub struct MaskedBackend;

impl Culler for MaskedBackend {
    fn name(&self) -> &'static str {
        "cpu"
    }

    fn describe(&self) -> String {
        format!(
            "native CPU, masked map ({}, {} threads)",
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
        Ok(plans
            .par_iter()
            .map(|p| Self::pose_mask_masked(prep, p, s))
            .collect())
    }
}

impl MaskedBackend {
    /// [`NativeBackend::pose_mask`] on the masked map where it answers the
    /// settings (the conservative test: threshold 1, raster DEB), else on the per-pixel
    /// map.
    pub fn pose_mask_masked(prep: &PreparedScene, p: &PosePlan, s: &CullSettings) -> Vec<u32> {
        if !Self::masked_answers(s) {
            return NativeBackend::pose_mask(prep, p, s);
        }
        MASKED.with_borrow_mut(|map| Self::hom_masked(map, prep, p, s))
    }

    /// Whether the masked map answers these settings: the conservative test (threshold
    /// 1, raster DEB) of `hom`. The approximate thresholds, `hzb`, the box DEBs and
    /// `exact` read the per-pixel map.
    fn masked_answers(s: &CullSettings) -> bool {
        s.box_test() == Some(BoxTest::Hom)
            && s.options.threshold >= 1.0
            && s.options.deb == DebVariant::Raster
    }

    /// HOM on the masked map: draw, box test, refinement of the survivors.
    fn hom_masked(
        map: &mut MaskedMap,
        prep: &PreparedScene,
        p: &PosePlan,
        s: &CullSettings,
    ) -> Vec<u32> {
        let scene = &prep.scene;
        map.reset(p.cam.width, p.cam.height);
        map.draw_occluders(scene, &p.cam, &p.occluders.ids);
        let mut mask = masked_box_test(map, prep, p);
        if s.refines() {
            refine_survivors(&mut mask, prep, p, |c| hidden_masked(map, scene, &p.cam, c));
        }
        mask
    }
}

/// The box test on the masked map (threshold 1, raster DEB), compiled per SIMD level.
#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
fn masked_box_test(map: &MaskedMap, prep: &PreparedScene, p: &PosePlan) -> Vec<u32> {
    let hidden = |r: &ScreenRect| map.rect_hidden(r, (1.0 + DEPTH_MARGIN) / r.near);
    multiversion::target::match_target! {
        "x86_64+avx2+fma" => p.box_test_projecting(&prep.scene, |b| p.cam.project_box_avx(b), hidden),
        _ => p.box_test(&prep.scene, hidden),
    }
}

/// [`crate::native::refine::hidden_per_pixel`] on the masked map: a triangle the tiles' bounds show hidden
/// whole needs no more, else its tiles are settled one by one from their bounds and,
/// where those leave it in doubt, from the tile's exact depth
/// ([`MaskedMap::triangle_hidden_per_pixel`]).
#[multiversion::multiversion(targets("x86_64+avx2+fma"))]
pub fn hidden_masked(map: &mut MaskedMap, scene: &Scene, cam: &Camera, id: u32) -> bool {
    let o = &scene.objects[id as usize];
    let margin = REFINE_MARGIN as f64;
    // Front faces first: where an object shows, a front face usually does, and a back
    // face behind its own front faces is proven hidden only per pixel. Every triangle
    // is still tested before the object is called hidden.
    [true, false].into_iter().all(|front| {
        scene
            .corners_of(o)
            .filter(|tri| front_facing(cam.position, tri) == front)
            .all(|tri| {
                span_triangles(cam, tri, |t| {
                    map.triangle_hidden(t, margin) || map.triangle_hidden_per_pixel(t, margin)
                })
            })
    })
}
