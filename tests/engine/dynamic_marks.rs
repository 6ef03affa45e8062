//! Objects marked dynamic in advance, end to end: by glTF node extras (the demo
//! city's cars, a file written with the mark) and by the upload's `dynamic`
//! parameter; reported in the objects list and the scene's info, kept across a
//! restart; bad patterns refused with `bad_dynamic` and nothing stored; a marked
//! object moves, and an unmarked one may too.

use crate::common;

use common::rest::{error_of, small_glb};
use common::server::{TestServer, get_json, post_json};
use homcull::core::scene::{SceneBuilder, load_glb_bytes_within, write_glb};
use homcull_proto::{ObjectList, SceneInfo, SceneList, TransformsResponse};
use serde_json::json;

fn marked(list: &ObjectList) -> Vec<&str> {
    (list.objects.iter().filter(|o| o.dynamic))
        .map(|o| o.name.as_str())
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn uploads_mark_objects_dynamic_and_a_restart_keeps_the_marks() {
    let dir = tempfile::tempdir().unwrap();
    let http = reqwest::Client::new();
    let srv = TestServer::start_in(dir.path(), |_| {}).await;
    let upload = |q: &str| {
        http.post(srv.url(&format!("/v1/scenes?name=small{q}")))
            .body(small_glb())
            .send()
    };
    // Bad lists: refused before anything is stored, saying what is wrong.
    for (q, says) in [
        ("&dynamic=", "empty"),
        ("&dynamic=wall,,hidden", "empty"),
        ("&dynamic=w*ll", "*"),
        ("&dynamic=car_*", "car_*"),
        ("&dynamic=hid", "hid"),
    ] {
        let r = upload(q).await.unwrap();
        assert_eq!(r.status(), 400, "{q}");
        let body: homcull_proto::ErrorBody = r.json().await.unwrap();
        assert_eq!(body.error.code, "bad_dynamic", "{q}");
        assert!(
            body.error.message.contains(says),
            "{q}: {}",
            body.error.message
        );
    }
    let scenes: SceneList = get_json(&http, srv.url("/v1/scenes")).await;
    assert_eq!(scenes.scenes.len(), 1, "only the demo: nothing stored");
    // A name and a prefix.
    let r = upload("&dynamic=hidden,bes*").await.unwrap();
    assert_eq!(r.status(), 201);
    let info: SceneInfo = r.json().await.unwrap();
    assert_eq!(info.dynamic_objects, 2);
    let objects = format!("/v1/scenes/{}/objects", info.id);
    let list: ObjectList = get_json(&http, srv.url(&objects)).await;
    assert_eq!(marked(&list), ["hidden", "beside"]);
    // Marked or not, objects move.
    let moved: TransformsResponse = post_json(
        &http,
        srv.url(&format!("/v1/scenes/{}/transforms", info.id)),
        &json!({"objects": [{"id": 1, "translation": [0, 3, 0]}, {"id": 0, "translation": [1, 0, 0]}]}),
    )
    .await;
    assert_eq!(moved.version, 1);
    srv.stop().await;

    let srv = TestServer::start_in(dir.path(), |_| {}).await;
    let list: ObjectList = get_json(&http, srv.url(&objects)).await;
    assert_eq!(marked(&list), ["hidden", "beside"], "marks after a restart");
    let again: SceneInfo = get_json(&http, srv.url(&format!("/v1/scenes/{}", info.id))).await;
    assert_eq!(again.dynamic_objects, 2);
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn node_extras_mark_objects_and_the_demo_cars_are_marked() {
    let http = reqwest::Client::new();
    let srv = TestServer::start(|_| {}).await;
    // The demo city marks its cars, and only its cars.
    let demo: ObjectList = get_json(&http, srv.url("/v1/scenes/demo/objects")).await;
    let cars = demo.objects.iter().filter(|o| o.name.starts_with("car_"));
    assert!(cars.clone().count() > 100);
    assert!(cars.clone().all(|o| o.dynamic), "every car is marked");
    let others = demo.objects.iter().filter(|o| !o.name.starts_with("car_"));
    assert!(others.clone().all(|o| !o.dynamic), "nothing else is");

    // A file whose node extras mark one object (and one that only looks like a mark).
    let mut b = SceneBuilder::default();
    let v: Vec<glam::Vec3> = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0)]
        .map(|(x, y)| glam::Vec3::new(x, y, -5.0))
        .to_vec();
    let mark = json!({"homcull": {"dynamic": true}});
    b.push("lift".into(), &v, &[0, 1, 2], Some(mark));
    b.push(
        "no".into(),
        &v,
        &[0, 1, 2],
        Some(json!({"homcull": {"dynamic": 1}})),
    );
    b.push("plain".into(), &v, &[0, 1, 2], None);
    let glb = write_glb(&b.build("marked"));
    // The mark survives writing and reading the file.
    let limits = homcull::core::scene::LoadLimits::default();
    let read = load_glb_bytes_within(&glb, "marked", &limits).unwrap();
    let flags: Vec<bool> = read.objects.iter().map(|o| o.dynamic).collect();
    assert_eq!(flags, [true, false, false]);
    let r = http
        .post(srv.url("/v1/scenes?name=marked&dynamic=plain"))
        .body(glb)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 201);
    let info: SceneInfo = r.json().await.unwrap();
    let list: ObjectList =
        get_json(&http, srv.url(&format!("/v1/scenes/{}/objects", info.id))).await;
    assert_eq!(marked(&list), ["lift", "plain"]);
    // The error of a pattern matching nothing names the pattern.
    let r = http
        .post(srv.url("/v1/scenes?name=marked&dynamic=door_*"))
        .body(small_glb())
        .send()
        .await
        .unwrap();
    assert_eq!(error_of(r).await, (400, "bad_dynamic".to_string()));
    srv.stop().await;
}
