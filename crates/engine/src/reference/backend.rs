//! [`ReferenceBackend`]: the CPU reference of every pass behind the [`Culler`] seam.
//! Slow and simple on purpose: it is the test oracle of the GPU passes, and the
//! fallback when no adapter exists.

use homcull_proto::Method;

use super::pyramid::{self, LevelLayout};
use super::raster::raster_depth;
use super::test::{PyramidView, hom_occluded, hzb_occluded};
use super::{level_thresholds, oracle, refine, triangles_of};
use crate::cull::{CullError, CullSettings, Culler, PosePlan, PreparedScene};
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

    /// Visibility bitmask of the per-object test on a given pyramid.
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
        p.box_test(scene, |r| match s.options.method {
            Method::Hzb => hzb_occluded(r, &view),
            // Only the occluder methods reach the box test.
            Method::Hom | Method::Frustum | Method::Exact => {
                hom_occluded(r, &view, &thr, s.options.deb, &p.deb)
            }
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
        Ok(plans
            .iter()
            .map(|p| match s.options.method {
                Method::Exact => oracle::exact(scene, p),
                Method::Hom | Method::Hzb | Method::Frustum => {
                    let layout = LevelLayout::new(p.cam.width, p.cam.height);
                    let occluders = Self::occluder_depth(scene, p);
                    let (opacity, depth) = pyramid::build(&layout, &occluders);
                    let mut mask = Self::test_boxes(scene, p, s, &layout, &opacity, &depth);
                    if s.refines() {
                        refine::refine(prep, p, &occluders, &mut mask);
                    }
                    mask
                }
            })
            .collect())
    }
}
