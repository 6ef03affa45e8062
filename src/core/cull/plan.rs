//! The CPU-side preparation of one pose, the same for every backend: frustum-cull the
//! scene BVH, pick the in-frustum test boxes, select occluders, build the box-based
//! depth estimation buffer. A backend then runs the image-space work on the plan.

use super::prepared::PreparedScene;
use super::settings::CullSettings;
use crate::core::camera::Camera;
use crate::core::cull::deb::DepthEstimationBuffer;
use crate::core::occluders::OccluderSelection;

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

/// Frustum culling, test-box selection, occluder selection and box DEB for one pose.
pub fn plan(prep: &PreparedScene, cam: &Camera, s: &CullSettings) -> PosePlan {
    plan_preferring(prep, cam, s, &[])
}

/// [`plan`] whose occluder selection takes the objects in `prefer` (ascending IDs)
/// first ([`crate::core::occluders::OccluderDb::select_preferring`]).
pub fn plan_preferring(
    prep: &PreparedScene,
    cam: &Camera,
    s: &CullSettings,
    prefer: &[u32],
) -> PosePlan {
    let mut candidates = Vec::new();
    prep.bvh.frustum_query(cam, |i| candidates.push(i));
    candidates.sort_unstable();
    let mut test_boxes = Vec::new();
    let mut occluders = OccluderSelection::default();
    if s.uses_occluders() {
        for &c in &candidates {
            let (a, b) = prep.scene.box_ranges[c as usize];
            test_boxes
                .extend((a..b).filter(|&i| cam.intersects(&prep.scene.boxes[i as usize].aabb)));
        }
        occluders = prep
            .occluders
            .select_preferring(&prep.scene, cam, s.budget_triangles, prefer);
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
