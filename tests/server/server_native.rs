//! A server on the native CPU backend: `/readyz` and the stream's hello name it, and
//! its answers keep every object the exact CPU oracle sees at the same poses.

use crate::common;

use common::rest::pose_json;
use common::server::{TestServer, get_json, post_json, street_walk};
use common::ws::connect_hello;
use homcull::core::camera::Camera;
use homcull::core::cull::{CullSettings, Culler, PreparedScene, has_bit, plan};
use homcull::core::engine::Backend;
use homcull::core::occluders::OccluderParams;
use homcull::core::reference::ReferenceBackend;
use homcull::core::scene::demo_city;
use homcull_proto::{CullOptions, CullResponse, Method};
use serde_json::{Value, json};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_native_server_names_its_backend_and_keeps_what_the_oracle_sees() {
    let tmp = tempfile::tempdir().unwrap();
    let srv = TestServer::start_on(Backend::Native, tmp.path(), |_| {}).await;
    let http = reqwest::Client::new();
    let ready: Value = get_json(&http, srv.url("/readyz")).await;
    assert_eq!(ready["backend"], "cpu");
    assert_eq!(ready["cpu_fallback"], false);
    assert!(
        ready["adapter"].as_str().unwrap().starts_with("native CPU"),
        "{ready}"
    );
    let (_ws, hello) = connect_hello(&srv, "").await;
    assert_eq!(hello["backend"], "cpu", "{hello}");

    let prep = PreparedScene::new(demo_city(), OccluderParams::default());
    let exact = CullSettings::new(
        CullOptions {
            method: Method::Exact,
            ..CullOptions::default()
        },
        &prep,
    );
    let mut culled = 0;
    for pose in street_walk(6, [480, 270]) {
        let r: CullResponse = post_json(
            &http,
            &srv.url("/v1/scenes/demo/cull"),
            &json!({"pose": pose_json(&pose)}),
        )
        .await;
        let p = plan(&prep, &Camera::new(&pose).unwrap(), &exact);
        let oracle = ReferenceBackend.visibility(&prep, &[p], &exact).unwrap();
        let seen: Vec<u32> = (0..prep.scene.objects.len() as u32)
            .filter(|&i| has_bit(&oracle[0], i))
            .collect();
        for id in &seen {
            assert!(
                r.visible.contains(id),
                "the server culled object {id} the oracle sees"
            );
        }
        culled += r.stats.culled_by_occlusion;
    }
    assert!(culled > 0, "the native server culled nothing by occlusion");
}
