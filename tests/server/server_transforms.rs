//! `POST /v1/scenes/{id}/transforms` end to end: an object moved in front of the eye
//! appears in the next answer, which names the new version; an object sent back home
//! disappears again; every bad update gets its JSON error and changes nothing (the
//! version stays, the answers stay); the write token guards it.

use crate::common;

use common::rest::{error_of, pose_json};
use common::server::{TestServer, get_json, post_json, street_walk};
use glam::Vec3;
use homcull::core::camera::Camera;
use homcull::server::StateMode;
use homcull_proto::{CullResponse, ObjectList, TransformsResponse};
use serde_json::{Value, json};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn moved_objects_show_in_the_next_answer_and_bad_updates_change_nothing() {
    let srv = TestServer::start(|c| c.max_transform_objects = 4).await;
    let http = reqwest::Client::new();
    let pose = street_walk(1, [320, 180]).remove(0);
    let cull_url = srv.url("/v1/scenes/demo/cull");
    let cull = || async {
        let r: CullResponse =
            post_json(&http, cull_url.as_str(), &json!({"pose": pose_json(&pose)})).await;
        r
    };
    let before = cull().await;
    assert_eq!(before.stats.scene_version, 0);

    // A small solid object the pose does not see, moved 8 m in front of the eye.
    let objects: ObjectList = get_json(&http, srv.url("/v1/scenes/demo/objects")).await;
    let hidden = objects
        .objects
        .iter()
        .find(|o| {
            let size = Vec3::from(o.aabb[1]) - Vec3::from(o.aabb[0]);
            let solid = size.min_element() > 0.5 && size.length() < 20.0;
            solid && before.visible.binary_search(&o.id).is_err()
        })
        .expect("a small object out of sight");
    let cam = Camera::new(&pose).unwrap();
    let centre = (Vec3::from(hidden.aabb[0]) + Vec3::from(hidden.aabb[1])) * 0.5;
    let shift = cam.position + cam.forward() * 8.0 - centre;
    let url = srv.url("/v1/scenes/demo/transforms");
    let send = |body: Value| http.post(url.as_str()).json(&body).send();
    let moved: TransformsResponse = send(json!({"objects": [
        {"id": hidden.id, "translation": shift.to_array()}
    ]}))
    .await
    .unwrap()
    .json()
    .await
    .unwrap();
    assert_eq!((moved.version, moved.applied), (1, 1));
    let after = cull().await;
    assert_eq!(after.stats.scene_version, 1);
    assert!(
        after.visible.binary_search(&hidden.id).is_ok(),
        "object {} moved in front of the eye is not in the answer",
        hidden.id
    );
    // The object table says where it is now, where the file put it, and at what
    // version; every other object is where its file puts it.
    let listed: ObjectList = get_json(&http, srv.url("/v1/scenes/demo/objects")).await;
    assert_eq!(listed.version, 1);
    let o = &listed.objects[hidden.id as usize];
    assert_eq!(o.file_aabb, hidden.aabb);
    let moved_by = Vec3::from(o.aabb[0]) - Vec3::from(hidden.aabb[0]);
    assert!(moved_by.distance(shift) < 1e-2, "{moved_by} vs {shift}");
    let placement = o.placement.as_ref().expect("its placement");
    assert_eq!(placement.valid_ms, None, "no motion: until the next update");
    assert!(Vec3::from_slice(&placement.matrix[12..15]).distance(shift) < 1e-2);
    let unmoved = listed.objects.iter().filter(|o| o.id != hidden.id);
    assert!(
        unmoved
            .into_iter()
            .all(|o| o.placement.is_none() && o.aabb == o.file_aabb)
    );

    // Bad updates: each its error, none applied, the version and the answer stay.
    let n = objects.objects.len();
    let ok = json!({"id": hidden.id, "translation": [0, 0, 0]});
    let cases: Vec<(Value, u16, &str)> = vec![
        (
            json!({"objects": [ok, {"id": n, "translation": [1, 0, 0]}]}),
            400,
            "unknown_object",
        ),
        (
            json!({"objects": [ok, {"id": 0, "scale": [1, 0, 1]}]}),
            400,
            "invalid_transform",
        ),
        (
            json!({"objects": [ok, {"id": 0, "matrix": [1, 0, 0, 0.5, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}]}),
            400,
            "invalid_transform",
        ),
        (
            json!({"objects": [ok, {"id": 0, "velocity": [1e30, 0, 0]}]}),
            400,
            "invalid_transform",
        ),
        (json!({"objects": [ok, ok]}), 400, "invalid_transform"),
        (
            json!({"objects": [ok], "horizon_ms": -5}),
            400,
            "invalid_transform",
        ),
        (
            json!({"objects": [ok, {"id": 1}, {"id": 2}, {"id": 3}, {"id": 4}]}),
            413,
            "too_many_objects",
        ),
        (
            json!({"objects": [{"id": 0, "translation": [1, 0]}]}),
            400,
            "malformed_json",
        ),
        (
            json!({"objects": [{"id": 0, "colour": 1}]}),
            400,
            "malformed_json",
        ),
    ];
    for (body, status, code) in cases {
        let (got, text) = error_of(send(body.clone()).await.unwrap()).await;
        assert_eq!(got, status, "{body}: {text}");
        assert!(text.contains(code), "{body}: {text}");
    }
    let nan = http
        .post(url.as_str())
        .header("content-type", "application/json")
        .body(format!(
            r#"{{"objects": [{{"id": {}, "translation": [NaN, 0, 0]}}]}}"#,
            hidden.id
        ))
        .send()
        .await
        .unwrap();
    assert_eq!(error_of(nan).await.0, 400);
    let unknown_scene = http
        .post(srv.url("/v1/scenes/nope/transforms"))
        .json(&json!({"objects": []}))
        .send()
        .await
        .unwrap();
    assert_eq!(error_of(unknown_scene).await.0, 404);
    let same = cull().await;
    assert_eq!(
        same.stats.scene_version, 1,
        "a refused update made no version"
    );
    assert_eq!(same.visible, after.visible);

    // Back home: the answer is the first one again.
    let home: TransformsResponse = send(json!({"objects": [{"id": hidden.id}]}))
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(home.version, 2);
    let back = cull().await;
    assert_eq!(back.stats.scene_version, 2);
    assert_eq!(back.visible, before.visible);
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_write_token_guards_updates() {
    let srv = TestServer::start(|c| c.api_token = Some("s3cret".into())).await;
    let http = reqwest::Client::new();
    let url = srv.url("/v1/scenes/demo/transforms");
    let body = json!({"objects": [{"id": 0, "translation": [1, 0, 0]}]});
    let refused = http.post(url.as_str()).json(&body).send().await.unwrap();
    assert_eq!(error_of(refused).await.0, 401);
    let accepted = http
        .post(url.as_str())
        .bearer_auth("s3cret")
        .json(&body)
        .send()
        .await
        .unwrap();
    assert_eq!(accepted.status(), 200);
    let r: TransformsResponse = accepted.json().await.unwrap();
    assert_eq!(r.version, 1);
    srv.stop().await;
}

/// Two objects trade places at every version: at an odd version A stands in front of
/// the eye and B behind it, at an even one the other way round. While one writer
/// sends 200 updates, culls (single and batched) run beside them, and a scene is
/// uploaded and deleted over and over: every answer names a version, and shows exactly
/// the one of the two that stands in front at that version (a torn cull would show
/// both or neither); no update is lost (the versions run 1..=200 in order, and the
/// last answer names the last one).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn updates_racing_with_culls_uploads_and_deletes_never_tear() {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};

    const UPDATES: u64 = 200;
    let srv = Arc::new(TestServer::start(|_| {}).await);
    let http = reqwest::Client::new();
    let pose = street_walk(1, [160, 90]).remove(0);
    let cam = Camera::new(&pose).unwrap();
    let objects: ObjectList = get_json(&http, srv.url("/v1/scenes/demo/objects")).await;
    let mut solid = objects.objects.iter().filter(|o| {
        let size = Vec3::from(o.aabb[1]) - Vec3::from(o.aabb[0]);
        size.min_element() > 0.5 && size.length() < 10.0
    });
    let (a, b) = (solid.next().unwrap().clone(), solid.next().unwrap().clone());
    let right = cam.forward().cross(Vec3::Y).normalize();
    let shift = move |o: &homcull_proto::ObjectInfo, front: bool, side: f32| {
        let centre = (Vec3::from(o.aabb[0]) + Vec3::from(o.aabb[1])) * 0.5;
        let ahead = if front { 10.0 } else { -10.0 };
        (cam.position + cam.forward() * ahead + right * side - centre).to_array()
    };
    let updates: Vec<Value> = (1..=UPDATES)
        .map(|v| {
            let odd = v % 2 == 1;
            json!({"objects": [
                {"id": a.id, "translation": shift(&a, odd, -2.0)},
                {"id": b.id, "translation": shift(&b, !odd, 2.0)},
            ]})
        })
        .collect();
    let done = Arc::new(AtomicBool::new(false));

    let writer = {
        let (http, srv, done) = (http.clone(), srv.clone(), done.clone());
        tokio::spawn(async move {
            for (v, body) in (1..=UPDATES).zip(&updates) {
                let r: TransformsResponse =
                    post_json(&http, srv.url("/v1/scenes/demo/transforms"), body).await;
                assert_eq!(r.version, v, "versions follow the accepted updates");
                // Paced, so that culls fall between updates (~1.6 s in all).
                tokio::time::sleep(std::time::Duration::from_millis(8)).await;
            }
            done.store(true, Ordering::SeqCst);
        })
    };
    let churn = {
        let (http, srv, done) = (http.clone(), srv.clone(), done.clone());
        tokio::spawn(async move {
            let mut rounds = 0;
            while !done.load(Ordering::SeqCst) {
                let up = http
                    .post(srv.url("/v1/scenes?name=churn"))
                    .body(common::rest::small_glb())
                    .send()
                    .await
                    .unwrap();
                assert_eq!(up.status(), 201);
                let info: homcull_proto::SceneInfo = up.json().await.unwrap();
                let del = http
                    .delete(srv.url(&format!("/v1/scenes/{}", info.id)))
                    .send()
                    .await
                    .unwrap();
                assert_eq!(del.status(), 204);
                rounds += 1;
            }
            rounds
        })
    };
    let (a, b) = (a.id, b.id);
    let check = move |r: &CullResponse| {
        let v = r.stats.scene_version;
        let (has_a, has_b) = (
            r.visible.binary_search(&a).is_ok(),
            r.visible.binary_search(&b).is_ok(),
        );
        if v > 0 {
            assert_eq!(
                (has_a, has_b),
                (!v.is_multiple_of(2), v.is_multiple_of(2)),
                "version {v}: A seen {has_a}, B seen {has_b}"
            );
        }
        v
    };
    let mut readers = Vec::new();
    for batched in [false, true] {
        let (http, srv, done, pose) = (http.clone(), srv.clone(), done.clone(), pose.clone());
        readers.push(tokio::spawn(async move {
            let mut versions = Vec::new();
            while !done.load(Ordering::SeqCst) {
                let answers: Vec<CullResponse> = if batched {
                    let body = json!({"poses": [pose_json(&pose), pose_json(&pose)]});
                    let r: homcull_proto::BatchResponse =
                        post_json(&http, srv.url("/v1/scenes/demo/cull/batch"), &body).await;
                    r.results
                } else {
                    let body = json!({"pose": pose_json(&pose)});
                    vec![post_json(&http, srv.url("/v1/scenes/demo/cull"), &body).await]
                };
                versions.extend(answers.iter().map(check));
            }
            versions
        }));
    }
    writer.await.unwrap();
    let rounds = churn.await.unwrap();
    let mut seen = std::collections::BTreeSet::new();
    for r in readers {
        let versions = r.await.unwrap();
        assert!(
            versions.windows(2).all(|w| w[0] <= w[1]),
            "one client's answers never go back a version"
        );
        seen.extend(versions);
    }
    let last: CullResponse = post_json(
        &http,
        srv.url("/v1/scenes/demo/cull"),
        &json!({"pose": pose_json(&pose)}),
    )
    .await;
    assert_eq!(
        check(&last),
        UPDATES,
        "the last answer names the last update"
    );
    eprintln!(
        "{} distinct versions answered while {UPDATES} updates and {rounds} upload/delete rounds ran",
        seen.len()
    );
    assert!(seen.len() > 10, "culls interleaved with updates: {seen:?}");
}

/// The load generator's writer: object transforms at a steady rate while WebSocket
/// clients stream, all accepted, and the streams keep being answered.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_load_generator_moves_objects_while_clients_stream() {
    let srv = TestServer::start(|_| {}).await;
    let report = homcull::eval::loadgen::run(&homcull::eval::loadgen::LoadConfig {
        url: srv.url(""),
        scene: "demo".into(),
        clients: 4,
        seconds: 1.5,
        mode: "ws".into(),
        batch: 1,
        transforms_per_s: 2000.0,
    })
    .await
    .unwrap();
    eprintln!("{}", report.summary());
    assert_eq!((report.errors, report.transform_errors), (0, 0));
    assert!(report.min_client_poses > 0, "every client was answered");
    assert!(
        report.transforms_per_s > 1000.0,
        "{}",
        report.transforms_per_s
    );
    assert!(report.last_version > 50, "{}", report.last_version);
    let latency = report.update_to_visible_ms.expect("measured with a writer");
    assert!(
        latency.p50 > 0.0 && latency.p50 < 1000.0,
        "update to visible p50 {} ms",
        latency.p50
    );
    srv.stop().await;
}

/// `homcull animate`: the demo city's cars drive (one update of all of them per tick,
/// each with its velocity), the scene's versions follow, and a cull afterwards names
/// the last; it refuses a server off loopback and a prefix nothing has.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn animate_drives_the_demo_citys_cars() {
    use homcull::eval::animate::{AnimateConfig, Axis, run};
    let srv = TestServer::start(|_| {}).await;
    let config = AnimateConfig {
        url: srv.url(""),
        scene: "demo".into(),
        prefix: "car_".into(),
        axis: Axis::Long,
        amplitude: 20.0,
        period_s: 4.0,
        rate_hz: 20.0,
        seconds: 1.0,
        token: None,
    };
    let report = run(&config).await.unwrap();
    assert!(report.objects > 50, "{} cars", report.objects);
    assert!(report.updates >= 10, "{} updates", report.updates);
    assert_eq!(report.last_version, report.updates);
    let http = reqwest::Client::new();
    let pose = street_walk(1, [320, 180]).remove(0);
    let r: CullResponse = post_json(
        &http,
        srv.url("/v1/scenes/demo/cull"),
        &json!({"pose": pose_json(&pose)}),
    )
    .await;
    assert_eq!(r.stats.scene_version, report.last_version);
    let off = AnimateConfig {
        url: "http://10.0.0.1:8080".into(),
        ..config.clone()
    };
    assert!(
        run(&off)
            .await
            .unwrap_err()
            .to_string()
            .contains("loopback")
    );
    let none = AnimateConfig {
        prefix: "spaceship_".into(),
        ..config
    };
    assert!(
        run(&none)
            .await
            .unwrap_err()
            .to_string()
            .contains("spaceship_")
    );
    srv.stop().await;
}

/// With the journal (the default) a restart serves the stored scene where its writers
/// left it, at the same version; in memory (`--state memory`) as its file has it, at
/// version 0. The upload itself survives both.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_restart_keeps_placements_in_the_journal_and_forgets_them_in_memory() {
    let dir = tempfile::tempdir().unwrap();
    let http = reqwest::Client::new();
    // The small scene: a wall at z = -10, a box hidden behind it at z = -20.
    let pose = json!({"position": [0, 1, 0], "look_at": [0, 1, -20], "viewport": [160, 90]});
    let srv = TestServer::start_in(dir.path(), |_| {}).await;
    let up = http
        .post(srv.url("/v1/scenes?name=small"))
        .body(common::rest::small_glb())
        .send()
        .await
        .unwrap();
    assert_eq!(up.status(), 201);
    let id = up.json::<homcull_proto::SceneInfo>().await.unwrap().id;
    let cull = |srv: &TestServer| srv.url(&format!("/v1/scenes/{id}/cull"));
    let before: CullResponse = post_json(&http, cull(&srv), &json!({"pose": pose})).await;
    assert_eq!(before.visible, [0], "only the wall: {:?}", before.visible);
    // The wall moves out of the way: the box shows.
    let moved: TransformsResponse = post_json(
        &http,
        srv.url(&format!("/v1/scenes/{id}/transforms")),
        &json!({"objects": [{"id": 0, "translation": [100, 0, 0]}]}),
    )
    .await;
    assert_eq!(moved.version, 1);
    let after: CullResponse = post_json(&http, cull(&srv), &json!({"pose": pose})).await;
    assert_eq!(
        (after.visible.as_slice(), after.stats.scene_version),
        (&[1][..], 1)
    );
    srv.stop().await;

    let srv = TestServer::start_in(dir.path(), |_| {}).await;
    let again: CullResponse = post_json(&http, cull(&srv), &json!({"pose": pose})).await;
    assert_eq!(
        (again.visible.as_slice(), again.stats.scene_version),
        (&[1][..], 1),
        "the journal keeps the wall out of the way"
    );
    srv.stop().await;

    let srv = TestServer::start_in(dir.path(), |c| c.state = StateMode::Memory).await;
    let fresh: CullResponse = post_json(&http, cull(&srv), &json!({"pose": pose})).await;
    assert_eq!(fresh.stats.scene_version, 0, "memory keeps no placements");
    assert_eq!(fresh.visible, before.visible);
    srv.stop().await;

    // Deleting the scene deletes its journal.
    let srv = TestServer::start_in(dir.path(), |_| {}).await;
    let gone = http
        .delete(srv.url(&format!("/v1/scenes/{id}")))
        .send()
        .await
        .unwrap();
    assert_eq!(gone.status(), 204);
    assert!(!dir.path().join("state").join(&id).exists());
    srv.stop().await;
}
