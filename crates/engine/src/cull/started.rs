//! Culls started and not yet answered: the seam that lets a caller plan and record one
//! batch while the device still runs the one before.
//!
//! [`Culler::start_cull`] plans the poses and starts the image-space work of each
//! viewport size ([`Culler::start_visibility`]); [`Culler::finish_cull`] waits for
//! that work and answers. A backend that works on the calling thread (the CPU ones)
//! answers inside `start_visibility`; the GPU backend submits and returns, so that
//! between the two calls the host is free while the device runs. Started culls of one
//! backend are finished in the order they were started. [`Culler::cull_preferring`]
//! is the two calls back to back.

use std::time::Instant;

use homcull_proto::CullStats;

use super::{CullError, CullSettings, Culler, PosePlan, PoseResult, PreparedScene};
use crate::camera::Camera;
use crate::occluders::OccluderSelection;

/// The image-space work of one batch, as [`Culler::start_visibility`] left it.
#[derive(Debug)]
pub enum StartedVisibility {
    /// Already answered: one bitmask per pose.
    Answered(Vec<Vec<u32>>),
    /// Submitted to a device and not yet read back; the number identifies the batch to
    /// the backend that started it ([`Culler::finish_visibility`] waits for it).
    InFlight(u64),
}

/// A cull started by [`Culler::start_cull`]: its plans and the batches running on them.
pub struct StartedCull {
    plans: Vec<PosePlan>,
    /// One per run of consecutive poses of the same viewport size.
    batches: Vec<StartedVisibility>,
    started: Instant,
    /// Time spent starting and finishing the image-space work, ms.
    image_ms: f64,
    /// Whether the answers leave out the scene's exact copies (the refined method:
    /// `copies.rs`).
    hides_copies: bool,
    /// The scene version it culls and its moved objects (set by the engine; answers
    /// carry them).
    pub scene_version: u64,
    pub placed: Option<super::Placed>,
    /// Poses answered apart from the plans (region poses, `core::region`): their
    /// place among all the poses, ascending, and their answers.
    answered: Vec<(usize, PoseResult)>,
}

impl StartedCull {
    /// Poses in the cull.
    pub fn poses(&self) -> usize {
        self.plans.len() + self.answered.len()
    }

    /// Adds poses answered apart from the plans: `(place among all the poses of the
    /// cull, answer)`, places ascending; the planned poses fill the other places in
    /// their order.
    pub fn with_answered(mut self, answered: Vec<(usize, PoseResult)>) -> Self {
        self.answered = answered;
        self
    }

    /// Whether some of its work is still on a device.
    pub fn in_flight(&self) -> bool {
        self.batches
            .iter()
            .any(|b| matches!(b, StartedVisibility::InFlight(_)))
    }
}

/// [`Culler::start_cull`]: plans every pose (in parallel: planning is independent per
/// pose) and starts one batch per run of equal viewport sizes.
pub(super) fn start<C: Culler + ?Sized>(
    culler: &mut C,
    prep: &PreparedScene,
    cams: &[Camera],
    s: &CullSettings,
    prefer: &[&[u32]],
) -> Result<StartedCull, CullError> {
    s.validate()?;
    if !s.method.runs_on(culler.name()) {
        return Err(CullError::Unsupported {
            method: s.method.name(),
            backend: culler.name(),
        });
    }
    let started = Instant::now();
    let plans = plan_all(prep, cams, s, prefer);
    tracing::debug!(
        target: "homcull::timing",
        poses = cams.len(),
        plan_ms = started.elapsed().as_secs_f64() * 1e3,
        "planned a batch"
    );
    let mut batches = Vec::new();
    let image = Instant::now();
    let mut i = 0;
    while i < plans.len() {
        let size = (plans[i].cam.width, plans[i].cam.height);
        let j = i + plans[i..]
            .iter()
            .take_while(|p| (p.cam.width, p.cam.height) == size)
            .count();
        batches.push(culler.start_visibility(prep, &plans[i..j], s)?);
        i = j;
    }
    Ok(StartedCull {
        plans,
        batches,
        started,
        image_ms: image.elapsed().as_secs_f64() * 1e3,
        hides_copies: s.refines() && !prep.copies.is_empty(),
        scene_version: 0,
        placed: None,
        answered: Vec::new(),
    })
}

/// Plans every camera (in parallel: planning is independent per camera), choosing
/// the occluders once for each run of consecutive cameras that share a selection
/// camera (a stereo pose's eyes, [`Camera::selection`]): its first camera's
/// preference orders the shared choice.
fn plan_all(
    prep: &PreparedScene,
    cams: &[Camera],
    s: &CullSettings,
    prefer: &[&[u32]],
) -> Vec<PosePlan> {
    use rayon::prelude::*;
    let prefer_of = |k: usize| prefer.get(k).copied().unwrap_or(&[]);
    let shares_previous = |k: usize| k > 0 && cams[k - 1].shares_selection(&cams[k]);
    // The first camera of each run chooses; the others take its choice.
    let leaders: Vec<usize> = (0..cams.len())
        .filter(|&k| cams[k].selection.is_some() && !shares_previous(k))
        .collect();
    let chosen: Vec<OccluderSelection> = leaders
        .par_iter()
        .map(|&k| super::select_occluders(prep, &cams[k], s, prefer_of(k)))
        .collect();
    cams.par_iter()
        .enumerate()
        .map(|(k, c)| {
            if c.selection.is_none() {
                return super::plan_preferring(prep, c, s, prefer_of(k));
            }
            // The run's leader: the last leader at or before k.
            let run = leaders.partition_point(|&l| l <= k) - 1;
            super::plan_with(prep, c, s, chosen[run].clone())
        })
        .collect()
}

/// [`Culler::finish_cull`]: waits for the started batches and answers every pose.
/// `total_ms` in the stats is the time from start to answer per pose, so it includes
/// whatever the caller did in between.
pub(super) fn finish<C: Culler + ?Sized>(
    culler: &mut C,
    prep: &PreparedScene,
    started: StartedCull,
) -> Result<Vec<PoseResult>, CullError> {
    let StartedCull {
        plans,
        batches,
        started,
        mut image_ms,
        hides_copies,
        scene_version,
        placed,
        answered,
    } = started;
    let image = Instant::now();
    let mut masks = Vec::with_capacity(plans.len());
    for batch in batches {
        masks.extend(culler.finish_visibility(batch)?);
    }
    // Every method answers through `start_visibility`, one mask per plan: a missing
    // mask is a backend bug, and answering all candidates would hide it.
    if masks.len() != plans.len() {
        return Err(CullError::Backend {
            backend: culler.name(),
            message: format!("{} masks for {} poses", masks.len(), plans.len()),
        });
    }
    // (`prep` may be a later version than the one planned: its copies are the same
    // pairs or fewer, `Copies::without_moved`, so the answer stays conservative.)
    if hides_copies {
        masks.iter_mut().for_each(|m| prep.copies.hide_in(m));
    }
    image_ms += image.elapsed().as_secs_f64() * 1e3;
    let n = plans.len().max(1) as f64;
    let total_ms = started.elapsed().as_secs_f64() * 1e3 / n;
    let objects = prep.scene.objects.len() as u32;
    let mut planned = plans.into_iter().zip(&masks).map(|(p, m)| {
        let visible: Vec<u32> = p
            .candidates
            .iter()
            .copied()
            .filter(|&c| m[c as usize / 32] >> (c % 32) & 1 == 1)
            .collect();
        let stats = CullStats {
            objects,
            candidates: p.candidates.len() as u32,
            culled_by_frustum: objects - p.candidates.len() as u32,
            culled_by_occlusion: (p.candidates.len() - visible.len()) as u32,
            occluders_used: p.occluders.ids.len() as u32,
            occluder_triangles: p.occluders.triangles,
            gpu_ms: image_ms / n,
            total_ms,
            scene_version,
        };
        PoseResult {
            visible,
            candidates: p.candidates,
            stats,
            placed: placed.clone(),
        }
    });
    // The answered poses take their places; the planned ones fill the rest in order.
    let total = planned.len() + answered.len();
    let mut answered = answered.into_iter().peekable();
    let mut out = Vec::with_capacity(total);
    for k in 0..total {
        let r = match answered.next_if(|(at, _)| *at == k) {
            Some((_, mut r)) => {
                r.stats.scene_version = scene_version;
                r.placed = placed.clone();
                r
            }
            None => match planned.next() {
                Some(r) => r,
                None => break,
            },
        };
        out.push(r);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use homcull_proto::{CullOptions, Pose, Stereo};

    use super::*;
    use crate::camera::stereo;
    use crate::cull::plan_preferring;
    use crate::occluders::OccluderParams;
    use crate::scene::demo_city;

    #[test]
    fn the_eyes_of_a_stereo_pose_share_one_occluder_choice() {
        let prep = PreparedScene::new(demo_city(), OccluderParams::default());
        let s = CullSettings::new(CullOptions::default(), &prep);
        // Eyes at street height outside the city, looking across it from three sides.
        let bounds = prep
            .scene
            .objects
            .iter()
            .fold(prep.scene.objects[0].aabb, |b, o| b.union(o.aabb));
        let (lo, hi, mid) = (bounds.min, bounds.max, bounds.center());
        let poses: Vec<Pose> = [
            [lo.x - 5.0, lo.z - 5.0],
            [hi.x + 5.0, lo.z - 5.0],
            [lo.x - 5.0, hi.z + 5.0],
        ]
        .into_iter()
        .map(|[x, z]| Pose {
            viewport: [320, 180],
            ..Pose::looking_at([x, lo.y + 1.7, z], [mid.x, lo.y + 1.7, mid.z])
        })
        .collect();
        let stereo_of = |k: usize| {
            let mut p = poses[k].clone();
            p.stereo = Some(Stereo {
                ipd_m: 0.064,
                convergence_m: Some(2.0),
            });
            stereo::eyes(&p).unwrap()
        };
        // Two stereo poses, then a mono one.
        let mut cams = stereo_of(0);
        cams.extend(stereo_of(1));
        cams.push(Camera::new(&poses[2]).unwrap());
        let plans = plan_all(&prep, &cams, &s, &[]);
        assert_eq!(plans[0].occluders, plans[1].occluders, "first pair");
        assert_eq!(plans[2].occluders, plans[3].occluders, "second pair");
        assert_ne!(plans[0].occluders, plans[2].occluders, "each pair its own");
        assert_eq!(
            plans[4].occluders,
            plan_preferring(&prep, &cams[4], &s, &[]).occluders,
            "a mono camera chooses in its own frustum"
        );
        for (k, (p, c)) in plans.iter().zip(&cams).enumerate().take(4) {
            // Within the budget, the shared choice holds every occluder the eye's own
            // frustum would choose.
            let own = Camera {
                selection: None,
                ..c.clone()
            };
            let own = plan_preferring(&prep, &own, &s, &[]).occluders;
            assert!(!own.ids.is_empty(), "eye {k} sees occluders");
            assert!(
                own.ids.iter().all(|id| p.occluders.ids.contains(id)),
                "eye {k}: its own occluders are in the shared choice"
            );
            assert_eq!(p.cam, *c, "each eye is planned with its own camera");
        }
    }
}
