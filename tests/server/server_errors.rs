//! Every error the REST API answers, each as its JSON error with the right status, and
//! the server serving on after all of them with the same answers.

use crate::common;

use common::rest::{error_of, pose_json, small_glb};
use common::server::{TestServer, post_json, street_walk};
use homcull_proto::CullResponse;
use serde_json::json;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_error_and_the_server_carries_on() {
    let srv = TestServer::start(|c| {
        c.max_batch = 8;
        c.max_upload_bytes = 1 << 20;
    })
    .await;
    let http = reqwest::Client::new();
    let poses = street_walk(1, [320, 180]);
    let before: CullResponse = post_json(
        &http,
        srv.url("/v1/scenes/demo/cull"),
        &json!({"pose": pose_json(&poses[0])}),
    )
    .await;

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
            format!(
                r#"{{"poses":[{}]}}"#,
                vec![format!(r#"{{{p},"viewport":[8192,8192]}}"#); 5].join(",")
            ),
            413,
            "work_too_large",
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
    // The server answers 413 without reading the rest of the body and closes that
    // connection: send it on a connection of its own, so that no later request is
    // written into the closing one.
    let once = reqwest::Client::builder()
        .pool_max_idle_per_host(0)
        .build()
        .unwrap();
    let too_large = once
        .post(srv.url("/v1/scenes?name=x"))
        .body(vec![7; 2 << 20])
        .send()
        .await
        .unwrap();
    assert_eq!(error_of(too_large).await, (413, "too_large".into()));
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
    // Still serving, with the same answer.
    let r: CullResponse = post_json(&http, &cull, &json!({"pose": pose_json(&poses[0])})).await;
    assert_eq!(r.visible, before.visible);
    srv.stop().await;
}
