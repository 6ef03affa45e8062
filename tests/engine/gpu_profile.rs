//! GPU time per pass (timestamp queries): profiling changes no answer, charges time to
//! exactly the passes a method runs, and its sum fits in the batch's wall time.

use crate::common;

use std::time::Instant;

use glam::Vec3;
use homcull::core::camera::look_at;
use homcull::core::cull::{CullSettings, Culler, PreparedScene};
use homcull::core::cull::{Pass, PassTimes};
use homcull::core::gpu::GpuBackend;
use homcull::core::occluders::OccluderParams;
use homcull::core::scene::demo_city;
use homcull_proto::{CullOptions, DebVariant, Method};

#[test]
fn pass_times_cover_the_passes_each_method_runs() {
    let Some(gpu) = common::gpu() else { return };
    assert!(
        gpu.timestamps,
        "adapter {} lacks timestamp queries inside encoders",
        gpu.describe()
    );
    let prep = PreparedScene::new(demo_city(), OccluderParams::default());
    let mut backend = GpuBackend::new(gpu, &prep);
    // 20 street poses: two groups of slots (16 + 4) in one batch.
    let cams: Vec<_> = (0..20)
        .map(|i| {
            let a = i as f32 * 0.3;
            let eye = Vec3::new(0.0, 1.7, 3.0 + i as f32);
            look_at(eye, eye + Vec3::new(a.cos(), 0.0, a.sin()), 480, 270)
        })
        .collect();
    let settings = |method, refine| {
        CullSettings::new(
            CullOptions {
                method,
                threshold: 1.0,
                deb: DebVariant::Raster,
                refine,
                lod: None,
            },
            &prep,
        )
    };
    let runs: [(Method, bool, &[Pass]); 3] = [
        (
            Method::Hom,
            true,
            &[
                Pass::OccluderRaster,
                Pass::Pyramid,
                Pass::BoxTest,
                Pass::Refine,
            ],
        ),
        (
            Method::Hzb,
            false,
            &[Pass::OccluderRaster, Pass::Pyramid, Pass::BoxTest],
        ),
        (Method::Exact, false, &[Pass::IdRaster, Pass::Collect]),
    ];
    for (method, refine, passes) in runs {
        let s = settings(method, refine);
        let plain = backend.cull(&prep, &cams, &s).unwrap();
        assert!(backend.take_pass_times().is_none(), "not profiling yet");
        assert!(backend.set_profiling(true));
        let t = Instant::now();
        let profiled = backend.cull(&prep, &cams, &s).unwrap();
        let wall_ms = t.elapsed().as_secs_f64() * 1e3;
        let times: PassTimes = backend.take_pass_times().expect("profiling is on");
        assert_eq!(
            plain.iter().map(|r| &r.visible).collect::<Vec<_>>(),
            profiled.iter().map(|r| &r.visible).collect::<Vec<_>>(),
            "{method:?}: profiling changed an answer"
        );
        assert_eq!(times.poses, cams.len() as u64);
        for pass in Pass::ALL {
            let ms = times.get(pass);
            if passes.contains(&pass) {
                assert!(
                    ms > 0.0,
                    "{method:?}: no time charged to {pass:?}: {times:?}"
                );
            } else {
                assert_eq!(
                    ms, 0.0,
                    "{method:?}: time charged to {pass:?}, which it skips"
                );
            }
        }
        assert!(
            times.total_ms() <= wall_ms,
            "{method:?}: GPU passes sum to {:.2} ms, more than the {wall_ms:.2} ms the batch took",
            times.total_ms()
        );
        eprintln!("{method:?}: {:?} (wall {wall_ms:.2} ms)", times.per_pose());
        // Taking the times starts a new sum; turning profiling off ends it.
        assert_eq!(backend.take_pass_times().unwrap().total_ms(), 0.0);
        assert!(!backend.set_profiling(false));
        assert!(backend.take_pass_times().is_none());
    }
}
