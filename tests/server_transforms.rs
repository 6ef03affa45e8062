//! `POST /v1/scenes/{id}/transforms` end to end: an object moved in front of the eye
//! appears in the next answer, which names the new version; an object sent back home
//! disappears again; every bad update gets its JSON error and changes nothing (the
//! version stays, the answers stay); the write token guards it.

mod common;

use common::rest::{error_of, pose_json};
use common::server::{TestServer, get_json, post_json, street_walk};
use glam::Vec3;
use homcull::core::camera::Camera;
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
