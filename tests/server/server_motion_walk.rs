//! Moving objects through the server, end to end: a 300-pose street walk through the
//! demo city while a third of its cars move between every ten poses, the updates
//! sent alternately over REST (`POST /transforms`) and by a writer stream (JSON text
//! messages on a WebSocket with the write token). Each group of poses is culled twice
//! by `POST /cull/batch`, refined HOM and the exact oracle; both must name the same
//! scene version (the latest accepted), and HOM must keep everything the oracle sees.
//! Once on the native CPU backend and once on the GPU (lavapipe in CI).

use crate::common;

use common::server::{TestServer, get_json, post_json, street_walk};
use futures_util::{SinkExt, StreamExt};
use homcull::core::engine::Backend;
use homcull_proto::BatchResponse;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde_json::{Value, json};
use tokio_tungstenite::tungstenite::Message;

const POSES: usize = 300;
const POSES_PER_VERSION: usize = 10;

async fn walk(backend: Backend, name: &str) {
    let tmp = tempfile::tempdir().unwrap();
    let srv = TestServer::start_on(backend, tmp.path(), |c| {
        c.api_token = Some("secret".into());
    })
    .await;
    let http = reqwest::Client::new();
    let objects: Value = get_json(&http, srv.url("/v1/scenes/demo/objects")).await;
    let cars: Vec<u64> = objects["objects"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|o| o["dynamic"] == true)
        .map(|o| o["id"].as_u64().unwrap())
        .collect();
    assert!(cars.len() > 100, "{name}: the demo's cars are marked");
    // A writer stream: the write token on its upgrade.
    let mut writer = common::ws::open(&srv, Some("secret")).await;
    let _hello = writer.next().await;
    let poses = street_walk(POSES, [320, 180]);
    let mut rng = StdRng::seed_from_u64(19);
    let (mut seen_total, mut culled_total) = (0usize, 0usize);
    for (step, group) in poses.chunks(POSES_PER_VERSION).enumerate() {
        let mut moves: Vec<Value> = Vec::new();
        for &id in &cars {
            if rng.random_bool(0.33) {
                let along = [
                    rng.random_range(-6.0..6.0f32),
                    0.0,
                    rng.random_range(-6.0..6.0f32),
                ];
                moves.push(json!({"id": id, "translation": along, "velocity": along}));
            }
        }
        let body = json!({"objects": moves});
        let version = if step % 2 == 0 {
            let r = http
                .post(srv.url("/v1/scenes/demo/transforms"))
                .bearer_auth("secret")
                .json(&body)
                .send()
                .await
                .unwrap();
            assert_eq!(r.status(), 200, "{name}: REST update");
            r.json::<Value>().await.unwrap()["version"]
                .as_u64()
                .unwrap()
        } else {
            let msg = json!({"seq": step, "transforms": body});
            writer
                .send(Message::Text(msg.to_string().into()))
                .await
                .unwrap();
            loop {
                let Message::Text(t) = writer.next().await.unwrap().unwrap() else {
                    continue;
                };
                let v: Value = serde_json::from_str(&t).unwrap();
                let answer = &v["transforms"];
                if answer["seq"] == step {
                    break answer["version"]
                        .as_u64()
                        .unwrap_or_else(|| panic!("{name}: {v}"));
                }
            }
        };
        assert_eq!(version, step as u64 + 1, "{name}: one version per update");
        let cull =
            |method: &str| json!({"poses": group, "options": {"method": method, "refine": true}});
        let url = srv.url("/v1/scenes/demo/cull/batch");
        let hom: BatchResponse = post_json(&http, url.clone(), &cull("hom")).await;
        let exact: BatchResponse = post_json(&http, url, &cull("exact")).await;
        for (k, (h, e)) in hom.results.iter().zip(&exact.results).enumerate() {
            assert_eq!(
                (h.stats.scene_version, e.stats.scene_version),
                (version, version),
                "{name}: answers at the version the update made"
            );
            let missing: Vec<u32> = (e.visible.iter())
                .filter(|id| h.visible.binary_search(id).is_err())
                .copied()
                .collect();
            assert!(
                missing.is_empty(),
                "{name}, version {version}, pose {k}: culled what the oracle sees: {missing:?}"
            );
            seen_total += e.visible.len();
            culled_total += h.stats.culled_by_occlusion as usize;
        }
    }
    assert!(
        culled_total > POSES * 10,
        "{name}: {culled_total} occlusion culls in the walk: the check says little"
    );
    eprintln!("{name}: {seen_total} sightings, {culled_total} occlusion culls, 0 false culls");
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_walk_with_traffic_culls_nothing_the_oracle_sees_on_the_native_backend() {
    walk(Backend::Native, "native").await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_walk_with_traffic_culls_nothing_the_oracle_sees_on_the_gpu() {
    match common::gpu() {
        Some(gpu) => walk(Backend::Gpu(gpu), "gpu").await,
        None => eprintln!("no GPU adapter: skipped (HOMCULL_REQUIRE_GPU=1 makes this an error)"),
    }
}
