//! Both eyes in one query (`Pose::stereo`), against the mono answers for the eyes'
//! own poses and against the exact oracle for each eye.
//!
//! On the demo city and every shared scene, 200 street-level poses each, native CPU
//! backend (a GPU adapter too, on fewer poses, where one exists):
//! - with parallel, symmetric frusta, the stereo set contains the union of the mono
//!   answers for the two eyes' exact poses, and keeps at most 1.03× its triangles;
//! - with converged (off-axis) frusta, nothing either eye's exact oracle sees is culled.

use crate::common;

use common::scenes::settings;
use homcull::core::camera::{Camera, stereo};
use homcull::core::cull::{CullSettings, Culler, PoseResult, PreparedScene};
use homcull::core::gpu::GpuBackend;
use homcull::core::native::NativeBackend;
use homcull::core::occluders::OccluderParams;
use homcull::core::sampler::PoseSampler;
use homcull_proto::{DebVariant, Method, Pose, Stereo};

const IPD: f32 = 0.064;

fn with_stereo(p: &Pose, convergence_m: Option<f32>) -> Pose {
    Pose {
        stereo: Some(Stereo {
            ipd_m: IPD,
            convergence_m,
        }),
        ..p.clone()
    }
}

fn triangles(prep: &PreparedScene, ids: &[u32]) -> u64 {
    ids.iter()
        .map(|&id| prep.scene.objects[id as usize].index_count as u64 / 3)
        .sum()
}

/// The stereo answer for `pose`: its eyes culled as a batch, united.
fn stereo_answer(
    c: &mut dyn Culler,
    prep: &PreparedScene,
    pose: &Pose,
    s: &CullSettings,
) -> PoseResult {
    let eyes = stereo::eyes(pose).unwrap();
    assert_eq!(eyes.len(), 2);
    PoseResult::union_of(c.cull(prep, &eyes, s).unwrap()).unwrap()
}

/// Checks `n` poses of `scene` on `culler`; returns (false culls, stereo ÷ union
/// triangles).
fn check(name: &str, culler: &mut dyn Culler, prep: &PreparedScene, n: usize) -> (usize, f64) {
    let hom = settings(prep, Method::Hom, DebVariant::Raster, true);
    let exact = settings(prep, Method::Exact, DebVariant::Raster, false);
    let sampled = PoseSampler::new(&prep.scene).sample(n, 5, [960, 540], &|_| true);
    let (mut false_culls, mut kept, mut union_tris) = (0, 0u64, 0u64);
    for pose in &sampled.poses {
        // Parallel axes: the union of the eyes' mono answers is in the stereo set.
        let st = stereo_answer(culler, prep, &with_stereo(pose, None), &hom);
        let mono: Vec<Camera> = [-0.5 * IPD, 0.5 * IPD]
            .map(|o| Camera::new(&stereo::eye_pose(pose, o)).unwrap())
            .to_vec();
        let union = PoseResult::union_of(culler.cull(prep, &mono, &hom).unwrap()).unwrap();
        let missing: Vec<_> = union
            .visible
            .iter()
            .filter(|id| st.visible.binary_search(id).is_err())
            .collect();
        assert!(
            missing.is_empty(),
            "{name} {pose:?}: the stereo set lacks {missing:?}"
        );
        kept += triangles(prep, &st.visible);
        union_tris += triangles(prep, &union.visible);
        // Converged, off-axis eyes: nothing an eye's oracle sees is culled.
        let converged = with_stereo(pose, Some(2.0));
        let st = stereo_answer(culler, prep, &converged, &hom);
        let eyes = stereo::eyes(&converged).unwrap();
        for oracle in culler.cull(prep, &eyes, &exact).unwrap() {
            false_culls += oracle
                .visible
                .iter()
                .filter(|id| st.visible.binary_search(id).is_err())
                .count();
        }
    }
    let ratio = kept as f64 / union_tris.max(1) as f64;
    eprintln!("{name}: {n} poses, {false_culls} false culls, stereo ÷ union triangles {ratio:.4}");
    (false_culls, ratio)
}

#[test]
fn stereo_on_the_native_backend_holds_both_eyes_answers() {
    for (name, scene) in common::scenes::demo_and_shared() {
        let prep = PreparedScene::new(scene, OccluderParams::default());
        let (false_culls, ratio) = check(&name, &mut NativeBackend, &prep, 200);
        assert_eq!(false_culls, 0, "{name}");
        assert!(ratio <= 1.03, "{name}: {ratio}");
    }
}

#[test]
fn stereo_on_the_gpu_holds_both_eyes_answers() {
    let Some(gpu) = common::gpu() else { return };
    for (name, scene) in common::scenes::demo_and_shared().into_iter().take(2) {
        let prep = PreparedScene::new(scene, OccluderParams::default());
        let mut backend = GpuBackend::new(gpu.clone(), &prep);
        let (false_culls, ratio) = check(&name, &mut backend, &prep, 16);
        assert_eq!(false_culls, 0, "{name}");
        assert!(ratio <= 1.03, "{name}: {ratio}");
    }
}
