//! Micro-benchmarks of the hot passes (divan). Run: `cargo bench --bench passes`.
//!
//! CPU paths: box projection, BVH frustum traversal, the CPU overlap test per object
//! (compare: ~100 ns per object test for software occlusion culling such as MOC).
//! GPU: a whole batch of 1, 16 and 64 poses per method on the demo city at 960×540
//! (raster + pyramid + test + readback; the passes are timed together because one
//! submission holds them all), and 64 stereo poses (both eyes), when an adapter exists.

use std::sync::{Arc, OnceLock};

use divan::Bencher;
use homcull::core::camera::{Camera, look_at, stereo};
use homcull::core::cull::{CullSettings, Culler, PosePlan, PreparedScene, plan};
use homcull::core::gpu::{GpuBackend, GpuContext};
use homcull::core::occluders::OccluderParams;
use homcull::core::reference::ReferenceBackend;
use homcull::core::reference::pyramid::{self, LevelLayout};
use homcull::core::scene::demo_city;
use homcull_proto::{CullOptions, DebVariant, Method, Pose, Stereo};

fn main() {
    divan::main();
}

fn prepared() -> &'static PreparedScene {
    static P: OnceLock<PreparedScene> = OnceLock::new();
    P.get_or_init(|| PreparedScene::new(demo_city(), OccluderParams::default()))
}

fn cams(n: usize) -> Vec<Camera> {
    (0..n)
        .map(|i| {
            let a = i as f32 * 0.7;
            let eye = glam::Vec3::new(3.0 + (i % 5) as f32 * 0.5, 1.7, 3.0);
            look_at(eye, eye + glam::Vec3::new(a.cos(), 0.0, a.sin()), 960, 540)
        })
        .collect()
}

fn settings(method: Method) -> CullSettings {
    CullSettings::new(
        CullOptions {
            method,
            threshold: 1.0,
            deb: DebVariant::Raster,
            refine: true,
            lod: None,
        },
        prepared(),
    )
}

#[divan::bench]
fn project_box_per_object(b: Bencher) {
    let p = prepared();
    let cam = &cams(1)[0];
    b.counter(divan::counter::ItemsCount::new(p.scene.boxes.len()))
        .bench(|| {
            p.scene
                .boxes
                .iter()
                .filter_map(|tb| cam.project_box(divan::black_box(&tb.aabb)))
                .count()
        });
}

#[divan::bench]
fn bvh_frustum_query(b: Bencher) {
    let p = prepared();
    let cam = &cams(1)[0];
    b.bench(|| {
        let mut n = 0;
        p.bvh.frustum_query(cam, |_| n += 1);
        n
    });
}

/// A street pose's plan and its pyramid, built once (the inputs of the CPU test).
fn street_pyramid() -> &'static (PosePlan, LevelLayout, Vec<f32>, Vec<f32>) {
    static P: OnceLock<(PosePlan, LevelLayout, Vec<f32>, Vec<f32>)> = OnceLock::new();
    P.get_or_init(|| {
        let p = prepared();
        let pl = plan(p, &cams(1)[0], &settings(Method::Hom));
        let layout = LevelLayout::new(960, 540);
        let (o, d) = pyramid::build(&layout, &ReferenceBackend::occluder_depth(&p.scene, &pl));
        (pl, layout, o, d)
    })
}

/// CPU overlap + depth test of one pose (the inner loop of HOM), counted per test box:
/// boxes of an object already proven visible are skipped, as the engine does.
#[divan::bench]
fn cpu_object_test_per_box(b: Bencher) {
    let p = prepared();
    let s = settings(Method::Hom);
    let (pl, layout, o, d) = street_pyramid();
    b.counter(divan::counter::ItemsCount::new(pl.test_boxes.len()))
        .bench(|| ReferenceBackend::test_boxes(&p.scene, pl, &s, layout, o, d));
}

/// The same test counted per candidate object (what MOC's ~100 ns per test is quoted
/// against): the amortized cost of deciding one in-frustum object.
#[divan::bench]
fn cpu_object_test_per_object(b: Bencher) {
    let p = prepared();
    let s = settings(Method::Hom);
    let (pl, layout, o, d) = street_pyramid();
    b.counter(divan::counter::ItemsCount::new(pl.candidates.len()))
        .bench(|| ReferenceBackend::test_boxes(&p.scene, pl, &s, layout, o, d));
}

/// Frustum query, test-box selection, occluder selection and the box DEB of one pose.
#[divan::bench(args = [DebVariant::Raster, DebVariant::Tiles])]
fn cpu_plan(b: Bencher, deb: DebVariant) {
    let p = prepared();
    let s = CullSettings::new(
        CullOptions {
            method: Method::Hom,
            threshold: 1.0,
            deb,
            refine: true,
            lod: None,
        },
        p,
    );
    let cam = &cams(1)[0];
    b.bench(|| plan(p, divan::black_box(cam), &s));
}

/// The CPU twin of the occluder raster (level 0 of the pyramid) for one pose.
#[divan::bench(sample_count = 20)]
fn cpu_occluder_raster(b: Bencher) {
    let p = prepared();
    let (pl, _, _, _) = street_pyramid();
    b.counter(divan::counter::ItemsCount::new(pl.occluders.ids.len()))
        .bench(|| ReferenceBackend::occluder_depth(&p.scene, pl));
}

#[divan::bench]
fn cpu_pyramid_reduce(b: Bencher) {
    let layout = LevelLayout::new(960, 540);
    let level0: Vec<f32> = (0..960 * 540)
        .map(|i| if i % 7 == 0 { 0.0 } else { 5.0 })
        .collect();
    b.bench(|| pyramid::build(&layout, divan::black_box(&level0)));
}

fn gpu() -> Option<Arc<GpuContext>> {
    static G: OnceLock<Option<Arc<GpuContext>>> = OnceLock::new();
    G.get_or_init(|| GpuContext::new().ok().map(Arc::new))
        .clone()
}

#[divan::bench(args = [1, 16, 64], consts = [0, 1, 2])]
fn gpu_batch<const M: usize>(b: Bencher, poses: usize) {
    let Some(ctx) = gpu() else {
        eprintln!("no GPU adapter: skipping gpu_batch");
        return;
    };
    let method = [Method::Hom, Method::Hzb, Method::Exact][M];
    let p = prepared();
    let mut backend = GpuBackend::new(ctx, p);
    let s = settings(method);
    let cams = cams(poses);
    backend.cull(p, &cams, &s).unwrap();
    b.counter(divan::counter::ItemsCount::new(poses))
        .bench_local(|| backend.cull(p, &cams, &s).unwrap());
}

/// Refined HOM on a batch of stereo poses (both eyes 64 mm apart, each culled as a view
/// of its own: twice the views of `gpu_batch`), per stereo pose: compare with
/// `gpu_batch::<0>` at the same batch size.
#[divan::bench(args = [64], sample_count = 10)]
fn gpu_batch_stereo(b: Bencher, poses: usize) {
    let Some(ctx) = gpu() else {
        eprintln!("no GPU adapter: skipping gpu_batch_stereo");
        return;
    };
    let p = prepared();
    let mut backend = GpuBackend::new(ctx, p);
    let s = settings(Method::Hom);
    let eyes: Vec<Camera> = cams(poses)
        .iter()
        .flat_map(|c| {
            let target = c.position + c.forward();
            let pose = Pose {
                viewport: [c.width, c.height],
                stereo: Some(Stereo {
                    ipd_m: 0.064,
                    convergence_m: None,
                }),
                ..Pose::looking_at(c.position.to_array(), target.to_array())
            };
            stereo::eyes(&pose).expect("a valid stereo pose")
        })
        .collect();
    backend.cull(p, &eyes, &s).unwrap();
    b.counter(divan::counter::ItemsCount::new(poses))
        .bench_local(|| backend.cull(p, &eyes, &s).unwrap());
}
