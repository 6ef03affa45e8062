//! Scenes: listing, info, objects and GLB download of the demo; uploads that persist
//! across restarts and need the token; replicas sharing a data dir; `--scene` files
//! served read-only.

use crate::common;

use common::rest::{error_of, small_glb};
use common::server::{TestServer, get_bytes, get_json, post_json};
use homcull::core::engine::Backend;
use homcull::core::scene::write_glb;
use homcull::server::StateMode;
use homcull_proto::{CullResponse, ObjectList, SceneInfo, SceneList};
use serde_json::json;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn scenes_objects_and_glb_of_the_demo() {
    let srv = TestServer::start(|_| {}).await;
    let http = reqwest::Client::new();

    // Scenes and objects.
    let list: SceneList = get_json(&http, srv.url("/v1/scenes")).await;
    let demo = list
        .scenes
        .iter()
        .find(|s| s.id == "demo")
        .expect("demo is listed");
    let info: SceneInfo = get_json(&http, srv.url("/v1/scenes/demo")).await;
    assert_eq!(&info, demo);
    let objects: ObjectList = get_json(&http, srv.url("/v1/scenes/demo/objects")).await;
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
    let objects_before: ObjectList =
        get_json(&http, srv.url(&format!("/v1/scenes/{}/objects", info.id))).await;
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
    let list: SceneList = get_json(&http, srv.url("/v1/scenes")).await;
    assert_eq!(list.scenes, vec![info.clone()]);
    let objects_after: ObjectList =
        get_json(&http, srv.url(&format!("/v1/scenes/{}/objects", info.id))).await;
    assert_eq!(objects_after, objects_before);
    let cull_url = srv.url(&format!("/v1/scenes/{}/cull", info.id));
    let after: CullResponse = post_json(&http, &cull_url, &pose).await;
    assert_eq!(after.visible, before.visible);
    let glb_back = get_bytes(&http, srv.url(&format!("/v1/scenes/{}/glb", info.id))).await;
    assert_eq!(
        glb_back.as_slice(),
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
    let list: SceneList = get_json(&http, srv.url("/v1/scenes")).await;
    assert!(list.scenes.is_empty());
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_replica_picks_up_scenes_another_wrote_and_healthcheck_answers() {
    let dir = tempfile::tempdir().unwrap();
    // Replicas that share a data dir keep placements in memory (one journal per dir).
    let a = TestServer::start_in(dir.path(), |c| {
        c.no_demo = true;
        c.state = StateMode::Memory;
    })
    .await;
    let b = TestServer::start_in(dir.path(), |c| {
        c.no_demo = true;
        c.rescan_s = 1;
        c.state = StateMode::Memory;
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
