//! The CPU-side preparation of one pose, the same for every backend: frustum-cull the
//! scene BVH, pick the in-frustum test boxes, select occluders, build the box-based
//! depth estimation buffer. A backend then runs the image-space work on the plan.

use super::mask::{empty_mask, has_bit, set_bit, set_bits};
use super::method::CullMethod;
use super::prepared::PreparedScene;
use super::settings::CullSettings;
use crate::camera::{Camera, ScreenRect};
use crate::cull::deb::DepthEstimationBuffer;
use crate::geom::Aabb;
use crate::occluders::OccluderSelection;
use crate::scene::Scene;

/// The CPU-side preparation of one pose.
pub struct PosePlan {
    pub cam: Camera,
    /// In-frustum object IDs, ascending.
    pub candidates: Vec<u32>,
    /// Indices into `scene.boxes` of the in-frustum test boxes of the candidates.
    pub test_boxes: Vec<u32>,
    pub occluders: OccluderSelection,
    pub deb: DepthEstimationBuffer,
}

impl PosePlan {
    /// The visibility bitmask of the box test: an object is visible unless `hidden`
    /// proves each of its in-frustum test boxes' screen rects hidden (a box behind the
    /// near plane shows nothing; an object's remaining boxes are skipped once one is
    /// visible). Every backend's box test is this loop with its own `hidden`.
    #[inline]
    pub fn box_test(&self, scene: &Scene, hidden: impl FnMut(&ScreenRect) -> bool) -> Vec<u32> {
        self.box_test_projecting(scene, |b| self.cam.project_box(b), hidden)
    }

    /// [`PosePlan::box_test`] with the projection given: `project` must answer as
    /// [`Camera::project_box`] does (a SIMD twin of it, chosen by the caller's CPU).
    #[inline(always)]
    pub(crate) fn box_test_projecting(
        &self,
        scene: &Scene,
        mut project: impl FnMut(&Aabb) -> Option<ScreenRect>,
        mut hidden: impl FnMut(&ScreenRect) -> bool,
    ) -> Vec<u32> {
        let mut mask = empty_mask(scene.objects.len());
        for &b in &self.test_boxes {
            let tb = &scene.boxes[b as usize];
            if has_bit(&mask, tb.object) {
                continue; // another sub-bound of this object is already visible
            }
            let Some(r) = project(&tb.aabb) else {
                continue;
            };
            if !hidden(&r) {
                set_bit(&mut mask, tb.object);
            }
        }
        mask
    }
}

/// Frustum culling, test-box selection, occluder selection and box DEB for one pose.
pub fn plan(prep: &PreparedScene, cam: &Camera, s: &CullSettings) -> PosePlan {
    plan_preferring(prep, cam, s, &[])
}

/// [`plan`] whose occluder selection takes the objects in `prefer` (ascending IDs)
/// first ([`crate::occluders::OccluderDb::select_preferring`]).
pub fn plan_preferring(
    prep: &PreparedScene,
    cam: &Camera,
    s: &CullSettings,
    prefer: &[u32],
) -> PosePlan {
    plan_with(prep, cam, s, select_occluders(prep, cam, s, prefer))
}

/// The occluders of `cam`: chosen in its selection camera's frustum where it has one
/// ([`Camera::selection`]), else in its own; none for methods that use none.
pub fn select_occluders(
    prep: &PreparedScene,
    cam: &Camera,
    s: &CullSettings,
    prefer: &[u32],
) -> OccluderSelection {
    if !s.uses_occluders() {
        return OccluderSelection::default();
    }
    let chooser = cam.selection.as_deref().unwrap_or(cam);
    prep.occluders
        .select_preferring(&prep.scene, chooser, s.budget_triangles, prefer)
}

/// [`plan`] with its occluders already chosen (shared by the eyes of a stereo pose).
pub fn plan_with(
    prep: &PreparedScene,
    cam: &Camera,
    s: &CullSettings,
    occluders: OccluderSelection,
) -> PosePlan {
    // Found in tree order, listed ascending through a bit per object.
    let mut found = empty_mask(prep.scene.objects.len());
    prep.bvh.frustum_query(cam, |i| set_bit(&mut found, i));
    let candidates: Vec<u32> = set_bits(&found).collect();
    let mut test_boxes = Vec::new();
    if s.uses_occluders() {
        let planes = cam.frustum_planes();
        for &c in &candidates {
            let (a, b) = prep.scene.box_ranges[c as usize];
            test_boxes
                .extend((a..b).filter(|&i| planes.intersects(&prep.scene.boxes[i as usize].aabb)));
        }
    }
    let deb = DepthEstimationBuffer::build(
        s.deb_variant(),
        s.deb_tile,
        cam,
        occluders
            .ids
            .iter()
            .map(|&i| prep.scene.objects[i as usize].aabb),
    );
    PosePlan {
        cam: cam.clone(),
        candidates,
        test_boxes,
        occluders,
        deb,
    }
}

/// [`CullMethod::mask_from_plan`] for every plan of a batch.
pub fn masks_from_plans(
    method: &dyn CullMethod,
    prep: &PreparedScene,
    plans: &[PosePlan],
) -> Vec<Vec<u32>> {
    plans
        .iter()
        .map(|p| method.mask_from_plan(prep, &p.cam, &p.candidates))
        .collect()
}
