//! The seam between callers and backends.
//!
//! A cull takes a batch of cameras (one pose is a batch of one) and answers each with
//! the IDs that may be visible. The CPU-side preparation is the same for every backend
//! ([`plan`]): frustum-cull the scene BVH, pick the in-frustum test boxes, select
//! occluders, build the box-based depth estimation buffer ([`deb`]). A backend
//! ([`Culler`]) then runs the image-space work on the plans and answers with one
//! visibility bitmask per pose ([`mask`]): the GPU one (`core::gpu`) records a whole
//! batch into one submission with one readback; the reference one (`core::reference`) runs
//! the CPU twin of every pass.
//!
//! Nothing here names a backend: settings ([`settings`]), pass times
//! ([`pass_times`]) and errors ([`error`]) are the algorithm's words. Each method is
//! one type behind [`CullMethod`] ([`method`]): `frustum` (BVH only), `hom`, `hzb`,
//! and `exact` (the ID-buffer oracle that defines ground truth); it says what the plan
//! prepares for it and which passes ([`Passes`]) the backends run. `hom` with `refine`
//! (the default) re-tests the objects that pass its box test per pixel of their own
//! triangles.

pub mod copies;
pub mod deb;
pub mod error;
pub mod holders;
pub mod mask;
pub mod method;
mod methods;
pub mod pass_times;
pub mod plan;
pub mod prepared;
pub mod settings;
pub mod started;

pub use error::CullError;
pub use mask::{clear_bit, empty_mask, has_bit, set_bit, union, words_per_pose};
pub use method::{BoxTest, CullMethod, Needs, Passes};
pub use methods::{Exact, Frustum, Hom, Hzb};
pub use pass_times::{Pass, PassMsPerPose, PassTimes};
pub use plan::{PosePlan, plan, plan_preferring, plan_with, select_occluders};
pub use prepared::PreparedScene;
pub use settings::CullSettings;
pub use started::{StartedCull, StartedVisibility};

use homcull_proto::CullStats;

use crate::camera::Camera;

/// The answer for one pose.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseResult {
    /// Object IDs that may be visible, ascending.
    pub visible: Vec<u32>,
    /// The in-frustum objects it was chosen from, ascending.
    pub candidates: Vec<u32>,
    pub stats: CullStats,
    /// Where the moved objects of the scene version it ran on are: `(object,
    /// column-major 4×4 matrix relative to the loaded scene)`, ascending; `None` when
    /// nothing of the scene moved (see `core::dynamic`).
    pub placed: Option<Placed>,
}

/// The placements of a scene version's moved objects (see [`PoseResult::placed`]).
pub type Placed = std::sync::Arc<[(u32, [f32; 16])]>;

impl PoseResult {
    /// One answer for several views of one pose (the eyes of a stereo pose): every
    /// object any of them may see, from every object in any of their frusta. Times add
    /// up; occluder counts are the largest view's.
    pub fn union_of(results: Vec<PoseResult>) -> Option<PoseResult> {
        results.into_iter().reduce(|mut a, b| {
            a.visible = union(&a.visible, &b.visible);
            a.candidates = union(&a.candidates, &b.candidates);
            let (s, t) = (&mut a.stats, &b.stats);
            s.candidates = a.candidates.len() as u32;
            s.culled_by_frustum = s.objects - s.candidates;
            s.culled_by_occlusion = s.candidates - a.visible.len() as u32;
            s.occluders_used = s.occluders_used.max(t.occluders_used);
            s.occluder_triangles = s.occluder_triangles.max(t.occluder_triangles);
            s.gpu_ms += t.gpu_ms;
            s.total_ms += t.total_ms;
            a
        })
    }
}

/// A backend that runs the image-space part of culling for a batch of poses.
pub trait Culler {
    /// The backend's short name (`gpu`, `cpu`, `reference`), as
    /// [`CullMethod::runs_on`] and `/readyz` name it.
    fn name(&self) -> &'static str;

    /// Adapter or implementation name, for reports.
    fn describe(&self) -> String;

    /// Visibility bitmasks (`words_per_pose(objects)` words per pose) of a batch of
    /// planned poses sharing one viewport size.
    fn visibility(
        &mut self,
        prep: &PreparedScene,
        plans: &[PosePlan],
        s: &CullSettings,
    ) -> Result<Vec<Vec<u32>>, CullError>;

    /// Starts measuring GPU time per pass (`on`) or stops; false where this backend
    /// cannot (the CPU reference, adapters without timestamp queries).
    fn set_profiling(&mut self, _on: bool) -> bool {
        false
    }

    /// GPU time per pass since profiling started or the times were last taken.
    fn take_pass_times(&mut self) -> Option<PassTimes> {
        None
    }

    /// The scene moved (`core::dynamic`): `prep` is its new version, in which the
    /// objects `changed` were placed anew, each by its matrix applied to its loaded
    /// vertices (identity: back as loaded; same objects, triangles and test-box count;
    /// other positions and boxes, and possibly other moving objects). A backend that
    /// keeps a copy of the scene updates it here; culls started before keep the
    /// version they started with.
    fn scene_changed(&mut self, _prep: &PreparedScene, _changed: &[(u32, glam::Mat4)]) {}

    /// Culls a batch of cameras with the chosen method.
    fn cull(
        &mut self,
        prep: &PreparedScene,
        cams: &[Camera],
        s: &CullSettings,
    ) -> Result<Vec<PoseResult>, CullError> {
        self.cull_preferring(prep, cams, s, &[])
    }

    /// [`Culler::cull`] where pose k's occluder selection takes the objects of
    /// `prefer[k]` first (ascending IDs, e.g. what the same client saw at its previous
    /// pose; see [`plan_preferring`]). Poses past the end of `prefer` prefer nothing.
    fn cull_preferring(
        &mut self,
        prep: &PreparedScene,
        cams: &[Camera],
        s: &CullSettings,
        prefer: &[&[u32]],
    ) -> Result<Vec<PoseResult>, CullError> {
        let started = self.start_cull(prep, cams, s, prefer)?;
        self.finish_cull(prep, started)
    }

    /// Starts the image-space work of a batch of plans (one viewport size) without
    /// waiting for it where the backend can ([`started`]); the default answers at once.
    fn start_visibility(
        &mut self,
        prep: &PreparedScene,
        plans: &[PosePlan],
        s: &CullSettings,
    ) -> Result<StartedVisibility, CullError> {
        Ok(StartedVisibility::Answered(
            self.visibility(prep, plans, s)?,
        ))
    }

    /// The bitmasks of a batch this backend started, waiting for them if needed.
    fn finish_visibility(
        &mut self,
        started: StartedVisibility,
    ) -> Result<Vec<Vec<u32>>, CullError> {
        match started {
            StartedVisibility::Answered(masks) => Ok(masks),
            StartedVisibility::InFlight(batch) => Err(CullError::Backend {
                backend: "culler",
                message: format!("batch {batch} was not started by this backend"),
            }),
        }
    }

    /// Plans `cams` and starts their image-space work ([`started`]): the first half of
    /// [`Culler::cull_preferring`]. Finish started culls in the order they started.
    fn start_cull(
        &mut self,
        prep: &PreparedScene,
        cams: &[Camera],
        s: &CullSettings,
        prefer: &[&[u32]],
    ) -> Result<StartedCull, CullError> {
        started::start(self, prep, cams, s, prefer)
    }

    /// Waits for a cull [`Culler::start_cull`] started and answers each pose.
    fn finish_cull(
        &mut self,
        prep: &PreparedScene,
        started: StartedCull,
    ) -> Result<Vec<PoseResult>, CullError> {
        started::finish(self, prep, started)
    }
}
