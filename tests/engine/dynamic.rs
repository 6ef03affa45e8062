//! Moving objects (`core::dynamic`) against the exact oracle.
//!
//! - Walks of 300 street-level poses on the demo city and on the OpenArena maps with
//!   their brush models (`model_*`: doors, platforms, lifts) and other objects moving,
//!   a new placement every 10 poses: at every version, zero false culls of the refined
//!   HOM answer against the exact oracle at the same version, on the native CPU
//!   backend (against the CPU oracle twin) and on the GPU (against the GPU oracle,
//!   with and without indirect draws); every answer names the version it used.
//! - Temporal bounding volumes: objects sent with a velocity and a spin are answered
//!   at version k; the objects the oracle sees at the same poses with the objects
//!   moved along that motion for half and all of the horizon are all in that answer.

use crate::common;

use std::sync::Arc;

use glam::{Mat4, Quat, Vec3};
use homcull::core::camera::Camera;
use homcull::core::cull::{CullSettings, PreparedScene};
use homcull::core::engine::{Backend, Engine};
use homcull::core::geom::Aabb;
use homcull::core::gpu::{GpuContext, GpuOptions};
use homcull::core::occluders::OccluderParams;
use homcull::core::pvs::Pvs;
use homcull::core::resident::sample_poses;
use homcull::core::scene::{Scene, demo_city, load_path};
use homcull_proto::{CullOptions, Method, ObjectTransform, TransformsRequest};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

const POSES: usize = 300;
const POSES_PER_VERSION: usize = 10;
const VIEWPORT: [u32; 2] = [320, 180];

/// What moves: the maps' brush models and every object small enough to be a prop;
/// on the demo city, everything but the ground.
fn movers(scene: &Scene) -> Vec<u32> {
    let models: Vec<u32> = scene
        .objects
        .iter()
        .filter(|o| o.name.starts_with("model_"))
        .map(|o| o.id)
        .collect();
    let props = scene
        .objects
        .iter()
        .filter(|o| o.index_count > 0 && o.aabb.diagonal() < 40.0);
    let mut ids: Vec<u32> = models;
    ids.extend(props.map(|o| o.id).step_by(3));
    ids.sort_unstable();
    ids.dedup();
    ids
}

/// Each of `ids` with probability `p`.
fn chosen(rng: &mut StdRng, ids: &[u32], p: f64) -> Vec<u32> {
    ids.iter().copied().filter(|_| rng.random_bool(p)).collect()
}

fn options(method: Method) -> CullOptions {
    CullOptions {
        method,
        refine: method == Method::Hom,
        ..CullOptions::default()
    }
}

/// A random placement: a few metres away, turned about the vertical.
fn random_move(rng: &mut StdRng, id: u32) -> ObjectTransform {
    let angle = rng.random_range(-3.2f32..3.2);
    ObjectTransform {
        id,
        translation: Some([
            rng.random_range(-3.0..3.0),
            rng.random_range(-0.5..1.5),
            rng.random_range(-3.0..3.0),
        ]),
        rotation: Some(Quat::from_rotation_y(angle).to_array()),
        ..Default::default()
    }
}

/// A GPU context of its own with some of the refinement's draw paths turned off.
fn gpu_with(options: GpuOptions) -> Arc<GpuContext> {
    let ctx = GpuContext::with_options(options).expect("the test adapter opens twice");
    assert_eq!(ctx.indirect_draws, options.indirect_draws);
    Arc::new(ctx)
}

/// An engine under test and the oracle engine it is held to.
struct Pair {
    name: &'static str,
    culler: Engine,
    oracle: Engine,
}

fn pairs(scene: &Scene) -> Vec<Pair> {
    let prepared = || PreparedScene::new(scene.clone(), OccluderParams::default());
    let mut out = vec![Pair {
        name: "native",
        culler: Engine::from_prepared(prepared(), Backend::Native),
        oracle: Engine::from_prepared(prepared(), Backend::Reference),
    }];
    if let Some(gpu) = common::gpu() {
        out.push(Pair {
            name: "gpu",
            culler: Engine::from_prepared(prepared(), Backend::Gpu(gpu.clone())),
            oracle: Engine::from_prepared(prepared(), Backend::Gpu(gpu)),
        });
        // The refinement's other draw paths: draws not compacted (no indirect
        // count), and direct draws.
        let env = GpuOptions::from_env();
        let paths = [
            (
                "gpu without indirect count",
                GpuOptions {
                    indirect_count: false,
                    ..env
                },
            ),
            (
                "gpu without indirect draws",
                GpuOptions {
                    indirect_draws: false,
                    ..env
                },
            ),
        ];
        for (name, options) in paths {
            let gpu = gpu_with(options);
            out.push(Pair {
                name,
                culler: Engine::from_prepared(prepared(), Backend::Gpu(gpu.clone())),
                oracle: Engine::from_prepared(prepared(), Backend::Gpu(gpu)),
            });
        }
    }
    out
}

fn apply(engine: &Engine, req: &TransformsRequest) -> u64 {
    let d = engine.dynamics();
    let mut d = d.lock().unwrap();
    d.apply(req, usize::MAX).expect("the update is accepted")
}

fn cameras(scene: &Scene, n: usize, seed: u64) -> Vec<Camera> {
    let pvs = Pvs::from_scene(scene).map(|r| r.expect("the scene's PVS parses"));
    let sampled = sample_poses(scene, pvs.as_ref(), n, seed, VIEWPORT);
    assert_eq!(sampled.poses.len(), n, "{}: too few poses", scene.name);
    sampled
        .poses
        .iter()
        .map(|p| Camera::new(p).unwrap())
        .collect()
}

fn visible_sets(results: &[homcull::core::cull::PoseResult]) -> Vec<Vec<u32>> {
    results.iter().map(|r| r.visible.clone()).collect()
}

/// Objects the oracle sees that the answer culls, per pose.
fn missing(answer: &[Vec<u32>], oracle: &[Vec<u32>]) -> Vec<(usize, u32)> {
    let mut out = Vec::new();
    for (k, (a, o)) in answer.iter().zip(oracle).enumerate() {
        out.extend(
            o.iter()
                .filter(|id| a.binary_search(id).is_err())
                .map(|&id| (k, id)),
        );
    }
    out
}

fn walk(scene: Scene) {
    let name = scene.name.clone();
    let movers = movers(&scene);
    assert!(movers.len() >= 5, "{name}: {} movers", movers.len());
    let cams = cameras(&scene, POSES, 5);
    let mut rng = StdRng::seed_from_u64(7);
    let mut pairs = pairs(&scene);
    // The CPU oracle twin, which every GPU oracle must agree with but for cracks (so
    // that a GPU answering on stale geometry, culler and oracle alike, is caught).
    let mut twin = Engine::from_prepared(
        PreparedScene::new(scene.clone(), OccluderParams::default()),
        Backend::Reference,
    );
    let (mut seen_total, mut disagreements) = (0usize, 0usize);
    let mut moved_culls = 0usize;
    for (step, batch) in cams.chunks(POSES_PER_VERSION).enumerate() {
        // A third of the movers each time; every fifth version, some go back home.
        let req = TransformsRequest {
            objects: chosen(&mut rng, &movers, 0.33)
                .into_iter()
                .map(|id| {
                    if step % 5 == 4 && rng.random_bool(0.5) {
                        ObjectTransform {
                            id,
                            ..Default::default()
                        }
                    } else {
                        random_move(&mut rng, id)
                    }
                })
                .collect(),
            horizon_ms: None,
        };
        apply(&twin, &req);
        let twin_seen = visible_sets(
            &twin
                .cull(batch, &twin.settings(options(Method::Exact)))
                .unwrap(),
        );
        for pair in &mut pairs {
            let v = apply(&pair.culler, &req);
            assert_eq!(apply(&pair.oracle, &req), v);
            let hom = pair.culler.settings(options(Method::Hom));
            let exact = pair.oracle.settings(options(Method::Exact));
            let answer = pair.culler.cull(batch, &hom).unwrap();
            let oracle = pair.oracle.cull(batch, &exact).unwrap();
            assert!(
                answer
                    .iter()
                    .chain(&oracle)
                    .all(|r| r.stats.scene_version == v)
            );
            let visible = visible_sets(&answer);
            let seen = visible_sets(&oracle);
            seen_total += seen.iter().map(Vec::len).sum::<usize>();
            disagreements += missing(&seen, &twin_seen).len() + missing(&twin_seen, &seen).len();
            let wrong = missing(&visible, &seen);
            assert!(
                wrong.is_empty(),
                "{name}, {}: version {v}: culled what the oracle sees (pose, object): {wrong:?}",
                pair.name
            );
            moved_culls += answer
                .iter()
                .map(|r| r.stats.culled_by_occlusion as usize)
                .sum::<usize>();
        }
    }
    // The walk culls something: the check above is not vacuous.
    assert!(moved_culls > POSES, "{name}: {moved_culls} occlusion culls");
    eprintln!("{name}: oracles disagree on {disagreements} of {seen_total} sightings");
    assert!(
        disagreements * 50 <= seen_total,
        "{name}: the oracles disagree on {disagreements} of {seen_total} sightings"
    );
}

fn shared(file: &str) -> Option<Scene> {
    let dir = common::scenes_dir()?;
    Some(load_path(&dir.join(file)).expect("shared scene loads"))
}

#[test]
fn demo_city_with_moving_objects() {
    walk(demo_city());
}

#[test]
fn oa_dm1_with_moving_brush_models() {
    if let Some(s) = shared("oa_dm1.glb") {
        walk(s);
    }
}

#[test]
fn oa_shouse_with_moving_brush_models() {
    if let Some(s) = shared("oa_shouse.glb") {
        walk(s);
    }
}

/// The placed bounds of object `id` under `m` (what the swept volume turns about).
fn placed_bounds(scene: &Scene, id: u32, m: Mat4) -> Aabb {
    let o = &scene.objects[id as usize];
    let pts: Vec<Vec3> = scene
        .triangles_of(o)
        .iter()
        .map(|&v| m.transform_point3(scene.positions[v as usize]))
        .collect();
    Aabb::from_points(pts.iter())
}

fn horizon(scene: Scene) {
    let name = scene.name.clone();
    let movers = movers(&scene);
    let cams = cameras(&scene, 60, 9);
    let mut rng = StdRng::seed_from_u64(3);
    let horizon_ms = 400.0;
    for pair in &mut pairs(&scene) {
        for round in 0..3 {
            let moves: Vec<ObjectTransform> = chosen(&mut rng, &movers, 0.5)
                .into_iter()
                .map(|id| ObjectTransform {
                    velocity: Some([
                        rng.random_range(-8.0..8.0),
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-8.0..8.0),
                    ]),
                    angular_velocity: Some([0.0, rng.random_range(-3.0..3.0), 0.0]),
                    ..random_move(&mut rng, id)
                })
                .collect();
            let req = TransformsRequest {
                objects: moves.clone(),
                horizon_ms: Some(horizon_ms),
            };
            let v = apply(&pair.culler, &req);
            let hom: CullSettings = pair.culler.settings(options(Method::Hom));
            let answer = pair.culler.cull(&cams, &hom).unwrap();
            assert!(answer.iter().all(|r| r.stats.scene_version == v));
            let visible: Vec<Vec<u32>> = answer.iter().map(|r| r.visible.clone()).collect();
            for fraction in [0.5f32, 1.0] {
                let s = horizon_ms as f32 / 1e3 * fraction;
                // Where each mover is after `s` seconds of its declared motion.
                let later = TransformsRequest {
                    objects: moves
                        .iter()
                        .map(|t| {
                            let from = placement_matrix(t, &scene);
                            let c = placed_bounds(&scene, t.id, from).center();
                            let v = Vec3::from(t.velocity.unwrap());
                            let w = Vec3::from(t.angular_velocity.unwrap());
                            let m = Mat4::from_translation(c + v * s)
                                * Mat4::from_quat(Quat::from_scaled_axis(w * s))
                                * Mat4::from_translation(-c)
                                * from;
                            ObjectTransform {
                                id: t.id,
                                matrix: Some(m.to_cols_array()),
                                ..Default::default()
                            }
                        })
                        .collect(),
                    horizon_ms: Some(0.0),
                };
                apply(&pair.oracle, &later);
                let exact = pair.oracle.settings(options(Method::Exact));
                let oracle = pair.oracle.cull(&cams, &exact).unwrap();
                let seen: Vec<Vec<u32>> = oracle.iter().map(|r| r.visible.clone()).collect();
                let wrong = missing(&visible, &seen);
                assert!(
                    wrong.is_empty(),
                    "{name}, {}, round {round}: {fraction} of the horizon later the oracle \
                     sees what version {v} culled (pose, object): {wrong:?}",
                    pair.name
                );
            }
        }
    }
}

/// The matrix a translation/rotation update stands for (as `core::dynamic` reads it).
fn placement_matrix(t: &ObjectTransform, scene: &Scene) -> Mat4 {
    let loaded = scene.objects[t.id as usize].aabb;
    homcull::core::dynamic::Placement::from_update(t, loaded)
        .expect("valid")
        .matrix
}

#[test]
fn demo_city_moving_objects_stay_visible_over_the_horizon() {
    horizon(demo_city());
}

#[test]
fn oa_dm1_moving_brush_models_stay_visible_over_the_horizon() {
    if let Some(s) = shared("oa_dm1.glb") {
        horizon(s);
    }
}

/// What a journal's snapshot keeps (`Dynamics::placed`), restored into a fresh engine
/// of the same scene, answers as the engine it was taken from, at the same version;
/// and a checked update holds until it is committed.
#[test]
fn restored_placements_answer_as_the_originals() {
    let scene = demo_city();
    let open = || Engine::new(scene.clone(), OccluderParams::default(), Backend::Native);
    let (mut original, mut restored) = (open(), open());
    let mut rng = StdRng::seed_from_u64(5);
    let ids = movers(&scene);
    for _ in 0..3 {
        let objects = chosen(&mut rng, &ids, 0.05)
            .into_iter()
            .map(|id| random_move(&mut rng, id))
            .collect();
        let req = TransformsRequest {
            objects,
            horizon_ms: Some(250.0),
        };
        let d = original.dynamics();
        let mut d = d.lock().unwrap();
        let checked = d.check(&req, usize::MAX).expect("the update is accepted");
        assert_eq!(d.version() + 1, checked.version, "a check applies nothing");
        d.commit(checked);
    }
    let placed = original.dynamics().lock().unwrap().placed();
    assert_eq!(placed.version, 3);
    restored
        .dynamics()
        .lock()
        .unwrap()
        .restore(&placed)
        .unwrap();
    let cams = cameras(&scene, 24, 9);
    let settings = original.settings(options(Method::Hom));
    let a = original.cull(&cams, &settings).unwrap();
    let b = restored.cull(&cams, &settings).unwrap();
    assert_eq!(visible_sets(&a), visible_sets(&b));
    assert!(b.iter().all(|r| r.stats.scene_version == 3));
    // Back to the file: every object as loaded again, a later version.
    let home = homcull::core::dynamic::Placed {
        version: 4,
        horizon_s: placed.horizon_s,
        objects: Vec::new(),
    };
    restored.dynamics().lock().unwrap().restore(&home).unwrap();
    let fresh = open().cull(&cams, &settings).unwrap();
    assert_eq!(
        visible_sets(&restored.cull(&cams, &settings).unwrap()),
        visible_sets(&fresh)
    );
    let behind = restored.dynamics().lock().unwrap().restore(&placed);
    assert!(
        behind.is_err(),
        "a snapshot behind the scene's version is refused"
    );
}
