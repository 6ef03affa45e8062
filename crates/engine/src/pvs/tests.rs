//! Parsing and queries of the PVS on hand-made maps, and on a real one when present.

use super::*;
use crate::scene::SceneBuilder;
use serde_json::json;

/// Two leaves split by the plane x = 1: front (x ≥ 1) is cluster 0, back is
/// `back_cluster`. Cluster 0 sees only itself; cluster 1 sees both.
fn tiny_extras(back_cluster: i64) -> Value {
    json!({
        "pvs": { "num_clusters": 2, "bytes_per_cluster": 1, "visible": { "0": [0], "1": [0, 1] } },
        "bsp": {
            "planes": [[1.0, 0.0, 0.0, 1.0]],
            "nodes": [[0, -1, -2]],
            "leaf_cluster": [0, back_cluster],
        }
    })
}

/// Objects: in cluster 0, in cluster 1, a brush model in cluster 1, a brush model
/// in solid, one without extras.
fn tiny_scene(extras: Value) -> Scene {
    let mut b = SceneBuilder::default();
    let tri = [Vec3::ZERO, Vec3::X, Vec3::Z];
    let objects = [
        Some(json!({ "cluster": 0, "ref_clusters": [0] })),
        Some(json!({ "cluster": 1, "ref_clusters": [1] })),
        Some(json!({ "model": 1, "cluster": 1 })),
        Some(json!({ "model": 2, "cluster": -1 })),
        None,
    ];
    for (i, e) in objects.into_iter().enumerate() {
        b.push(format!("o{i}"), &tri, &[0, 1, 2], e);
    }
    let mut scene = b.build("tiny");
    scene.extras = Some(extras);
    scene
}

fn parse(extras: Value) -> Result<Pvs, PvsError> {
    Pvs::from_scene(&tiny_scene(extras)).expect("scene has a pvs")
}

#[test]
fn tiny_bsp_and_pvs() {
    let pvs = parse(tiny_extras(1)).unwrap();
    assert_eq!(pvs.num_clusters(), 2);
    assert_eq!(pvs.cluster_at(Vec3::new(5.0, 0.0, 0.0)), 0);
    assert_eq!(
        pvs.cluster_at(Vec3::new(1.0, 0.0, 0.0)),
        0,
        "on the plane counts as front"
    );
    assert_eq!(pvs.cluster_at(Vec3::new(-5.0, 0.0, 0.0)), 1);
    // From cluster 0 only cluster 0's object (and the unknowns) may be seen.
    assert_eq!(pvs.visible_objects(0), vec![0, 3, 4]);
    assert_eq!(pvs.visible_objects(1), vec![0, 1, 2, 3, 4]);
    assert!(!pvs.may_see(0, 1) && !pvs.may_see(0, 2));
    // From solid nothing; unknown objects and clusters stay conservative.
    assert!(!pvs.may_see(-1, 0) && !pvs.may_see(-1, 4));
    assert!(pvs.may_see(0, 99) && pvs.may_see(7, 1));
    // Cluster to cluster: the rows as given; a point in solid is not ruled out.
    assert!(pvs.cluster_may_see(0, 0) && !pvs.cluster_may_see(0, 1));
    assert!(pvs.cluster_may_see(1, 0) && pvs.cluster_may_see(1, 1));
    assert!(!pvs.cluster_may_see(-1, 0) && pvs.cluster_may_see(0, -1));
}

#[test]
fn solid_leaf_has_cluster_minus_one() {
    let pvs = parse(tiny_extras(-1)).unwrap();
    assert_eq!(pvs.cluster_at(Vec3::new(-5.0, 0.0, 0.0)), -1);
    assert_eq!(pvs.visible_objects(-1), Vec::<u32>::new());
}

#[test]
fn no_pvs_is_none() {
    let mut scene = tiny_scene(json!({}));
    assert!(Pvs::from_scene(&scene).is_none());
    scene.extras = None;
    assert!(Pvs::from_scene(&scene).is_none());
}

#[test]
fn missing_row_sees_everything() {
    let mut e = tiny_extras(1);
    e["pvs"]["visible"] = json!({ "1": [1] });
    let pvs = parse(e).unwrap();
    assert_eq!(pvs.visible_objects(0), vec![0, 1, 2, 3, 4]);
    assert_eq!(pvs.visible_objects(1), vec![1, 2, 3, 4]);
}

#[test]
fn malformed_data_is_an_error() {
    type Breakage = (&'static str, fn(&mut Value));
    let broken: [Breakage; 10] = [
        ("no bsp", |e| e["bsp"] = Value::Null),
        ("node child past the end", |e| {
            e["bsp"]["nodes"] = json!([[0, 1, -1]])
        }),
        ("leaf past the end", |e| {
            e["bsp"]["nodes"] = json!([[0, -1, -3]])
        }),
        ("plane past the end", |e| {
            e["bsp"]["nodes"] = json!([[1, -1, -2]])
        }),
        ("cycle", |e| {
            e["bsp"]["nodes"] = json!([[0, 1, -1], [0, 0, -2]])
        }),
        ("no nodes", |e| e["bsp"]["nodes"] = json!([])),
        ("plane not numbers", |e| {
            e["bsp"]["planes"] = json!([[1.0, "a", 0.0, 0.0]])
        }),
        ("row cluster out of range", |e| {
            e["pvs"]["visible"]["0"] = json!([0, 2])
        }),
        ("row key not a number", |e| {
            e["pvs"]["visible"] = json!({ "x": [0] })
        }),
        ("too many clusters", |e| {
            e["pvs"]["num_clusters"] = json!(1u64 << 40)
        }),
    ];
    for (what, breaks) in broken {
        let mut e = tiny_extras(1);
        breaks(&mut e);
        if what == "no bsp" {
            e.as_object_mut().unwrap().remove("bsp");
        }
        assert!(parse(e).is_err(), "{what} was accepted");
    }
    // Object extras are checked too.
    let mut scene = tiny_scene(tiny_extras(1));
    scene.objects[0].extras = Some(json!({ "ref_clusters": [5] }));
    assert!(matches!(
        Pvs::from_scene(&scene),
        Some(Err(PvsError::OutOfRange { .. }))
    ));
}

/// Probe points 5 cm in front of the triangles of oa_dm1's cluster objects land in
/// open space and the PVS from there marks the object visible (README: ~97 % and
/// 100 %).
#[test]
fn oa_dm1_probes_see_their_own_faces() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../shared/scenes");
    let path = std::path::Path::new(dir).join("oa_dm1.glb");
    if !path.exists() {
        eprintln!("skipping: {} not found", path.display());
        return;
    }
    let scene = crate::scene::load_path(&path).expect("oa_dm1.glb loads");
    let pvs = Pvs::from_scene(&scene)
        .expect("oa_dm1 has a PVS")
        .expect("its PVS parses");
    let (mut probes, mut in_open, mut seen) = (0usize, 0usize, 0usize);
    for o in scene
        .objects
        .iter()
        .filter(|o| o.name.starts_with("cluster_"))
    {
        for [a, b, c] in scene.corners_of(o) {
            let normal = (b - a).cross(c - a).normalize_or_zero();
            if normal == Vec3::ZERO {
                continue;
            }
            probes += 1;
            let cluster = pvs.cluster_at((a + b + c) / 3.0 + normal * 0.05);
            if cluster >= 0 {
                in_open += 1;
                seen += usize::from(pvs.may_see(cluster, o.id));
            }
        }
    }
    let open_fraction = in_open as f64 / probes as f64;
    let seen_fraction = seen as f64 / in_open as f64;
    eprintln!(
        "oa_dm1: {probes} probes, {:.1} % in open clusters, PVS sees {:.2} % of those",
        100.0 * open_fraction,
        100.0 * seen_fraction
    );
    assert!(probes > 1000);
    assert!(open_fraction > 0.9, "{open_fraction}");
    assert!(seen_fraction > 0.99, "{seen_fraction}");
}

#[test]
fn a_box_reaches_the_clusters_of_the_leaves_it_straddles() {
    let pvs = parse(tiny_extras(1)).unwrap();
    let b = |x0: f32, x1: f32| Aabb::new(Vec3::new(x0, -1.0, -1.0), Vec3::new(x1, 1.0, 1.0));
    assert_eq!(pvs.clusters_touching(&b(0.0, 2.0)), vec![0, 1]);
    assert_eq!(pvs.clusters_touching(&b(1.5, 2.0)), vec![0]);
    assert_eq!(
        pvs.clusters_touching(&b(1.0, 2.0)),
        vec![0],
        "on the plane is front"
    );
    assert_eq!(pvs.clusters_touching(&b(-3.0, 0.5)), vec![1]);
    let solid_behind = parse(tiny_extras(-1)).unwrap();
    assert!(solid_behind.clusters_touching(&b(-3.0, 0.5)).is_empty());
    assert_eq!(solid_behind.clusters_touching(&b(0.0, 2.0)), vec![0]);
}
