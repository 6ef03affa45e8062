//! Region answers on the native CPU backend (divan; one thread). Run: `cargo bench
//! --bench region`. Scenes come from `HOMCULL_SCENES` (default `../shared/scenes`)
//! and the built-in demo city (`demo`); 8 sampled street-level poses per scene at
//! 960×540 (seed 1, the first of `homcull eval --random 32`'s), each asked as a
//! region of radius 0.5 m turning 10°, what a walking stream client would hold.
//!
//! - `maps`: occluder choice and the region map drawn (bounds, leak edges, tables).
//! - `pose`: the whole region answer (`region::cull`: candidates, maps, box tests),
//!   beside `point`, the same poses culled as points by the native backend.

mod common;

use std::sync::OnceLock;

use divan::Bencher;
use homcull::core::camera::Camera;
use homcull::core::cull::{CullSettings, Culler, PreparedScene};
use homcull::core::native::NativeBackend;
use homcull::core::occluders::OccluderParams;
use homcull::core::region;
use homcull::core::sampler::PoseSampler;
use homcull::eval::region_eyes::ball_region;
use homcull_proto::{CullOptions, Method};

const SCENES: &[&str] = &["demo", "munich", "oa_dm1"];
const POSES: usize = 8;

fn main() {
    // One thread: the figures are per core.
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build_global()
        .expect("a one-thread pool");
    divan::main();
}

struct Bench {
    prep: PreparedScene,
    /// The poses as points, and as regions.
    points: Vec<Camera>,
    regions: Vec<Camera>,
}

fn scene(name: &str) -> &'static Bench {
    static ALL: OnceLock<Vec<(String, Bench)>> = OnceLock::new();
    let all = ALL.get_or_init(|| {
        SCENES
            .iter()
            .map(|&n| {
                let scene = common::scene_named(n);
                let sampled = PoseSampler::new(&scene).sample(POSES, 1, [960, 540], &|_| true);
                let points = sampled
                    .poses
                    .iter()
                    .map(|p| Camera::new(p).unwrap())
                    .collect();
                let regions = sampled
                    .poses
                    .iter()
                    .map(|p| Camera::new(&ball_region(p, 0.5, 10.0)).unwrap())
                    .collect();
                let prep = PreparedScene::new(scene, OccluderParams::default());
                prep.edge_neighbours();
                (
                    n.to_string(),
                    Bench {
                        prep,
                        points,
                        regions,
                    },
                )
            })
            .collect()
    });
    &all.iter()
        .find(|(n, _)| n == name)
        .expect("a benchmarked scene")
        .1
}

fn settings(b: &Bench) -> CullSettings {
    CullSettings::new(
        CullOptions {
            method: Method::Hom,
            ..CullOptions::default()
        },
        &b.prep,
    )
}

#[divan::bench(args = SCENES, sample_count = 5, sample_size = 1)]
fn maps(bencher: Bencher, name: &str) {
    let b = scene(name);
    let s = settings(b);
    bencher
        .counter(divan::counter::ItemsCount::new(b.regions.len()))
        .bench(|| {
            b.regions
                .iter()
                .map(|c| region::draw_maps(&b.prep, c, c.region.as_ref().unwrap(), &s).len())
                .sum::<usize>()
        });
}

#[divan::bench(args = SCENES, sample_count = 5, sample_size = 1)]
fn pose(bencher: Bencher, name: &str) {
    let b = scene(name);
    let s = settings(b);
    bencher
        .counter(divan::counter::ItemsCount::new(b.regions.len()))
        .bench(|| {
            b.regions
                .iter()
                .map(|c| {
                    region::cull(&b.prep, c, c.region.as_ref().unwrap(), &s)
                        .visible
                        .len()
                })
                .sum::<usize>()
        });
}

#[divan::bench(args = SCENES, sample_count = 5, sample_size = 1)]
fn point(bencher: Bencher, name: &str) {
    let b = scene(name);
    let s = settings(b);
    bencher
        .counter(divan::counter::ItemsCount::new(b.points.len()))
        .bench(|| NativeBackend.cull(&b.prep, &b.points, &s).unwrap().len());
}
