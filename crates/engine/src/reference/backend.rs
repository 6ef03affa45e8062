//! [`ReferenceBackend`]: the CPU reference of every pass behind the [`Culler`] seam.
//! Slow and simple on purpose: it is the test oracle of the GPU passes, and the
//! fallback when no adapter exists.

use super::pyramid::{self, LevelLayout};
use super::raster::raster_depth;
use super::test::{PyramidView, hom_occluded, hzb_occluded};
use super::{level_thresholds, oracle, refine, triangles_of};
use crate::cull::plan::masks_from_plans;
use crate::cull::{BoxTest, CullError, CullSettings, Culler, Passes, PosePlan, PreparedScene};
use crate::scene::Scene;

/// The CPU reference of every pass.
#[derive(Default)]
pub struct ReferenceBackend;

impl ReferenceBackend {
    /// Level-0 occluder depth map of one pose (0 = uncovered).
    pub fn occluder_depth(scene: &Scene, p: &PosePlan) -> Vec<f32> {
        let mut depth = vec![0.0; (p.cam.width * p.cam.height) as usize];
        raster_depth(
            &p.cam,
            triangles_of(scene, &p.occluders.ids).map(|(_, t)| t),
            &mut depth,
        );
        depth
    }

    /// Visibility bitmask of the method's box test on a given pyramid (a plan of a
    /// method without one has no test boxes: every box is visible).
    pub fn test_boxes(
        scene: &Scene,
        p: &PosePlan,
        s: &CullSettings,
        layout: &LevelLayout,
        opacity: &[f32],
        depth: &[f32],
    ) -> Vec<u32> {
        let view = PyramidView {
            layout,
            opacity,
            depth,
        };
        let thr = level_thresholds(s.options.threshold, layout.levels());
        let test = s.box_test().unwrap_or(BoxTest::Hom);
        p.box_test(scene, |r| match test {
            BoxTest::Hzb => hzb_occluded(r, &view),
            BoxTest::Hom => hom_occluded(r, &view, &thr, s.options.deb, &p.deb),
        })
    }

    /// See [`refine::refine`].
    pub fn refine(prep: &PreparedScene, p: &PosePlan, occluders: &[f32], mask: &mut [u32]) {
        refine::refine(prep, p, occluders, mask)
    }

    /// See [`oracle::exact`].
    pub fn exact(scene: &Scene, p: &PosePlan) -> Vec<u32> {
        oracle::exact(scene, p)
    }
}

impl Culler for ReferenceBackend {
    fn name(&self) -> &'static str {
        "reference"
    }

    fn describe(&self) -> String {
        "CPU reference (no GPU)".into()
    }

    fn visibility(
        &mut self,
        prep: &PreparedScene,
        plans: &[PosePlan],
        s: &CullSettings,
    ) -> Result<Vec<Vec<u32>>, CullError> {
        let scene = &prep.scene;
        let occlusion = |p: &PosePlan, refine: bool| {
            let layout = LevelLayout::new(p.cam.width, p.cam.height);
            let occluders = Self::occluder_depth(scene, p);
            let (opacity, depth) = pyramid::build(&layout, &occluders);
            let mut mask = Self::test_boxes(scene, p, s, &layout, &opacity, &depth);
            if refine {
                refine::refine(prep, p, &occluders, &mut mask);
            }
            mask
        };
        Ok(match s.passes() {
            None => masks_from_plans(s.method, prep, plans),
            Some(Passes::Exact) => plans.iter().map(|p| oracle::exact(scene, p)).collect(),
            // (`test_boxes` reads the box test from `s` itself.)
            Some(Passes::Occlusion { test: _, refine }) => {
                plans.iter().map(|p| occlusion(p, refine)).collect()
            }
        })
    }
}
