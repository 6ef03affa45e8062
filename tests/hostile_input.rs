//! Hostile input: crafted GLB files that ask for far more than they hold are refused
//! before anything is decoded, by the loader and by the server (4xx within seconds,
//! nothing stored, `/healthz` quick throughout); a stored scene that cannot load is
//! quarantined and the server starts without it; the token is checked before an
//! upload's body is read; culls must be declared JSON.

mod common;

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use common::hostile;
use common::rest::error_of;
use common::server::{TestServer, get_json, post_json};
use homcull::core::scene::{LoadLimits, load_glb_bytes, load_glb_bytes_within};
use homcull_proto::{CullResponse, SceneInfo, SceneList};
use serde_json::json;

#[test]
fn the_loader_refuses_every_crafted_file_before_decoding() {
    for (name, glb) in hostile::all_refused() {
        let t = Instant::now();
        let err = load_glb_bytes(&glb, name).expect_err(name);
        let took = t.elapsed();
        eprintln!("{name} ({} bytes, {took:?}): {err}", glb.len());
        assert!(took < Duration::from_secs(2), "{name} took {took:?}");
    }
    let why = |glb: Vec<u8>| load_glb_bytes(&glb, "x").unwrap_err().to_string();
    assert!(why(hostile::self_child()).contains("its own ancestor"));
    assert!(why(hostile::cycle_without_mesh()).contains("its own ancestor"));
    assert!(why(hostile::deep_nesting(200)).contains("deeper than 64"));
    assert!(why(hostile::huge_sparse_count()).contains("decoded-bytes limit"));
    assert!(why(hostile::accessor_count_2_pow_62()).contains("decoded-bytes limit"));
    assert!(why(hostile::accessor_past_its_view()).contains("exceed buffer view"));
    assert!(why(hostile::shared_index_accessor(1_000, 30_000)).contains("triangles"));
    assert!(why(hostile::no_triangles()).contains("no triangles"));
}

#[test]
fn what_fits_the_limits_loads_and_the_limits_are_what_refuse() {
    let one = load_glb_bytes(&hostile::one_triangle(), "t").unwrap();
    assert_eq!((one.objects.len(), one.triangle_count()), (1, 1));
    let many = load_glb_bytes(&hostile::many_instances(1_000), "i").unwrap();
    assert_eq!(
        many.objects.len(),
        1_000,
        "instancing within the limits loads"
    );
    assert!(load_glb_bytes(&hostile::deep_nesting(60), "d").is_ok());
    let shared = hostile::shared_index_accessor(100, 3_000);
    assert_eq!(
        load_glb_bytes(&shared, "s").unwrap().triangle_count(),
        100_000
    );
    let tight = LoadLimits {
        max_triangles: 50_000,
        ..LoadLimits::default()
    };
    assert!(load_glb_bytes_within(&shared, "s", &tight).is_err());
    let few_nodes = LoadLimits {
        max_nodes: 500,
        ..LoadLimits::default()
    };
    let err = load_glb_bytes_within(&hostile::many_instances(1_000), "i", &few_nodes);
    assert!(err.unwrap_err().to_string().contains("500 node instances"));
}

/// How far resident memory may rise while the hostile uploads are refused.
const HOSTILE_RSS_MIB: f64 = 64.0;

/// GET /healthz, timed.
async fn healthz_ms(http: &reqwest::Client, srv: &TestServer) -> f64 {
    let t = Instant::now();
    let r = http.get(srv.url("/healthz")).send().await.unwrap();
    assert_eq!(r.status(), 200);
    t.elapsed().as_secs_f64() * 1e3
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn hostile_uploads_get_a_4xx_and_the_server_carries_on() {
    let srv = TestServer::start(|c| c.no_demo = true).await;
    let http = reqwest::Client::new();
    let rss0 = common::rss_mib();
    let mut rss_peak = rss0;
    for (name, glb) in hostile::all_refused() {
        let t = Instant::now();
        let r = http
            .post(srv.url("/v1/scenes?name=hostile"))
            .body(glb)
            .send()
            .await
            .unwrap();
        let got = error_of(r).await;
        assert_eq!(got, (400, "invalid_glb".to_string()), "{name}");
        assert!(
            t.elapsed() < Duration::from_secs(5),
            "{name}: {:?}",
            t.elapsed()
        );
        let ms = healthz_ms(&http, &srv).await;
        assert!(ms < 100.0, "/healthz took {ms:.1} ms after {name}");
        rss_peak = rss_peak.max(common::rss_mib());
    }
    // Each file asks for gigabytes; refused before decoding, none gets near it.
    assert!(
        rss_peak < rss0 + HOSTILE_RSS_MIB,
        "resident memory {rss0:.1} -> {rss_peak:.1} MiB"
    );
    let stored = std::fs::read_dir(srv.data_dir.join("scenes"))
        .unwrap()
        .count();
    assert_eq!(stored, 0, "a refused upload is never stored");
    let list: SceneList = get_json(&http, srv.url("/v1/scenes")).await;
    assert!(list.scenes.is_empty());

    // A legitimate upload still works, and culls.
    let r = http
        .post(srv.url("/v1/scenes?name=triangle"))
        .body(hostile::one_triangle())
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 201);
    let info: SceneInfo = r.json().await.unwrap();
    let pose = json!({"pose": {"position": [0.3, 0.3, 3.0], "look_at": [0.3, 0.3, 0.0],
                               "viewport": [64, 64]}});
    let url = srv.url(&format!("/v1/scenes/{}/cull", info.id));
    let culled: CullResponse = post_json(&http, url, &pose).await;
    assert_eq!(culled.visible, vec![0]);
    srv.stop().await;
}

/// Writes a stored scene by hand, as a crash or another version might have left it.
fn plant(data: &std::path::Path, folder: &str, meta_id: &str, glb: &[u8]) {
    let dir = data.join("scenes").join(folder);
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("scene.glb"), glb).unwrap();
    let meta = json!({"id": meta_id, "name": "planted", "created_unix": 0});
    std::fs::write(dir.join("meta.json"), meta.to_string()).unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stored_scenes_that_cannot_load_are_quarantined_and_the_server_starts() {
    let dir = tempfile::tempdir().unwrap();
    let good = "00000000000000aa";
    plant(dir.path(), good, good, &hostile::one_triangle());
    plant(
        dir.path(),
        "00000000000000bb",
        "00000000000000bb",
        &hostile::self_child(),
    );
    plant(
        dir.path(),
        "00000000000000cc",
        "00000000000000cc",
        &hostile::huge_sparse_count(),
    );
    // A folder whose meta.json names another scene's id must not take it over.
    plant(
        dir.path(),
        "00000000000000dd",
        good,
        &hostile::one_triangle(),
    );
    let srv = TestServer::start_in(dir.path(), |c| c.no_demo = true).await;
    let http = reqwest::Client::new();
    let list: SceneList = get_json(&http, srv.url("/v1/scenes")).await;
    let ids: Vec<&str> = list.scenes.iter().map(|s| s.id.as_str()).collect();
    assert_eq!(ids, vec![good]);
    let quarantined: Vec<String> = std::fs::read_dir(dir.path().join("quarantine"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(quarantined.len(), 3, "{quarantined:?}");
    for id in ["00000000000000bb", "00000000000000cc", "00000000000000dd"] {
        assert!(
            quarantined.iter().any(|q| q.starts_with(id)),
            "{id} quarantined"
        );
        assert!(!dir.path().join("scenes").join(id).exists());
    }
    srv.stop().await;
    // The next start does not try them again, and keeps the good one.
    let again = TestServer::start_in(dir.path(), |c| c.no_demo = true).await;
    let list: SceneList = get_json(&http, again.url("/v1/scenes")).await;
    assert_eq!(list.scenes.len(), 1);
    again.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_token_is_checked_before_an_upload_body_is_read() {
    let srv = TestServer::start(|c| {
        c.api_token = Some("correct-horse".into());
        c.no_demo = true;
    })
    .await;
    // Declare a 200 MB upload, send 1 KB of it, and wait: the answer must come now.
    let addr = srv.addr;
    let head = tokio::task::spawn_blocking(move || {
        let mut s = std::net::TcpStream::connect(addr).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
        let req = format!(
            "POST /v1/scenes?name=x HTTP/1.1\r\nHost: {addr}\r\nContent-Length: 200000000\r\n\r\n"
        );
        s.write_all(req.as_bytes()).unwrap();
        s.write_all(&[0u8; 1024]).unwrap();
        let mut buf = [0u8; 64];
        let n = s.read(&mut buf).expect("an answer before the body is sent");
        String::from_utf8_lossy(&buf[..n]).into_owned()
    })
    .await
    .unwrap();
    assert!(head.starts_with("HTTP/1.1 401"), "{head}");
    let http = reqwest::Client::new();
    let r = http
        .delete(srv.url("/v1/scenes/0123456789abcdef"))
        .send()
        .await
        .unwrap();
    assert_eq!(error_of(r).await, (401, "unauthorized".into()));
    let r = http
        .delete(srv.url("/v1/scenes/0123456789abcdef"))
        .bearer_auth("correct-horsE")
        .send()
        .await
        .unwrap();
    assert_eq!(error_of(r).await, (401, "unauthorized".into()));
    // Reads need no token.
    assert_eq!(
        http.get(srv.url("/v1/scenes"))
            .send()
            .await
            .unwrap()
            .status(),
        200
    );
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn culls_must_be_declared_json() {
    let srv = TestServer::start(|_| {}).await;
    let http = reqwest::Client::new();
    let body = r#"{"pose":{"position":[0,1.7,0],"look_at":[10,1.7,0]}}"#;
    for route in ["cull", "cull/batch", "occluders", "pyramid"] {
        let url = srv.url(&format!("/v1/scenes/demo/{route}"));
        for ctype in [
            Some("text/plain"),
            Some("application/x-www-form-urlencoded"),
            None,
        ] {
            let mut req = http.post(&url).body(body);
            if let Some(c) = ctype {
                req = req.header("content-type", c);
            }
            let got = error_of(req.send().await.unwrap()).await;
            assert_eq!(
                got,
                (415, "unsupported_media_type".into()),
                "{route} {ctype:?}"
            );
        }
    }
    let ok = http
        .post(srv.url("/v1/scenes/demo/cull"))
        .header("content-type", "application/json; charset=utf-8")
        .body(body)
        .send()
        .await
        .unwrap();
    assert_eq!(ok.status(), 200);
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn writes_and_streams_from_other_origins_are_refused() {
    use tokio_tungstenite::tungstenite::client::IntoClientRequest;
    let srv =
        TestServer::start(|c| c.allowed_origins = vec!["https://viewer.example".into()]).await;
    let http = reqwest::Client::new();
    let upload = |origin: &'static str| {
        http.post(srv.url("/v1/scenes?name=o"))
            .header("origin", origin)
            .body(hostile::one_triangle())
            .send()
    };
    let r = upload("https://evil.example").await.unwrap();
    assert_eq!(error_of(r).await, (403, "forbidden_origin".into()));
    assert_eq!(
        upload("https://viewer.example").await.unwrap().status(),
        201
    );
    let own = format!("http://{}", srv.addr);
    let r = http
        .post(srv.url("/v1/scenes?name=o"))
        .header("origin", own.as_str())
        .body(hostile::one_triangle())
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 201, "the server's own origin");
    let stream = |origin: &str| {
        let mut req = srv
            .ws_url("/v1/scenes/demo/stream")
            .into_client_request()
            .unwrap();
        req.headers_mut().insert("origin", origin.parse().unwrap());
        tokio_tungstenite::connect_async(req)
    };
    assert!(
        stream("https://evil.example").await.is_err(),
        "refused upgrade"
    );
    assert!(stream(&own).await.is_ok());
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn with_auth_cull_culls_and_streams_need_the_token_too() {
    use tokio_tungstenite::tungstenite::client::IntoClientRequest;
    let srv = TestServer::start(|c| {
        c.api_token = Some("s3cret".into());
        c.auth = homcull::server::AuthScope::Cull;
    })
    .await;
    let http = reqwest::Client::new();
    let pose = json!({"pose": {"position": [0, 1.7, 0], "look_at": [10, 1.7, 0]}});
    let url = srv.url("/v1/scenes/demo/cull");
    let r = http.post(&url).json(&pose).send().await.unwrap();
    assert_eq!(error_of(r).await, (401, "unauthorized".into()));
    let r = http
        .post(&url)
        .bearer_auth("s3cret")
        .json(&pose)
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 200);
    let stream = |token: Option<&str>| {
        let mut req = srv
            .ws_url("/v1/scenes/demo/stream")
            .into_client_request()
            .unwrap();
        if let Some(t) = token {
            req.headers_mut()
                .insert("authorization", format!("Bearer {t}").parse().unwrap());
        }
        tokio_tungstenite::connect_async(req)
    };
    assert!(stream(None).await.is_err());
    assert!(stream(Some("wrong")).await.is_err());
    assert!(stream(Some("s3cret")).await.is_ok());
    srv.stop().await;
}
