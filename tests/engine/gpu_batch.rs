//! The GPU batch's structure, counted through `GpuDevice::counts` (every buffer, bind
//! group, pass and submission goes through it; `tests/repo/architecture.rs` keeps it so):
//! a batch of any size up to one atlas records the same passes and one submission,
//! and a batch after one of the same size creates nothing.

use crate::common;

use common::scenes::settings;
use homcull::core::camera::Camera;
use homcull::core::cull::{CullSettings, Culler, PosePlan, PreparedScene, StartedVisibility, plan};
use homcull::core::gpu::targets::slots_for;
use homcull::core::gpu::{GpuBackend, GpuContext, GpuOptions, RecordCounts};
use homcull::core::occluders::OccluderParams;
use homcull::core::sampler::PoseSampler;
use homcull::core::scene::demo_city;
use homcull_proto::{DebVariant, Method};

fn plans(prep: &PreparedScene, n: usize, viewport: [u32; 2], s: &CullSettings) -> Vec<PosePlan> {
    let sampled = PoseSampler::new(&prep.scene).sample(n, 3, viewport, &|_| true);
    assert_eq!(sampled.poses.len(), n);
    sampled
        .poses
        .iter()
        .map(|p| plan(prep, &Camera::new(p).unwrap(), s))
        .collect()
}

/// What one batch of `plans` records, and its answers.
fn counted(
    backend: &mut GpuBackend,
    prep: &PreparedScene,
    plans: &[PosePlan],
    s: &CullSettings,
) -> (RecordCounts, Vec<Vec<u32>>) {
    let before = backend.context().counts();
    let masks = backend.visibility(prep, plans, s).unwrap();
    (backend.context().counts() - before, masks)
}

#[test]
fn a_batch_records_the_same_passes_whatever_its_size_and_a_repeat_creates_nothing() {
    let Some(gpu) = common::private_gpu() else {
        return;
    };
    let prep = PreparedScene::new(demo_city(), OccluderParams::default());
    let mut backend = GpuBackend::new(gpu, &prep);
    let hom = settings(&prep, Method::Hom, DebVariant::Raster, true);
    let exact = settings(&prep, Method::Exact, DebVariant::Raster, false);
    let all = plans(&prep, 256, [96, 54], &hom);
    let mut shapes = Vec::new();
    for n in [1, 16, 64, 256] {
        for (s, name) in [(&hom, "refined HOM"), (&exact, "exact")] {
            let batch = &all[..n];
            let (first, first_masks) = counted(&mut backend, &prep, batch, s);
            let (again, masks) = counted(&mut backend, &prep, batch, s);
            assert_eq!(masks, first_masks, "{name}, {n} poses: same answers again");
            assert_eq!(
                (again.buffers, again.bind_groups),
                (0, 0),
                "{name}, {n} poses: the second batch created buffers or bind groups \
                 (first: {first:?})"
            );
            assert_eq!(again.submissions, 1, "{name}, {n} poses: one submission");
            shapes.push((
                name,
                n,
                again.render_passes,
                again.compute_passes,
                again.dispatches,
            ));
        }
    }
    eprintln!("(method, poses, render passes, compute passes, dispatches): {shapes:?}");
    // The same passes at every size: refined HOM 2 render passes (occluders,
    // refinement) and one compute pass (pyramid, box test, filter), the exact oracle
    // 1 render pass (IDs) and one compute pass (collect); dispatches the same too.
    for &(name, n, render, compute, dispatches) in &shapes {
        let (render0, dispatches0) = match name {
            "exact" => (1, 1),
            _ => (2, shapes[0].4),
        };
        assert_eq!(
            (render, compute, dispatches),
            (render0, 1, dispatches0),
            "{name}, {n} poses: {shapes:?}"
        );
    }
    assert!(shapes[0].4 >= 3, "pyramid, box test and filter dispatches");
    // A smaller batch after a larger one needs nothing new either.
    let (smaller, _) = counted(&mut backend, &prep, &all[..5], &hom);
    assert_eq!((smaller.buffers, smaller.bind_groups), (0, 0));
}

#[test]
fn a_batch_larger_than_one_atlas_runs_in_groups_with_the_answers_of_single_poses() {
    let Some(gpu) = common::private_gpu() else {
        return;
    };
    let prep = PreparedScene::new(demo_city(), OccluderParams::default());
    let mut backend = GpuBackend::new(gpu, &prep);
    let hom = settings(&prep, Method::Hom, DebVariant::Raster, true);
    // 1920×1080: about 22 MB a slot (a 256 MiB software-adapter budget holds 11).
    let (w, h) = (1920, 1080);
    let slots = slots_for(backend.context(), w, h) as usize;
    let batch = plans(&prep, slots + 3, [w, h], &hom);
    let (counts, masks) = counted(&mut backend, &prep, &batch, &hom);
    assert_eq!(counts.render_passes, 2 * 2, "two groups: {counts:?}");
    assert_eq!(counts.submissions, 1);
    for (k, p) in batch.iter().enumerate() {
        let single = backend
            .visibility(&prep, std::slice::from_ref(p), &hom)
            .unwrap();
        assert_eq!(single[0], masks[k], "pose {k}: batch and single differ");
        assert!(masks[k].iter().any(|&w| w != 0), "pose {k} sees something");
    }
}

/// The refinement issues only the box test's survivors (compacted on the GPU where the
/// adapter draws with an indirect count), and the answers are those of the path that
/// draws every candidate with an instance count of 0 or 1.
#[test]
fn the_refinement_draws_only_the_box_tests_survivors() {
    let Some(gpu) = common::gpu() else { return };
    let prep = PreparedScene::new(demo_city(), OccluderParams::default());
    let mut backend = GpuBackend::new(gpu.clone(), &prep);
    let hom = settings(&prep, Method::Hom, DebVariant::Raster, true);
    let boxes = settings(&prep, Method::Hom, DebVariant::Raster, false);
    let batch = plans(&prep, 16, [960, 540], &hom);
    let box_masks = backend.visibility(&prep, &batch, &boxes).unwrap();
    let refined = backend.visibility(&prep, &batch, &hom).unwrap();
    let Some(draws) = backend.refine_draws().unwrap() else {
        assert!(
            !gpu.indirect_count,
            "the adapter draws with a count, so the draws are compacted"
        );
        return;
    };
    let bit = |m: &[u32], id: u32| m[id as usize / 32] & (1 << (id % 32)) != 0;
    let (mut candidates, mut survivors) = (0, 0);
    for (k, p) in batch.iter().enumerate() {
        let drawn = p
            .candidates
            .iter()
            .filter(|&&id| prep.scene.objects[id as usize].index_count > 0);
        let expected = drawn.clone().filter(|&&id| bit(&box_masks[k], id)).count();
        assert_eq!(
            draws[k] as usize, expected,
            "pose {k}: draws = box survivors"
        );
        candidates += drawn.count();
        survivors += expected;
    }
    eprintln!(
        "refinement draws per pose: {:.0} survivors of {:.0} candidates",
        survivors as f64 / batch.len() as f64,
        candidates as f64 / batch.len() as f64
    );
    assert!(survivors < candidates, "the box test culls something");
    // The same answers where every candidate is drawn with an instance count of 0 or 1.
    let options = GpuOptions {
        indirect_count: false,
        ..GpuOptions::from_env()
    };
    let uncounted = std::sync::Arc::new(GpuContext::with_options(options).unwrap());
    assert!(!uncounted.indirect_count);
    let mut backend = GpuBackend::new(uncounted, &prep);
    assert_eq!(backend.visibility(&prep, &batch, &hom).unwrap(), refined);
    assert_eq!(backend.refine_draws().unwrap(), None);
}

/// Batches started before the last one is read back (what the server's worker does
/// under load: it records batch k+1 while the device runs batch k) answer exactly as
/// batches run one at a time, whatever runs between them: another method, another
/// viewport (the atlas is remade while batches that drew into the old one are still
/// in flight). Two in flight need two staging buffers; once they exist, a repeat
/// creates nothing. A batch its caller gave up on is waited for and dropped when a
/// later one is taken.
#[test]
fn batches_in_flight_together_answer_as_batches_run_one_at_a_time() {
    let Some(gpu) = common::private_gpu() else {
        return;
    };
    let prep = PreparedScene::new(demo_city(), OccluderParams::default());
    let mut backend = GpuBackend::new(gpu, &prep);
    let hom = settings(&prep, Method::Hom, DebVariant::Raster, true);
    let exact = settings(&prep, Method::Exact, DebVariant::Raster, false);
    let a = plans(&prep, 16, [96, 54], &hom);
    let b = plans(&prep, 16, [96, 54], &exact);
    let c = plans(&prep, 3, [128, 72], &hom);
    let one_at_a_time: Vec<_> = [(&a, &hom), (&b, &exact), (&c, &hom)]
        .iter()
        .map(|(p, s)| backend.visibility(&prep, p, s).unwrap())
        .collect();
    for round in 0..2 {
        let before = backend.context().counts();
        let started: Vec<_> = [(&a, &hom), (&b, &exact)]
            .iter()
            .map(|(p, s)| backend.start_visibility(&prep, p, s).unwrap())
            .collect();
        assert!(
            started
                .iter()
                .all(|s| matches!(s, StartedVisibility::InFlight(_))),
            "the GPU backend returns before reading back"
        );
        assert_eq!(backend.in_flight(), 2);
        let answers: Vec<_> = started
            .into_iter()
            .map(|s| backend.finish_visibility(s).unwrap())
            .collect();
        assert_eq!(backend.in_flight(), 0);
        assert_eq!(answers[..], one_at_a_time[..2], "round {round}");
        let counts = backend.context().counts() - before;
        assert_eq!(counts.submissions, 2);
        if round == 1 {
            assert_eq!((counts.buffers, counts.bind_groups), (0, 0), "{counts:?}");
        }
    }
    // A third batch at another viewport while two are in flight.
    let started: Vec<_> = [(&a, &hom), (&b, &exact), (&c, &hom)]
        .iter()
        .map(|(p, s)| backend.start_visibility(&prep, p, s).unwrap())
        .collect();
    assert_eq!(backend.in_flight(), 3);
    let answers: Vec<_> = started
        .into_iter()
        .map(|s| backend.finish_visibility(s).unwrap())
        .collect();
    assert_eq!(answers, one_at_a_time);
    // Taking the later of two drops the earlier; the earlier cannot be taken after.
    let first = backend.start_visibility(&prep, &a, &hom).unwrap();
    let second = backend.start_visibility(&prep, &b, &exact).unwrap();
    assert_eq!(backend.finish_visibility(second).unwrap(), one_at_a_time[1]);
    assert_eq!(backend.in_flight(), 0);
    let err = backend.finish_visibility(first).unwrap_err().to_string();
    assert!(err.contains("no batch in flight"), "{err}");
}
