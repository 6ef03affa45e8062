//! The seam between callers and backends.
//!
//! A cull takes a batch of cameras (one pose is a batch of one) and answers each with
//! the IDs that may be visible. The CPU-side preparation is the same for every backend
//! ([`plan`]): frustum-cull the scene BVH, pick the in-frustum test boxes, select
//! occluders, build the box-based depth estimation buffer ([`deb`]). A backend
//! ([`Culler`]) then runs the image-space work on the plans and answers with one
//! visibility bitmask per pose ([`mask`]): the GPU one (`core::gpu`) records a whole
//! batch into one submission with one readback; the reference one (`core::hom`) runs
//! the CPU twin of every pass.
//!
//! Nothing here names a backend: settings ([`settings`]), pass times
//! ([`pass_times`]) and errors ([`error`]) are the algorithm's words. Methods:
//! `frustum` (BVH only), `hom`, `hzb`, and `exact` (the ID-buffer oracle that defines
//! ground truth). `hom` with `refine` (the default) re-tests the objects that pass its
//! box test per pixel of their own triangles. What a method asks of the plan is said
//! once, in [`CullSettings`].

pub mod deb;
pub mod error;
pub mod mask;
pub mod pass_times;
pub mod plan;
pub mod prepared;
pub mod settings;

pub use error::CullError;
pub use mask::{clear_bit, empty_mask, has_bit, set_bit, words_per_pose};
pub use pass_times::{Pass, PassMsPerPose, PassTimes};
pub use plan::{PosePlan, plan, plan_preferring};
pub use prepared::PreparedScene;
pub use settings::CullSettings;

use std::time::Instant;

use homcull_proto::CullStats;

use crate::core::camera::Camera;

/// The answer for one pose.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseResult {
    /// Object IDs that may be visible, ascending.
    pub visible: Vec<u32>,
    pub stats: CullStats,
}

/// A backend that runs the image-space part of culling for a batch of poses.
pub trait Culler {
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
        s.validate()?;
        let start = Instant::now();
        // Planning is independent per pose: spread it over the CPU cores.
        let plans: Vec<PosePlan> = {
            use rayon::prelude::*;
            cams.par_iter()
                .enumerate()
                .map(|(k, c)| plan_preferring(prep, c, s, prefer.get(k).copied().unwrap_or(&[])))
                .collect()
        };
        tracing::debug!(
            target: "homcull::timing",
            poses = cams.len(),
            plan_ms = start.elapsed().as_secs_f64() * 1e3,
            "planned a batch"
        );
        let mut masks = Vec::with_capacity(plans.len());
        let mut image_ms = 0.0;
        if s.uses_image() {
            // Batches run per viewport size; consecutive equal sizes share one batch.
            let mut i = 0;
            while i < plans.len() {
                let size = (plans[i].cam.width, plans[i].cam.height);
                let j = i + plans[i..]
                    .iter()
                    .take_while(|p| (p.cam.width, p.cam.height) == size)
                    .count();
                let t = Instant::now();
                masks.extend(self.visibility(prep, &plans[i..j], s)?);
                image_ms += t.elapsed().as_secs_f64() * 1e3;
                i = j;
            }
        }
        let n = cams.len().max(1) as f64;
        let total_ms = start.elapsed().as_secs_f64() * 1e3 / n;
        let objects = prep.scene.objects.len() as u32;
        Ok(plans
            .iter()
            .enumerate()
            .map(|(k, p)| {
                let visible = match masks.get(k) {
                    Some(m) => p
                        .candidates
                        .iter()
                        .copied()
                        .filter(|&c| m[c as usize / 32] >> (c % 32) & 1 == 1)
                        .collect(),
                    None => p.candidates.clone(),
                };
                let stats = CullStats {
                    objects,
                    candidates: p.candidates.len() as u32,
                    culled_by_frustum: objects - p.candidates.len() as u32,
                    culled_by_occlusion: (p.candidates.len() - visible.len()) as u32,
                    occluders_used: p.occluders.ids.len() as u32,
                    occluder_triangles: p.occluders.triangles,
                    gpu_ms: image_ms / n,
                    total_ms,
                };
                PoseResult { visible, stats }
            })
            .collect())
    }
}
