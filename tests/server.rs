//! REST routes of the server, each error case, persistence across restarts, tokens.

mod common;

use common::server::{TestServer, post_json, street_walk};
use homcull::core::engine::Backend;
use homcull::core::scene::{SceneBuilder, write_glb};
use homcull_proto::{BatchResponse, CullResponse, ErrorBody, ObjectList, SceneInfo, SceneList};
use serde_json::{Value, json};

async fn error_of(r: reqwest::Response) -> (u16, String) {
    let status = r.status().as_u16();
    let body: ErrorBody = r.json().await.expect("error bodies are JSON");
    assert!(!body.error.message.is_empty());
    (status, body.error.code)
}

/// A small scene to upload: a wall with a box behind it and one beside it.
fn small_glb() -> Vec<u8> {
    let mut b = SceneBuilder::default();
    let cube = |b: &mut SceneBuilder, name: &str, c: [f32; 3], h: [f32; 3]| {
        let v: Vec<glam::Vec3> = (0..8)
            .map(|i| {
                glam::Vec3::new(
                    c[0] + if i & 1 == 0 { -h[0] } else { h[0] },
                    c[1] + if i & 2 == 0 { -h[1] } else { h[1] },
                    c[2] + if i & 4 == 0 { -h[2] } else { h[2] },
                )
            })
            .collect();
        let idx = [
            0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4,
            6, 1, 3, 5, 3, 7, 5,
        ];
        b.push(name.into(), &v, &idx, None);
    };
    cube(&mut b, "wall", [0.0, 5.0, -10.0], [20.0, 5.0, 0.5]);
    cube(&mut b, "hidden", [0.0, 1.0, -20.0], [1.0, 1.0, 1.0]);
    cube(&mut b, "beside", [40.0, 1.0, -20.0], [1.0, 1.0, 1.0]);
    write_glb(&b.build("small"))
}

fn pose_json(p: &homcull_proto::Pose) -> Value {
    serde_json::to_value(p).unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_route_and_every_error() {
    let srv = TestServer::start(|c| {
        c.max_batch = 8;
        c.max_upload_bytes = 1 << 20;
    })
    .await;
    let http = reqwest::Client::new();
    eprintln!("adapter: {}", srv.adapter);

    // Probes, metrics, docs.
    assert_eq!(
        http.get(srv.url("/healthz")).send().await.unwrap().status(),
        200
    );
    let ready: Value = http
        .get(srv.url("/readyz"))
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(ready["ready"], true);
    assert_eq!(ready["adapter"], srv.adapter.as_str());
    let api: Value = http
        .get(srv.url("/openapi.json"))
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    for path in [
        "/v1/scenes",
        "/v1/scenes/{id}/cull",
        "/v1/scenes/{id}/cull/batch",
        "/v1/scenes/{id}/stream",
    ] {
        assert!(api["paths"][path].is_object(), "openapi lacks {path}");
    }
    assert_eq!(
        http.get(srv.url("/docs/")).send().await.unwrap().status(),
        200
    );

    // Scenes and objects.
    let list: SceneList = http
        .get(srv.url("/v1/scenes"))
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    let demo = list
        .scenes
        .iter()
        .find(|s| s.id == "demo")
        .expect("demo is listed");
    let info: SceneInfo = http
        .get(srv.url("/v1/scenes/demo"))
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(&info, demo);
    let objects: ObjectList = http
        .get(srv.url("/v1/scenes/demo/objects"))
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(objects.objects.len() as u32, info.objects);
    assert!(
        objects
            .objects
            .iter()
            .enumerate()
            .all(|(i, o)| o.id == i as u32)
    );
    let glb = http
        .get(srv.url("/v1/scenes/demo/glb"))
        .send()
        .await
        .unwrap();
    assert_eq!(glb.headers()["content-type"], "model/gltf-binary");
    let glb = glb.bytes().await.unwrap();
    assert_eq!(glb.len() as u64, info.glb_bytes);
    let back = homcull::core::scene::load_glb_bytes(&glb, "demo").unwrap();
    assert_eq!(back.objects.len() as u32, info.objects);

    // Single and batch culls agree, in pose order.
    let poses = street_walk(6, [320, 180]);
    let mut singles = Vec::new();
    for p in &poses {
        let r = http
            .post(srv.url("/v1/scenes/demo/cull"))
            .json(&json!({"pose": pose_json(p)}))
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), 200);
        let r: CullResponse = r.json().await.unwrap();
        assert!(r.visible.windows(2).all(|w| w[0] < w[1]), "ascending");
        let s = &r.stats;
        assert_eq!(s.objects, info.objects);
        assert_eq!(s.candidates + s.culled_by_frustum, s.objects);
        assert_eq!(r.visible.len() as u32 + s.culled_by_occlusion, s.candidates);
        singles.push(r.visible);
    }
    let batch: BatchResponse = http
        .post(srv.url("/v1/scenes/demo/cull/batch"))
        .json(&json!({"poses": poses.iter().map(pose_json).collect::<Vec<_>>(), "options": {"method": "hom"}}))
        .send().await.unwrap().json().await.unwrap();
    let batched: Vec<Vec<u32>> = batch.results.into_iter().map(|r| r.visible).collect();
    assert_eq!(batched, singles);
    let frustum: CullResponse = post_json(
        &http,
        srv.url("/v1/scenes/demo/cull"),
        &json!({"pose": pose_json(&poses[0]), "options": {"method": "frustum"}}),
    )
    .await;
    assert!(
        singles[0].iter().all(|i| frustum.visible.contains(i)),
        "hom ⊆ frustum"
    );
    assert!(
        frustum.visible.len() > singles[0].len(),
        "a street-level pose hides something"
    );

    // The pyramid debug view: one PNG per level, level 0 at the viewport size.
    let pyr: Value = post_json(
        &http,
        srv.url("/v1/scenes/demo/pyramid"),
        &json!({"pose": pose_json(&poses[0])}),
    )
    .await;
    let levels = pyr["levels"].as_array().expect("levels");
    assert_eq!(
        levels.len(),
        homcull::core::hom::pyramid::LevelLayout::new(320, 180).levels()
    );
    assert_eq!(
        (levels[0]["width"].as_u64(), levels[0]["height"].as_u64()),
        (Some(320), Some(180))
    );
    let last = levels.last().unwrap();
    assert_eq!(
        (last["width"].as_u64(), last["height"].as_u64()),
        (Some(1), Some(1))
    );
    for l in levels {
        let url = l["png"].as_str().unwrap();
        let b64 = url
            .strip_prefix("data:image/png;base64,")
            .expect("a PNG data URL");
        use base64::Engine as _;
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(b64)
            .unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
    }

    // The occluders of a pose: distinct qualifying occluders within the budget, all in
    // the frustum (so among the frustum method's visible set).
    let occ: Value = post_json(
        &http,
        srv.url("/v1/scenes/demo/occluders"),
        &json!({"pose": pose_json(&poses[0])}),
    )
    .await;
    let ids: Vec<u32> = serde_json::from_value(occ["occluders"].clone()).expect("occluder ids");
    assert!(!ids.is_empty(), "a street pose renders occluders");
    assert!(ids.iter().all(|i| frustum.visible.contains(i)));
    let distinct: std::collections::BTreeSet<_> = ids.iter().collect();
    assert_eq!(distinct.len(), ids.len());
    assert!(occ["triangles"].as_u64().unwrap() <= occ["budget"].as_u64().unwrap());
    let status = http
        .post(srv.url("/v1/scenes/nope/occluders"))
        .json(&json!({"pose": pose_json(&poses[0])}))
        .send()
        .await
        .unwrap()
        .status();
    assert_eq!(status, 404);
    let status = http
        .post(srv.url("/v1/scenes/demo/occluders"))
        .header("content-type", "application/json")
        .body(r#"{"pose": {"position": [0, 1, 0], "viewport": [0, 0]}}"#)
        .send()
        .await
        .unwrap()
        .status();
    assert_eq!(status, 400);

    // Errors: each gets its JSON error, and the server carries on.
    let cull = srv.url("/v1/scenes/demo/cull");
    let post = |url: String, body: String| {
        http.post(url)
            .header("content-type", "application/json")
            .body(body)
            .send()
    };
    let p = r#""position":[0,1.7,0],"look_at":[10,1.7,0]"#;
    let cases: Vec<(String, String, u16, &str)> = vec![
        (cull.clone(), "{not json".into(), 400, "malformed_json"),
        (
            cull.clone(),
            format!(r#"{{"pose":{{{p}}},"bogus":1}}"#),
            400,
            "malformed_json",
        ),
        (
            cull.clone(),
            r#"{"pose":{"position":[1e39,0,0]}}"#.into(),
            400,
            "invalid_pose",
        ),
        (
            cull.clone(),
            format!(r#"{{"pose":{{{p},"viewport":[0,0]}}}}"#),
            400,
            "invalid_pose",
        ),
        (
            cull.clone(),
            format!(r#"{{"pose":{{{p},"viewport":[100000,100]}}}}"#),
            400,
            "invalid_pose",
        ),
        (
            cull.clone(),
            format!(r#"{{"pose":{{{p},"fov_y_deg":0}}}}"#),
            400,
            "invalid_pose",
        ),
        (
            cull.clone(),
            format!(r#"{{"pose":{{{p},"near":0}}}}"#),
            400,
            "invalid_pose",
        ),
        (
            cull.clone(),
            r#"{"pose":{"position":[0,0,0],"look_at":[0,0,0]}}"#.into(),
            400,
            "invalid_pose",
        ),
        (
            cull.clone(),
            format!(r#"{{"pose":{{{p}}},"options":{{"threshold":2}}}}"#),
            400,
            "invalid_options",
        ),
        (
            cull.clone(),
            format!(r#"{{"pose":{{{p}}},"options":{{"method":"magic"}}}}"#),
            400,
            "malformed_json",
        ),
        (
            srv.url("/v1/scenes/nope/cull"),
            format!(r#"{{"pose":{{{p}}}}}"#),
            404,
            "unknown_scene",
        ),
        (
            srv.url("/v1/scenes/demo/cull/batch"),
            format!(r#"{{"poses":[{}]}}"#, vec![format!("{{{p}}}"); 9].join(",")),
            413,
            "batch_too_large",
        ),
        (
            srv.url("/v1/scenes/demo/cull/batch"),
            format!(r#"{{"poses":[{{{p}}},{{"position":[0,1,0],"fov_y_deg":400}}]}}"#),
            400,
            "invalid_pose",
        ),
    ];
    for (url, body, status, code) in cases {
        let got = error_of(post(url, body.clone()).await.unwrap()).await;
        assert_eq!(got, (status, code.to_string()), "body {body}");
    }
    assert_eq!(
        error_of(http.get(srv.url("/v1/scenes/nope")).send().await.unwrap()).await,
        (404, "unknown_scene".into())
    );
    assert_eq!(
        error_of(http.get(srv.url("/no/such/route")).send().await.unwrap()).await,
        (404, "not_found".into())
    );
    assert_eq!(
        error_of(
            http.delete(srv.url("/v1/scenes/demo"))
                .send()
                .await
                .unwrap()
        )
        .await,
        (409, "read_only".into())
    );
    let upload = |body: Vec<u8>| http.post(srv.url("/v1/scenes?name=x")).body(body).send();
    assert_eq!(
        error_of(upload(vec![7; 2 << 20]).await.unwrap()).await,
        (413, "too_large".into())
    );
    assert_eq!(
        error_of(upload(b"glTF but not really".to_vec()).await.unwrap()).await,
        (400, "invalid_glb".into())
    );
    assert_eq!(
        error_of(upload(vec![]).await.unwrap()).await,
        (400, "invalid_glb".into())
    );
    let mut truncated = small_glb();
    truncated.truncate(truncated.len() / 2);
    assert_eq!(
        error_of(upload(truncated).await.unwrap()).await,
        (400, "invalid_glb".into())
    );

    // Still serving, and the metrics saw it all.
    let r: CullResponse = post_json(&http, &cull, &json!({"pose": pose_json(&poses[0])})).await;
    assert_eq!(r.visible, singles[0]);
    let metrics = http
        .get(srv.url("/metrics"))
        .send()
        .await
        .unwrap()
        .text()
        .await
        .unwrap();
    for name in [
        "homcull_http_requests_total",
        "homcull_http_request_seconds",
        "homcull_culls_total",
        "homcull_gpu_batch_poses",
        "homcull_gpu_batch_seconds",
    ] {
        assert!(metrics.contains(name), "metrics lack {name}");
    }
    assert!(metrics.contains(r#"route="/v1/scenes/{id}/cull""#));
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn uploads_persist_across_restarts_and_writes_need_the_token() {
    let dir = tempfile::tempdir().unwrap();
    let token = "s3cret-token";
    let srv = TestServer::start_in(dir.path(), |c| {
        c.api_token = Some(token.into());
        c.no_demo = true;
    })
    .await;
    let http = reqwest::Client::new();
    let glb = small_glb();
    let up = |auth: Option<&str>| {
        let mut r = http
            .post(srv.url("/v1/scenes?name=small%20scene"))
            .body(glb.clone());
        if let Some(a) = auth {
            r = r.header("authorization", a);
        }
        r.send()
    };
    assert_eq!(
        error_of(up(None).await.unwrap()).await,
        (401, "unauthorized".into())
    );
    assert_eq!(
        error_of(up(Some("Bearer wrong")).await.unwrap()).await,
        (401, "unauthorized".into())
    );
    let r = up(Some(&format!("Bearer {token}"))).await.unwrap();
    assert_eq!(r.status(), 201);
    let info: SceneInfo = r.json().await.unwrap();
    assert_eq!((info.name.as_str(), info.objects), ("small scene", 3));

    // The wall hides one box; the other stands beside it.
    let pose =
        json!({"pose": {"position": [0, 1, 5], "look_at": [0, 1, -20], "viewport": [320, 180]}});
    let cull_url = srv.url(&format!("/v1/scenes/{}/cull", info.id));
    let before: CullResponse = post_json(&http, &cull_url, &pose).await;
    assert_eq!(
        before.visible,
        vec![0],
        "the wall is seen, the box behind it is culled"
    );
    let objects_before: ObjectList = http
        .get(srv.url(&format!("/v1/scenes/{}/objects", info.id)))
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert!(
        dir.path()
            .join(format!("scenes/{}/occluders.json", info.id))
            .is_file()
    );
    srv.stop().await;

    // Restart on the same data dir: same id, same objects, same answers.
    let srv = TestServer::start_in(dir.path(), |c| {
        c.api_token = Some(token.into());
        c.no_demo = true;
    })
    .await;
    let list: SceneList = http
        .get(srv.url("/v1/scenes"))
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(list.scenes, vec![info.clone()]);
    let objects_after: ObjectList = http
        .get(srv.url(&format!("/v1/scenes/{}/objects", info.id)))
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(objects_after, objects_before);
    let cull_url = srv.url(&format!("/v1/scenes/{}/cull", info.id));
    let after: CullResponse = post_json(&http, &cull_url, &pose).await;
    assert_eq!(after.visible, before.visible);
    let glb_back = http
        .get(srv.url(&format!("/v1/scenes/{}/glb", info.id)))
        .send()
        .await
        .unwrap()
        .bytes()
        .await
        .unwrap();
    assert_eq!(
        glb_back.as_ref(),
        glb.as_slice(),
        "the upload is served byte for byte"
    );

    // Deleting needs the token too, and sticks across restarts.
    let del = |auth: Option<String>| {
        let mut r = http.delete(srv.url(&format!("/v1/scenes/{}", info.id)));
        if let Some(a) = auth {
            r = r.header("authorization", a);
        }
        r.send()
    };
    assert_eq!(
        error_of(del(None).await.unwrap()).await,
        (401, "unauthorized".into())
    );
    assert_eq!(
        del(Some(format!("Bearer {token}"))).await.unwrap().status(),
        204
    );
    assert_eq!(
        error_of(
            http.get(srv.url(&format!("/v1/scenes/{}", info.id)))
                .send()
                .await
                .unwrap()
        )
        .await,
        (404, "unknown_scene".into())
    );
    srv.stop().await;
    let srv = TestServer::start_in(dir.path(), |c| c.no_demo = true).await;
    let list: SceneList = http
        .get(srv.url("/v1/scenes"))
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert!(list.scenes.is_empty());
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_replica_picks_up_scenes_another_wrote_and_healthcheck_answers() {
    let dir = tempfile::tempdir().unwrap();
    let a = TestServer::start_in(dir.path(), |c| c.no_demo = true).await;
    let b = TestServer::start_in(dir.path(), |c| {
        c.no_demo = true;
        c.rescan_s = 1;
    })
    .await;
    let http = reqwest::Client::new();
    let info: SceneInfo = http
        .post(a.url("/v1/scenes?name=shared"))
        .body(small_glb())
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    let mut seen = false;
    for _ in 0..100 {
        if http
            .get(b.url(&format!("/v1/scenes/{}", info.id)))
            .send()
            .await
            .unwrap()
            .status()
            == 200
        {
            seen = true;
            break;
        }
        tokio::time::sleep(std::time::Duration::from_millis(100)).await;
    }
    assert!(seen, "replica b serves the scene uploaded through a");
    assert!(
        homcull::cli::healthcheck::check(&a.url("/healthz"), std::time::Duration::from_secs(2))
            .is_ok()
    );
    let url = a.url("/healthz");
    a.stop().await;
    assert!(homcull::cli::healthcheck::check(&url, std::time::Duration::from_secs(2)).is_err());
    b.stop().await;
}

/// `--scene FILE` (`HOMCULL_SCENES`): served read-only under the file's name, never in
/// the data dir; a broken file stops the server at start, naming the file.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn scene_files_given_at_start_are_served_read_only() {
    let files = tempfile::tempdir().unwrap();
    let path = files.path().join("small_town.glb");
    let glb = small_glb();
    std::fs::write(&path, &glb).unwrap();
    let city = files.path().join("city.glb");
    std::fs::write(&city, write_glb(&homcull::core::scene::demo_city_sized(2))).unwrap();
    let srv = TestServer::start(|c| {
        c.no_demo = true;
        c.scenes = vec![path.clone(), city];
        c.rescan_s = 1;
    })
    .await;
    let http = reqwest::Client::new();
    let get = |p: &str| http.get(srv.url(p)).send();
    let list: SceneList = get("/v1/scenes").await.unwrap().json().await.unwrap();
    let ids: Vec<&str> = list.scenes.iter().map(|s| s.id.as_str()).collect();
    assert_eq!(ids, ["city", "small_town"]);
    let info = &list.scenes[1];
    assert_eq!(info.objects, 3);
    assert_eq!(info.glb_bytes, glb.len() as u64);
    // The city has streets: the viewer starts walking at eye height on one.
    let start = list.scenes[0].start.expect("a street to start on");
    assert!((start.position[1] - 1.7).abs() < 0.05, "{start:?}");
    assert_eq!(start.position[1], start.look_at[1], "looking level");
    let served = get("/v1/scenes/small_town/glb").await.unwrap();
    assert_eq!(served.status(), 200);
    assert_eq!(served.bytes().await.unwrap().as_ref(), glb.as_slice());
    let pose =
        json!({"pose": {"position": [0, 1, 5], "look_at": [0, 1, -20], "viewport": [320, 180]}});
    let culled: CullResponse =
        post_json(&http, &srv.url("/v1/scenes/small_town/cull"), &pose).await;
    assert_eq!(culled.visible, vec![0], "the box behind the wall is culled");

    let delete = http
        .delete(srv.url("/v1/scenes/small_town"))
        .send()
        .await
        .unwrap();
    assert_eq!(error_of(delete).await, (409, "read_only".into()));
    // Rescans of the (empty) data dir leave it resident.
    tokio::time::sleep(std::time::Duration::from_millis(2500)).await;
    assert_eq!(get("/v1/scenes/small_town").await.unwrap().status(), 200);
    assert!(
        std::fs::read_dir(srv.data_dir.join("scenes")).map_or(true, |mut d| d.next().is_none()),
        "nothing is written to the data dir"
    );
    srv.stop().await;

    let broken = files.path().join("broken.glb");
    std::fs::write(&broken, b"not a glb").unwrap();
    let mut cfg = common::server::config(files.path());
    cfg.scenes = vec![broken];
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let serving = homcull::server::serve(listener, cfg, Backend::Reference, std::future::pending());
    let err = tokio::time::timeout(std::time::Duration::from_secs(30), serving)
        .await
        .expect("a broken file stops the start at once")
        .expect_err("a broken file stops the start");
    assert!(err.to_string().contains("broken.glb"), "{err}");
}
