//! Conservativeness and efficiency on the shared real scenes and the demo city, on
//! each backend (a real adapter, and the native CPU backend), each against its own
//! exact oracle: for each scene, 200 sampled poses at 960×540; `hom` (every DEB
//! variant, with and without the per-pixel refinement) and `hzb` must have zero false
//! culls against the exact oracle, and `hom` as served (raster DEB, refined) and the
//! box test alone (`hom-raster`) must reach the efficiency floors measured for that
//! scene. The OpenArena
//! maps also check the oracle against the map's own PVS.

use crate::common;

use homcull::core::camera::Camera;
use homcull::core::engine::{Backend, Engine};
use homcull::core::occluders::OccluderParams;
use homcull::core::pvs::Pvs;
use homcull::core::sampler::PoseSampler;
use homcull::core::scene::{Scene, demo_city, load_path};
use homcull::eval::{MethodSpec, evaluate};

const POSES: usize = 200;

/// Efficiency floors for `hom` as served (raster DEB, refined, threshold 1.0, default
/// budget), on either backend, set under what 200 poses measured on lavapipe (demo 1.000, munich 1.000,
/// etoile 1.000, oa_shouse 0.998, oa_dm1 0.992, godot_room 1.000, fzk_haus 1.000).
fn floor(scene: &str) -> f64 {
    match scene {
        "demo" => 0.99,
        "munich" => 0.99,
        "etoile" => 0.99,
        "oa_shouse" => 0.98,
        "oa_dm1" => 0.98,
        "godot_room" => 0.97,
        "fzk_haus" => 0.98,
        _ => 0.5,
    }
}

/// Efficiency floors for the box test alone (`hom-raster`), as above.
fn box_floor(scene: &str) -> f64 {
    match scene {
        "demo" => 0.97,
        "munich" => 0.94,
        "etoile" => 0.84,
        "oa_shouse" => 0.72,
        "oa_dm1" => 0.73,
        "godot_room" => 0.70,
        "fzk_haus" => 0.37,
        _ => 0.5,
    }
}

fn check(scene: Scene) {
    check_on(scene.clone(), Backend::Native);
    if let Some(gpu) = common::gpu() {
        check_on(scene, Backend::Gpu(gpu));
    }
}

fn check_on(scene: Scene, backend: Backend) {
    let name = scene.name.clone();
    let pvs = Pvs::from_scene(&scene).map(|r| r.expect("the scene's PVS parses"));
    let accept = |p: glam::Vec3| pvs.as_ref().is_none_or(|v| v.cluster_at(p) >= 0);
    let sampled = PoseSampler::new(&scene).sample(POSES, 7, [960, 540], &accept);
    assert_eq!(
        sampled.poses.len(),
        POSES,
        "{name}: sampler found too few poses"
    );
    let cams: Vec<Camera> = sampled
        .poses
        .iter()
        .map(|p| Camera::new(p).unwrap())
        .collect();
    let methods: Vec<MethodSpec> = [
        "hom",
        "hom-raster",
        "hom-plane",
        "hom-tiles",
        "hzb",
        "frustum",
    ]
    .iter()
    .map(|m| MethodSpec::with_defaults(m).unwrap())
    .collect();
    let mut engine = Engine::new(scene, OccluderParams::default(), backend);
    let report = evaluate(&mut engine, &cams, &methods, 16, pvs.as_ref(), false).unwrap();
    eprintln!("{}", homcull::eval::table(&report));
    let label = format!("{name} ({})", engine.adapter());
    for (m, r) in &report.methods {
        assert_eq!(
            r.false_culls, 0,
            "{label}: {m} culled objects the oracle sees"
        );
        assert!(r.oracle_visible <= r.in_frustum);
    }
    let hom = &report.methods["hom"];
    assert!(
        hom.efficiency >= floor(&name),
        "{label}: hom efficiency {:.3} below floor {}",
        hom.efficiency,
        floor(&name)
    );
    let boxes = &report.methods["hom-raster"];
    assert!(
        boxes.efficiency >= box_floor(&name),
        "{label}: hom-raster (box test alone) efficiency {:.3} below floor {}",
        boxes.efficiency,
        box_floor(&name)
    );
    assert!(
        hom.efficiency >= boxes.efficiency,
        "{label}: the refinement only removes objects"
    );
    assert!(report.methods["frustum"].efficiency == 0.0);
    if let Some(check) = &report.pvs {
        assert!(
            check.poses_checked as usize >= POSES / 2,
            "{label}: too few poses inside a cluster"
        );
        eprintln!(
            "{label}: hom keeps {} objects the PVS proves hidden",
            hom.kept_pvs_hidden.unwrap_or(0)
        );
        // Every object the GPU oracle sees outside the map's PVS must be explained: an
        // object holding copies of brush-model faces (oa_dm1's cluster_0: the PVS data
        // cannot cover those, see `pvs::audit`), or one the CPU twin of the oracle does
        // not see at that pose (a crack: the GPU, which snaps vertices to a fixed-point
        // grid, leaves a pixel between nearer triangles uncovered that exact arithmetic
        // covers; oa_shouse pose 8 sees 10.06 m deep at one pixel where the CPU sees a
        // wall at 7.82 m). The CPU oracle is audited pixel by pixel in `pvs_oracle.rs`.
        eprintln!("{label}: {}", check.summary());
        assert_eq!(
            check.unexplained, 0,
            "{label}: the oracle sees objects the PVS rules out: {:?}",
            check.sightings
        );
        assert_eq!(
            check.brush_model_copies + check.cracks,
            check.oracle_outside_pvs
        );
        assert!(
            check.cracks as usize * 100 <= POSES,
            "{label}: {} GPU-only sightings outside the PVS in {POSES} poses",
            check.cracks
        );
    }
}

fn shared(file: &str) {
    let Some(dir) = common::scenes_dir() else {
        return;
    };
    check(load_path(&dir.join(file)).expect("shared scene loads"));
}

#[test]
fn demo_city_is_conservative_and_efficient() {
    check(demo_city());
}

#[test]
fn munich() {
    shared("munich.glb");
}

#[test]
fn etoile() {
    shared("etoile.glb");
}

#[test]
fn oa_shouse() {
    shared("oa_shouse.glb");
}

#[test]
fn oa_dm1() {
    shared("oa_dm1.glb");
}

#[test]
fn godot_room() {
    shared("godot_room.glb");
}

#[test]
fn fzk_haus() {
    shared("fzk_haus.glb");
}
