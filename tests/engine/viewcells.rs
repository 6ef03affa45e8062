//! View-cell PVS (`core::viewcells`) against the exact oracle: nothing an eye in a
//! cell sees, looking any way, may be missing from the cell's set; on the demo
//! city's grid cells and on oa_dm1's vis clusters (with the map's own PVS beside
//! it).

use crate::common;
use homcull::eval::region_eyes::Xorshift as Rng;

use glam::Vec3;
use homcull::core::camera::Camera;
use homcull::core::cull::{CullSettings, Culler, PreparedScene};
use homcull::core::geom::Aabb;
use homcull::core::native::NativeBackend;
use homcull::core::occluders::OccluderParams;
use homcull::core::pvs::Pvs;
use homcull::core::region;
use homcull::core::sampler::PoseSampler;
use homcull::core::scene::{demo_city, load_path};
use homcull::core::viewcells::{self, ViewCells};
use homcull_proto::{DebVariant, Method, Pose};

/// Maps coarse enough to keep the test quick (0.37° cells); the answer holds at any.
const VIEWPORT: [u32; 2] = [320, 180];
const FOV_Y_DEG: f32 = 60.0;

/// Eyes in box `b` (its centre, two opposite corners, random points) that `accept`
/// takes, at most `n`, each looking along the six axes with a 90° view.
fn eye_cameras(rng: &mut Rng, b: &Aabb, n: usize, accept: &dyn Fn(Vec3) -> bool) -> Vec<Camera> {
    let inset = Aabb::new(b.min + 1e-3, b.max - 1e-3);
    let mut eyes = vec![inset.center(), inset.min, inset.max];
    for _ in 0..4 * n {
        let t = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        eyes.push(inset.min + (inset.max - inset.min) * t);
    }
    eyes.into_iter()
        .filter(|&e| accept(e))
        .take(n)
        .flat_map(|e| {
            region::CUBE_FACES.map(|(d, up)| {
                let pose = Pose {
                    position: e.to_array(),
                    rotation: None,
                    look_at: Some((e + d).to_array()),
                    up: Some(up.to_array()),
                    fov_y_deg: 90.0,
                    viewport: [128, 128],
                    near: 0.1,
                    far: 1000.0,
                    stereo: None,
                    region: None,
                };
                Camera::new(&pose).unwrap()
            })
        })
        .collect()
}

/// Answers every box of `cells`, then checks each cell's set against the exact
/// oracle at up to `eyes` eyes per box: returns each cell's (set size, eyes used,
/// objects seen).
fn check(
    name: &str,
    prep: &PreparedScene,
    cells: &ViewCells,
    eyes: usize,
    accept: &dyn Fn(usize, Vec3) -> bool,
) -> Vec<(usize, usize, usize)> {
    let hom = common::scenes::settings(prep, Method::Hom, DebVariant::Raster, false);
    let exact: CullSettings =
        common::scenes::settings(prep, Method::Exact, DebVariant::Raster, false);
    let far = 2.0 * prep.scene.bounds.diagonal();
    let answers =
        viewcells::answer_boxes(prep, &cells.boxes, VIEWPORT, FOV_Y_DEG, far, &hom, &|_| {})
            .unwrap();
    let mut rng = Rng(0x5EED_CE11);
    let mut out = Vec::new();
    for (k, cell) in cells.cells.iter().enumerate() {
        let set = viewcells::cell_set(cell, &answers);
        let (mut used, mut seen) = (0, Vec::new());
        for &b in &cell.boxes {
            let cams = eye_cameras(&mut rng, &cells.boxes[b as usize], eyes, &|e| accept(k, e));
            used += cams.len() / 6;
            for oracle in NativeBackend.cull(prep, &cams, &exact).unwrap() {
                seen = homcull::core::cull::union(&seen, &oracle.visible);
            }
        }
        let lost: Vec<u32> = seen
            .iter()
            .copied()
            .filter(|id| set.binary_search(id).is_err())
            .collect();
        assert!(
            lost.is_empty(),
            "{name} {}: eyes in the cell see {lost:?}, not in its set",
            cell.name
        );
        out.push((set.len(), used, seen.len()));
    }
    out
}

#[test]
fn a_grid_cell_holds_what_its_eyes_see_on_the_demo_street() {
    let prep = PreparedScene::new(demo_city(), OccluderParams::default());
    let sampler = PoseSampler::new(&prep.scene);
    let (start, _) = sampler
        .walk_start(&|_| true)
        .expect("the demo has a street");
    let around = Aabb::new(
        start - Vec3::new(2.0, 5.0, 2.0),
        start + Vec3::new(2.0, 5.0, 2.0),
    );
    let cells = viewcells::grid_cells(&sampler, &around, 1.0, &|_| true);
    assert!(cells.cells.len() >= 2, "the street holds standing eyes");
    for b in &cells.boxes {
        assert!(
            b.extent().max_element() <= 1.0 + 1e-4,
            "boxes are at most a cell"
        );
    }
    let checked = check("demo", &prep, &cells, 8, &|_, _| true);
    let objects = prep.scene.objects.len();
    for (set, used, seen) in &checked {
        eprintln!("demo street cell: {set} of {objects} objects kept, {seen} seen by {used} eyes");
        assert!(*used >= 8, "every cell checked from 8 eyes or more");
        assert!(
            *set < objects * 3 / 4,
            "a street cell culls a quarter of the city"
        );
    }
}

#[test]
fn a_cluster_cell_holds_what_its_eyes_see_on_oa_dm1() {
    let Some(dir) = common::scenes_dir() else {
        return;
    };
    let scene = load_path(&dir.join("oa_dm1.glb")).expect("oa_dm1 loads");
    let pvs = Pvs::from_scene(&scene).unwrap().unwrap();
    // Every point of a box lies in a cluster the box reaches.
    let mut rng = Rng(3);
    let bounds = scene.bounds;
    for _ in 0..2000 {
        let t = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let p = bounds.min + (bounds.max - bounds.min) * t;
        let b = Aabb::new(
            p - Vec3::splat(rng.next_f32()),
            p + Vec3::splat(rng.next_f32()),
        );
        let c = pvs.cluster_at(p);
        assert!(
            c < 0 || pvs.clusters_touching(&b).contains(&c),
            "{p} in {c}"
        );
    }
    // The clusters covered by a single 2 m box, a few of them.
    let all = viewcells::cluster_cells(&pvs, &bounds, 2.0, None);
    let small: Vec<i32> = all
        .cells
        .iter()
        .filter(|c| c.boxes.len() == 1)
        .filter_map(|c| c.cluster)
        .take(3)
        .collect();
    assert!(!small.is_empty(), "oa_dm1 has clusters within one box");
    let cells = viewcells::cluster_cells(&pvs, &bounds, 2.0, Some(&small));
    let prep = PreparedScene::new(scene, OccluderParams::default());
    let in_cluster = |k: usize, e: Vec3| Some(pvs.cluster_at(e)) == cells.cells[k].cluster;
    let checked = check("oa_dm1", &prep, &cells, 8, &in_cluster);
    for (cell, (set, used, seen)) in cells.cells.iter().zip(&checked) {
        let map = pvs.visible_objects(cell.cluster.unwrap()).len();
        eprintln!(
            "oa_dm1 {}: {set} objects kept, the map's PVS {map}, {seen} seen by {used} eyes",
            cell.name
        );
    }
}
