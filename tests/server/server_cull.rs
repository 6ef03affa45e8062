//! `POST …/cull`, `…/cull/batch`, `…/pyramid` and `…/occluders` on the demo city: single
//! and batch culls agree in pose order, HOM keeps a subset of the frustum's set, the
//! pyramid has one PNG per level, the occluders fit the budget.

use crate::common;

use common::rest::pose_json;
use common::server::{TestServer, get_json, post_json, street_walk};
use homcull_proto::{BatchResponse, CullResponse, SceneInfo};
use serde_json::{Value, json};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn culls_pyramid_and_occluders() {
    let srv = TestServer::start(|_| {}).await;
    let http = reqwest::Client::new();
    let info: SceneInfo = get_json(&http, srv.url("/v1/scenes/demo")).await;

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
        homcull::core::reference::pyramid::LevelLayout::new(320, 180).levels()
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

    srv.stop().await;
}

/// Under load the worker records a batch while the device runs the one before (a
/// batch request longer than `cull_batch` always does: its chunks are started one
/// after another), and every answer is still the one a pose gets alone: concurrent
/// batches of mixed options, each split into chunks, against single-pose culls.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn batches_recorded_while_the_device_runs_others_answer_as_single_poses() {
    let srv = TestServer::start(|c| c.cull_batch = 4).await;
    let http = reqwest::Client::new();
    let poses = street_walk(10, [160, 90]);
    let body = |refine: bool| {
        json!({"poses": poses.iter().map(pose_json).collect::<Vec<_>>(),
               "options": {"method": "hom", "refine": refine}})
    };
    let mut singles = std::collections::HashMap::new();
    for refine in [true, false] {
        let mut visible = Vec::new();
        for p in &poses {
            let r: CullResponse = post_json(
                &http,
                srv.url("/v1/scenes/demo/cull"),
                &json!({"pose": pose_json(p), "options": {"method": "hom", "refine": refine}}),
            )
            .await;
            visible.push(r.visible);
        }
        singles.insert(refine, visible);
    }
    let clients = (0..6).map(|k| {
        let (http, url, body) = (
            http.clone(),
            srv.url("/v1/scenes/demo/cull/batch"),
            body(k % 2 == 0),
        );
        tokio::spawn(async move {
            let r: BatchResponse = post_json(&http, url, &body).await;
            (
                k % 2 == 0,
                r.results.into_iter().map(|r| r.visible).collect::<Vec<_>>(),
            )
        })
    });
    for client in clients {
        let (refine, visible) = client.await.unwrap();
        assert_eq!(visible, singles[&refine], "refine {refine}");
    }
    let metrics = http
        .get(srv.url("/metrics"))
        .send()
        .await
        .unwrap()
        .text()
        .await
        .unwrap();
    let overlapped: f64 = metrics
        .lines()
        .find_map(|l| l.strip_prefix("homcull_worker_overlapped_batches_total "))
        .map_or(0.0, |v| v.trim().parse().unwrap());
    eprintln!("adapter {}: {overlapped} batches overlapped", srv.adapter);
    // The CPU backend answers as it starts: nothing is ever in flight there.
    if !srv.adapter.starts_with("native CPU") {
        assert!(overlapped >= 2.0, "batches overlapped: {overlapped}");
    }
    srv.stop().await;
}

/// With `options.lod`, single and batch answers carry a level per visible object,
/// computed from the pose and the object table the server publishes; without it, no
/// `lod` key; bad thresholds are a 400 that says why.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn answers_carry_level_of_detail_hints_when_asked() {
    use homcull::core::camera::Camera;
    use homcull::core::geom::Aabb;
    use homcull_proto::{LodThresholds, ObjectList};

    let srv = TestServer::start(|_| {}).await;
    let http = reqwest::Client::new();
    let objects: ObjectList = get_json(&http, srv.url("/v1/scenes/demo/objects")).await;
    let bounds = |id: u32| {
        let [min, max] = objects.objects[id as usize].aabb;
        Aabb {
            min: min.into(),
            max: max.into(),
        }
    };
    let poses = street_walk(4, [960, 540]);
    let thresholds = LodThresholds::new(&[64.0, 16.0, 4.0]).unwrap();
    let options = json!({"method": "hom", "lod": {"px": [64, 16, 4]}});
    let batch: BatchResponse = post_json(
        &http,
        srv.url("/v1/scenes/demo/cull/batch"),
        &json!({"poses": poses.iter().map(pose_json).collect::<Vec<_>>(), "options": options}),
    )
    .await;
    let mut levels_seen = std::collections::BTreeSet::new();
    for (pose, r) in poses.iter().zip(&batch.results) {
        let cam = Camera::new(pose).unwrap();
        let expected =
            homcull::core::lod::levels(std::slice::from_ref(&cam), &r.visible, bounds, &thresholds);
        assert_eq!(r.lod.as_ref(), Some(&expected));
        levels_seen.extend(expected);
        let single: CullResponse = post_json(
            &http,
            srv.url("/v1/scenes/demo/cull"),
            &json!({"pose": pose_json(pose), "options": options}),
        )
        .await;
        assert_eq!((&single.visible, &single.lod), (&r.visible, &r.lod));
    }
    assert!(levels_seen.len() >= 3, "levels {levels_seen:?}");
    let plain: Value = post_json(
        &http,
        srv.url("/v1/scenes/demo/cull"),
        &json!({"pose": pose_json(&poses[0])}),
    )
    .await;
    assert!(plain.get("lod").is_none(), "no lod unless asked: {plain}");
    for bad in [
        json!({"px": [4, 16]}),
        json!({"px": []}),
        json!({"px": [64, -1]}),
    ] {
        let r = http
            .post(srv.url("/v1/scenes/demo/cull"))
            .json(&json!({"pose": pose_json(&poses[0]), "options": {"lod": bad}}))
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), 400, "{bad}");
        let body: homcull_proto::ErrorBody = r.json().await.unwrap();
        let message = body.error.message;
        assert!(message.contains("lod.px"), "{bad}: {message}");
    }
    srv.stop().await;
}

/// A stereo pose answers with every object either eye may see: the union of the
/// answers for its two eyes' own poses, with a level per object from the eye that sees
/// it larger; bad stereo parameters are an `invalid_pose` naming the field, in a batch
/// with the pose's index.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stereo_pose_answers_for_both_eyes() {
    use homcull::core::camera::stereo::eye_pose;
    use homcull_proto::Stereo;

    let srv = TestServer::start(|_| {}).await;
    let http = reqwest::Client::new();
    let cull = srv.url("/v1/scenes/demo/cull");
    let options = json!({"lod": {"px": [64, 16, 4]}});
    for pose in street_walk(4, [640, 360]) {
        let stereo = homcull_proto::Pose {
            stereo: Some(Stereo {
                ipd_m: 0.5,
                convergence_m: None,
            }),
            ..pose.clone()
        };
        let both: CullResponse =
            post_json(&http, &cull, &json!({"pose": stereo, "options": options})).await;
        let mut union = std::collections::BTreeMap::new();
        for offset in [-0.25, 0.25] {
            let eye = eye_pose(&pose, offset);
            let r: CullResponse =
                post_json(&http, &cull, &json!({"pose": eye, "options": options})).await;
            for (id, level) in r.visible.iter().zip(r.lod.unwrap()) {
                // The finer level (the larger projection) of the two eyes.
                let l = union.entry(*id).or_insert(level);
                *l = (*l).min(level);
            }
        }
        let (ids, levels): (Vec<u32>, Vec<u8>) = union.into_iter().unzip();
        assert_eq!(both.visible, ids);
        assert_eq!(both.lod, Some(levels));
        let s = &both.stats;
        assert_eq!(s.candidates + s.culled_by_frustum, s.objects);
        assert_eq!(
            both.visible.len() as u32 + s.culled_by_occlusion,
            s.candidates
        );
        // The same in a batch, beside a mono pose.
        let batch: BatchResponse = post_json(
            &http,
            srv.url("/v1/scenes/demo/cull/batch"),
            &json!({"poses": [pose, stereo], "options": options}),
        )
        .await;
        assert_eq!(batch.results[1].visible, both.visible);
        assert!(batch.results[0].visible.len() <= both.visible.len());
    }
    let pose = &street_walk(1, [640, 360])[0];
    for (stereo, field) in [
        (json!({"ipd_m": 0.0}), "ipd_m"),
        (
            json!({"ipd_m": 0.064, "convergence_m": 0.01}),
            "convergence_m",
        ),
    ] {
        let mut bad = serde_json::to_value(pose).unwrap();
        bad["stereo"] = stereo;
        let r = http
            .post(srv.url("/v1/scenes/demo/cull/batch"))
            .json(&json!({"poses": [pose, bad]}))
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), 400);
        let body: homcull_proto::ErrorBody = r.json().await.unwrap();
        assert_eq!(body.error.code, "invalid_pose");
        assert!(
            body.error.message.contains("pose 1") && body.error.message.contains(field),
            "{}",
            body.error.message
        );
    }
    srv.stop().await;
}

/// A pose with a region answers for the whole region through `/cull` and `/cull/batch`
/// (a superset of the point answer at its centre, the batch agreeing with the single
/// pose); `exact` refuses a region with `region_unsupported`, and bad regions are an
/// `invalid_pose` naming the field, with the batch pose's index.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_pose_with_a_region_answers_for_the_region() {
    let srv = TestServer::start(|_| {}).await;
    let http = reqwest::Client::new();
    let cull = srv.url("/v1/scenes/demo/cull");
    let pose = street_walk(1, [480, 270]).remove(0);
    let mut asked = serde_json::to_value(&pose).unwrap();
    asked["region"] = json!({"radius_m": 0.5, "turn_deg": 10});
    let point: CullResponse = post_json(&http, cull.clone(), &json!({"pose": pose})).await;
    let region: CullResponse = post_json(&http, cull.clone(), &json!({"pose": asked})).await;
    let missing: Vec<_> = point
        .visible
        .iter()
        .filter(|id| region.visible.binary_search(id).is_err())
        .collect();
    assert!(missing.is_empty(), "the region answer lacks {missing:?}");
    assert!(region.stats.culled_by_occlusion > 0, "{:?}", region.stats);
    let batch: BatchResponse = post_json(
        &http,
        srv.url("/v1/scenes/demo/cull/batch"),
        &json!({"poses": [pose, asked]}),
    )
    .await;
    assert_eq!(batch.results[0].visible, point.visible);
    assert_eq!(batch.results[1].visible, region.visible);
    let refused = |r: reqwest::Response| async move {
        let status = r.status();
        let body: homcull_proto::ErrorBody = r.json().await.unwrap();
        (status, body.error.code, body.error.message)
    };
    let exact = http
        .post(cull.clone())
        .json(&json!({"pose": asked, "options": {"method": "exact"}}))
        .send()
        .await
        .unwrap();
    let (status, code, _) = refused(exact).await;
    assert_eq!(
        (status.as_u16(), code.as_str()),
        (400, "region_unsupported")
    );
    for (bad, field) in [
        (json!({"radius_m": 0}), "region.radius_m"),
        (json!({"radius_m": 1, "turn_deg": 90}), "region.turn_deg"),
        (json!({"box": [[0, 0, 0], [1, 1, 1]]}), "region.box"),
        (json!({}), "region"),
    ] {
        let mut p = serde_json::to_value(&pose).unwrap();
        p["region"] = bad;
        let r = http
            .post(srv.url("/v1/scenes/demo/cull/batch"))
            .json(&json!({"poses": [pose, p]}))
            .send()
            .await
            .unwrap();
        let (status, code, message) = refused(r).await;
        assert_eq!(
            (status.as_u16(), code.as_str()),
            (400, "invalid_pose"),
            "{message}"
        );
        assert!(
            message.contains("pose 1") && message.contains(field),
            "{message}"
        );
    }
    srv.stop().await;
}

/// Region poses count their maps' pixels, weighted, against a request's work budget:
/// a batch of many every-direction regions is refused before any work.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn region_poses_count_their_maps_against_the_work_budget() {
    let srv = TestServer::start(|_| {}).await;
    let http = reqwest::Client::new();
    let pose = street_walk(1, [960, 540]).remove(0);
    let mut p = serde_json::to_value(&pose).unwrap();
    let c = pose.position;
    p["region"] = json!({"box": [[c[0] - 0.5, c[1] - 0.5, c[2] - 0.5], [c[0] + 0.5, c[1] + 0.5, c[2] + 0.5]], "all_directions": true});
    let poses: Vec<Value> = (0..4).map(|_| p.clone()).collect();
    let r = http
        .post(srv.url("/v1/scenes/demo/cull/batch"))
        .json(&json!({"poses": poses}))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 413);
    let body: homcull_proto::ErrorBody = r.json().await.unwrap();
    assert_eq!(body.error.code, "work_too_large");
    // The same poses without their regions are well within it.
    let points: Vec<_> = (0..4).map(|_| pose.clone()).collect();
    let ok: BatchResponse = post_json(
        &http,
        srv.url("/v1/scenes/demo/cull/batch"),
        &json!({"poses": points}),
    )
    .await;
    assert_eq!(ok.results.len(), 4);
    srv.stop().await;
}
