//! The exact oracle against the OpenArena maps' own PVS, pixel by pixel.
//!
//! The PVS was computed offline by q3map's vis, an algorithm unrelated to ours. For
//! every pixel the CPU twin of the exact oracle covers, the point it sees (stepped back
//! towards the eye) must lie in a cluster the camera cluster's PVS row lists
//! (`pvs::audit`). At object level the maps' face-to-object assignment has one known
//! flaw (objects holding copies of brush-model faces, see `pvs::audit`), so every
//! object the oracle sees outside the PVS must be one of those copies. The GPU oracle's
//! object-level sightings are checked against this in `real_scenes.rs`.

use crate::common;

use homcull::core::camera::Camera;
use homcull::core::pvs::Pvs;
use homcull::core::sampler::PoseSampler;
use homcull::core::scene::load_path;
use homcull::eval::pvs_audit::{audit_pixels, brush_model_copies};
use rayon::prelude::*;

/// Same poses as `real_scenes.rs`: 200 street-level poses, seed 7, 960×540.
const POSES: usize = 200;

fn audit(file: &str, expected_copies: &[&str]) {
    let Some(dir) = common::scenes_dir() else {
        return;
    };
    let scene = load_path(&dir.join(file)).expect("shared scene loads");
    let pvs = Pvs::from_scene(&scene)
        .expect("the map has a PVS")
        .expect("its PVS parses");
    let copies = brush_model_copies(&scene);
    let names: Vec<&str> = copies
        .iter()
        .map(|&o| scene.objects[o as usize].name.as_str())
        .collect();
    assert_eq!(
        names, expected_copies,
        "{file}: objects holding brush-model copies"
    );

    let accept = |p: glam::Vec3| pvs.cluster_at(p) >= 0;
    let sampled = PoseSampler::new(&scene).sample(POSES, 7, [960, 540], &accept);
    assert_eq!(sampled.poses.len(), POSES);
    let audits: Vec<_> = sampled
        .poses
        .par_iter()
        .map(|p| audit_pixels(&pvs, &scene, &Camera::new(p).unwrap()).expect("eye in a cluster"))
        .collect();

    let pixels: u64 = audits.iter().map(|a| a.pixels).sum();
    let outside: u64 = audits.iter().map(|a| a.outside).sum();
    let solid: u64 = audits.iter().map(|a| a.solid).sum();
    let mut sightings = 0;
    for (k, a) in audits.iter().enumerate() {
        for &o in a.visible.iter().filter(|&&o| !pvs.may_see(a.cluster, o)) {
            sightings += 1;
            assert!(
                copies.contains(&o),
                "{file}: pose {k} (cluster {}) sees object {o} ({}), which the PVS rules out \
                 and which holds no brush-model copies",
                a.cluster,
                scene.objects[o as usize].name
            );
        }
    }
    eprintln!(
        "{file}: {pixels} pixels in {POSES} poses, {outside} seen outside the PVS, {solid} \
         unresolved (stepped-back point in solid); {sightings} object-level sightings, \
         all of brush-model copies {copies:?}"
    );
    assert_eq!(
        outside, 0,
        "{file}: pixels seen in clusters the PVS rules out"
    );
    assert!(
        solid * 1000 <= pixels,
        "{file}: {solid} of {pixels} pixels unresolved: the audit checks too little"
    );
    assert!(
        pixels >= POSES as u64 * 960 * 540 / 2,
        "{file}: too few pixels covered"
    );
}

#[test]
fn oa_shouse_oracle_pixels_lie_in_the_pvs() {
    audit("oa_shouse.glb", &[]);
}

#[test]
fn oa_dm1_oracle_pixels_lie_in_the_pvs() {
    // cluster_0 holds copies of all six brush models' faces (doors and lifts),
    // cluster_360 two of model_1's.
    audit("oa_dm1.glb", &["cluster_0", "cluster_360"]);
}
