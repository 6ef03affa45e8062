use glam::Vec3;
use homcull_proto::{CullOptions, Method, Pose, Region as WireRegion};

use super::*;
use crate::occluders::OccluderParams;
use crate::scene::{Scene, SceneBuilder};

/// A quad at view depth `depth` (the eye at the origin looks along −Z) over
/// `x0..x1` and `y0..y1`, as two triangles sharing a diagonal.
fn wall(b: &mut SceneBuilder, name: &str, depth: f32, [x0, x1]: [f32; 2], [y0, y1]: [f32; 2]) {
    let z = -depth;
    let v = [
        Vec3::new(x0, y0, z),
        Vec3::new(x1, y0, z),
        Vec3::new(x1, y1, z),
        Vec3::new(x0, y1, z),
    ];
    b.push(name.into(), &v, &[0, 1, 2, 0, 2, 3], None);
}

/// A small cube of side `side` centred at `c`.
fn cube(b: &mut SceneBuilder, name: &str, c: Vec3, side: f32) -> u32 {
    let h = side * 0.5;
    let v: Vec<Vec3> = (0..8)
        .map(|i| {
            c + Vec3::new(
                if i & 1 == 0 { -h } else { h },
                if i & 2 == 0 { -h } else { h },
                if i & 4 == 0 { -h } else { h },
            )
        })
        .collect();
    let f = [
        0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1, 2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4,
        1, 5, 7, 1, 7, 3,
    ];
    b.push(name.into(), &v, &f, None)
}

fn answer(scene: Scene, radius_m: f32) -> Vec<u32> {
    let prep = PreparedScene::new(scene, OccluderParams::default());
    let mut pose = Pose::looking_at([0.0, 0.0, 0.0], [0.0, 0.0, -1.0]);
    pose.region = Some(WireRegion {
        radius_m: Some(radius_m),
        ..WireRegion::default()
    });
    let cam = Camera::new(&pose).unwrap();
    let s = CullSettings::new(CullOptions::default(), &prep);
    cull(&prep, &cam, cam.region.as_ref().unwrap(), &s).visible
}

#[test]
fn a_box_behind_one_wall_is_hidden_from_the_whole_ball() {
    let mut b = SceneBuilder::default();
    wall(&mut b, "wall", 10.0, [-20.0, 20.0], [-10.0, 10.0]);
    let hidden = cube(&mut b, "behind", Vec3::new(0.0, 0.0, -30.0), 0.5);
    let visible = answer(b.build("one wall"), 0.5);
    assert!(!visible.contains(&hidden), "visible: {visible:?}");
}

#[test]
fn the_slit_between_two_walls_whose_edges_meet_in_the_centres_image_stays_open() {
    // Wall A (depth 10) covers x < 0, wall B (depth 20) x > 0: from the centre they
    // meet at x = 0 and cover the whole view, but an eye 0.5 m to the right sees
    // between them. The cube lies behind A from the centre and in that slit.
    let r = 0.5;
    let mut b = SceneBuilder::default();
    wall(&mut b, "near", 10.0, [-20.0, 0.0], [-10.0, 10.0]);
    wall(&mut b, "far", 20.0, [0.0, 40.0], [-20.0, 20.0]);
    let slit = cube(&mut b, "in the slit", Vec3::new(-0.35, 0.0, -30.0), 0.1);
    let eye = Vec3::new(r, 0.0, 0.0);
    // The eye's ray to the cube passes right of A's edge and left of B's.
    let (at_a, at_b) = (
        eye.x + (-0.35 - eye.x) * (10.0 / 30.0),
        eye.x + (-0.35 - eye.x) * (20.0 / 30.0),
    );
    assert!(at_a > 0.0 && at_b < 0.0, "the slit is open: {at_a} {at_b}");
    let visible = answer(b.build("two walls"), r);
    assert!(visible.contains(&slit), "the slit's cube was culled");
}

#[test]
fn every_method_but_exact_answers_for_a_region_and_frustum_keeps_its_candidates() {
    let mut b = SceneBuilder::default();
    wall(&mut b, "wall", 10.0, [-20.0, 20.0], [-10.0, 10.0]);
    cube(&mut b, "behind", Vec3::new(0.0, 0.0, -30.0), 0.5);
    let prep = PreparedScene::new(b.build("one wall"), OccluderParams::default());
    let mut pose = Pose::looking_at([0.0, 0.0, 0.0], [0.0, 0.0, -1.0]);
    pose.region = Some(WireRegion {
        radius_m: Some(0.5),
        turn_deg: Some(10.0),
        ..WireRegion::default()
    });
    let cam = Camera::new(&pose).unwrap();
    let opts = |method| CullOptions {
        method,
        ..CullOptions::default()
    };
    let frustum = CullSettings::new(opts(Method::Frustum), &prep);
    let r = cull(&prep, &cam, cam.region.as_ref().unwrap(), &frustum);
    assert_eq!(r.visible, r.candidates);
    assert_eq!(r.visible, vec![0, 1]);
    let hzb = CullSettings::new(opts(Method::Hzb), &prep);
    assert_eq!(
        cull(&prep, &cam, cam.region.as_ref().unwrap(), &hzb).visible,
        vec![0]
    );
}

#[test]
fn bad_regions_are_refused_naming_the_field() {
    let mut pose = Pose::looking_at([0.0, 1.7, 0.0], [10.0, 1.7, 0.0]);
    let cases: [(WireRegion, &str); 7] = [
        (WireRegion::default(), "region"),
        (
            WireRegion {
                radius_m: Some(-1.0),
                ..Default::default()
            },
            "region.radius_m",
        ),
        (
            WireRegion {
                radius_m: Some(f32::NAN),
                ..Default::default()
            },
            "region.radius_m",
        ),
        (
            WireRegion {
                radius_m: Some(6.0),
                ..Default::default()
            },
            "region.radius_m",
        ),
        (
            WireRegion {
                radius_m: Some(1.0),
                bounds: Some([[0.0; 3], [1.0; 3]]),
                ..Default::default()
            },
            "region",
        ),
        (
            WireRegion {
                bounds: Some([[1.0, 0.0, -1.0], [2.0, 2.0, 1.0]]),
                ..Default::default()
            },
            "region.box",
        ),
        (
            WireRegion {
                radius_m: Some(1.0),
                turn_deg: Some(5.0),
                all_directions: true,
                ..Default::default()
            },
            "region.turn_deg",
        ),
    ];
    for (region, field) in cases {
        pose.region = Some(region);
        match Camera::new(&pose) {
            Err(crate::camera::PoseError::Region { field: f, .. }) => {
                assert_eq!(f, field, "{region:?}")
            }
            other => panic!("{region:?} gave {other:?}"),
        }
    }
}

#[test]
fn walls_of_two_objects_that_meet_edge_to_edge_hide_what_is_behind_their_seam() {
    // Two coplanar walls, separate objects: neither edge at x = 0 has a neighbour in
    // its own mesh, but each lies along the other wall's edge, so the surface is whole.
    let mut b = SceneBuilder::default();
    wall(&mut b, "left", 10.0, [-20.0, 0.0], [-10.0, 10.0]);
    wall(&mut b, "right", 10.0, [0.0, 20.0], [-10.0, 10.0]);
    let behind = cube(&mut b, "behind the seam", Vec3::new(0.0, 0.0, -30.0), 0.5);
    let visible = answer(b.build("two walls, one plane"), 0.5);
    assert!(!visible.contains(&behind), "visible: {visible:?}");
}

#[test]
fn a_wall_standing_on_the_ground_hides_what_is_behind_its_foot() {
    // The wall's foot lies inside the ground's triangles (crossing their diagonal),
    // which run past the eye: only their part beyond the clip depth is drawn.
    let mut b = SceneBuilder::default();
    let y = -1.7;
    wall(&mut b, "wall", 10.0, [-20.0, 20.0], [y, 10.0]);
    let ground = [
        Vec3::new(-40.0, y, 5.0),
        Vec3::new(40.0, y, 5.0),
        Vec3::new(40.0, y, -40.0),
        Vec3::new(-40.0, y, -40.0),
    ];
    b.push("ground".into(), &ground, &[0, 2, 1, 0, 3, 2], None);
    let low = cube(&mut b, "low, behind", Vec3::new(0.0, y + 0.3, -12.0), 0.5);
    let visible = answer(b.build("wall on the ground"), 0.5);
    assert!(!visible.contains(&low), "visible: {visible:?}");
}
