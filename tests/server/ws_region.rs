//! Region streams (`?region_m=&turn_deg=`): one cull per region, announced with a
//! region frame before its set; the poses that stay inside answered with empty deltas;
//! every pose's view inside the announced region and its exact set within the held one.

use crate::common;

use common::server::{TestServer, post_json, street_walk};
use common::ws::{Tracker, connect, connect_hello, next_frame, pose_frame};
use futures_util::SinkExt;
use glam::Vec3;
use homcull_proto::frame::{ErrorCode, Frame, RegionFrame};
use homcull_proto::{CullResponse, Pose, Stereo};
use serde_json::json;

/// A slow walk down the demo street: 3 cm and under a degree of turn per pose.
fn slow_walk(n: usize) -> Vec<Pose> {
    (0..n)
        .map(|i| {
            let x = -100.0 + 0.03 * i as f32;
            homcull::eval::loadgen::street_pose([x, 1.7, 0.0], i as f32 * 0.5, [480, 270])
        })
        .collect()
}

use homcull::eval::latency::forward;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_region_stream_culls_once_per_region_and_its_sets_hold() {
    let srv = TestServer::start(|_| {}).await;
    let http = reqwest::Client::new();
    let (mut ws, hello) = connect_hello(&srv, "?region_m=0.5&turn_deg=10").await;
    assert_eq!(hello["region"], json!({"radius_m": 0.5, "turn_deg": 10.0}));
    let walk = slow_walk(48);
    let mut t = Tracker::default();
    let mut region: Option<RegionFrame> = None;
    let (mut regions, mut empty) = (0, 0);
    for (i, pose) in walk.iter().enumerate() {
        let seq = i as u32 + 1;
        ws.send(pose_frame(seq, pose, false)).await.unwrap();
        // A region frame comes before the set it holds for.
        let frame = match next_frame(&mut ws).await {
            Frame::Region(r) => {
                // 0.5 m at least: more only for a client too fast for it.
                assert_eq!((r.ack, r.turn_deg), (seq, 10.0));
                assert!((0.5..=5.0).contains(&r.radius_m), "{r:?}");
                let centre = Vec3::from(r.centre);
                assert!(
                    centre.distance(Vec3::from(pose.position)) <= r.radius_m / 4.0 + 1e-4,
                    "pose {i}: the region's centre lies a quarter radius ahead at most"
                );
                region = Some(r);
                regions += 1;
                next_frame(&mut ws).await
            }
            f => f,
        };
        if let Frame::Delta(d) = &frame
            && d.added.is_empty()
            && d.removed.is_empty()
        {
            empty += 1;
        }
        assert_eq!(t.apply(&frame), seq);
        let r = region.expect("the first answer comes with its region");
        assert!(
            r.holds(pose.position, forward(pose)),
            "pose {i} lies outside the region it is answered with: {r:?}"
        );
        let exact: CullResponse = post_json(
            &http,
            srv.url("/v1/scenes/demo/cull"),
            &json!({"pose": pose, "options": {"method": "exact"}}),
        )
        .await;
        let missing: Vec<u32> = exact
            .visible
            .iter()
            .copied()
            .filter(|id| t.set.binary_search(id).is_err())
            .collect();
        assert!(
            missing.is_empty(),
            "pose {i}: the held set lacks {missing:?}"
        );
    }
    eprintln!("48 poses: {regions} regions, {empty} empty deltas");
    assert!(
        (1..=12).contains(&regions),
        "a walk of 1.4 m with 0.5 m regions culls a few regions, not {regions}"
    );
    assert!(
        empty >= 48 - 2 * regions,
        "poses inside a region get empty deltas"
    );
    srv.stop().await;
}

/// A client faster than its regions (20 cm a pose, sent as soon as the last is
/// answered) gets larger ones, up to 5 m, each still holding the pose it answers.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_fast_client_gets_larger_regions() {
    let srv = TestServer::start(|_| {}).await;
    let (mut ws, _) = connect_hello(&srv, "?region_m=0.5&turn_deg=10").await;
    let mut t = Tracker::default();
    let mut radii = Vec::new();
    for i in 0..40u32 {
        let x = -100.0 + 0.2 * i as f32;
        let pose = homcull::eval::loadgen::street_pose([x, 1.7, 0.0], 0.0, [480, 270]);
        ws.send(pose_frame(i + 1, &pose, false)).await.unwrap();
        let frame = match next_frame(&mut ws).await {
            Frame::Region(r) => {
                assert!(r.holds(pose.position, forward(&pose)), "{r:?}");
                radii.push(r.radius_m);
                next_frame(&mut ws).await
            }
            f => f,
        };
        assert_eq!(t.apply(&frame), i + 1);
    }
    eprintln!("region radii: {radii:?}");
    assert_eq!(radii[0], 0.5, "nothing measured yet: the radius asked");
    assert!(radii.iter().all(|r| (0.5..=5.0).contains(r)), "{radii:?}");
    assert!(
        radii.iter().any(|&r| r > 1.0),
        "a client walking metres a second past 0.5 m regions gets larger ones: {radii:?}"
    );
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_region_streams_are_refused_and_stereo_poses_get_an_error_frame() {
    let srv = TestServer::start(|_| {}).await;
    let http = reqwest::Client::new();
    for (query, names) in [
        ("?region_m=-1", "region_m"),
        ("?region_m=NaN", "region_m"),
        ("?region_m=6", "region_m"),
        ("?region_m=0.5&turn_deg=90", "turn_deg"),
        ("?turn_deg=5", "turn_deg"),
        ("?region_m=0.5&lookahead_ms=100", "lookahead_ms"),
    ] {
        // A plain GET stands in for the upgrade: the query is checked first.
        let r = http
            .get(srv.url(&format!("/v1/scenes/demo/stream{query}")))
            .header("connection", "upgrade")
            .header("upgrade", "websocket")
            .header("sec-websocket-version", "13")
            .header("sec-websocket-key", "dGhlIHNhbXBsZSBub25jZQ==")
            .send()
            .await
            .unwrap();
        assert_eq!(r.status(), 400, "{query}");
        let body: serde_json::Value = r.json().await.unwrap();
        let message = body["error"]["message"].as_str().unwrap_or_default();
        assert!(message.contains(names), "{query}: {body}");
    }
    let mut ws = connect(&srv, "?region_m=0.5").await;
    let pose = street_walk(1, [320, 180]).remove(0);
    let stereo = Pose {
        stereo: Some(Stereo {
            ipd_m: 0.064,
            convergence_m: None,
        }),
        ..pose.clone()
    };
    ws.send(pose_frame(1, &stereo, false)).await.unwrap();
    match next_frame(&mut ws).await {
        Frame::Error(e) => {
            assert_eq!((e.ack, e.code), (1, ErrorCode::InvalidPose));
            assert!(e.message.contains("stereo"), "{}", e.message);
        }
        f => panic!("expected an error frame, got {f:?}"),
    }
    ws.send(pose_frame(2, &pose, false)).await.unwrap();
    assert!(matches!(next_frame(&mut ws).await, Frame::Region(r) if r.ack == 2));
    let mut t = Tracker::default();
    assert_eq!(t.apply(&next_frame(&mut ws).await), 2);
    srv.stop().await;
}

/// `homcull loadgen --mode walk` on a region stream: every drawn frame checked against
/// the exact oracle, culls counted by region frames (far fewer than the 60 poses a
/// second the client sends).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_delayed_walk_checks_every_frame_and_counts_region_culls() {
    use homcull::eval::latency::{WalkConfig, WalkPath, walk};

    let srv = TestServer::start(|_| {}).await;
    let host = homcull::eval::loadgen::loopback(&srv.url("")).unwrap();
    let cfg = |query: &str| WalkConfig {
        host: host.clone(),
        scene: "demo".into(),
        seconds: 1.0,
        delay_ms: 20,
        query: query.into(),
        viewport: [480, 270],
        path: WalkPath::DEMO_STREET,
    };
    let region = walk(&cfg("?region_m=1&turn_deg=15")).await.unwrap();
    let point = walk(&cfg("")).await.unwrap();
    eprintln!("{region:?}\n{point:?}");
    for r in [&region, &point] {
        assert_eq!(r.frames, 60);
        assert!(r.waiting < r.frames, "{r:?}: an answer arrived");
    }
    assert!(
        region.held_over_seen > 1.0,
        "{region:?}: region sets hold more"
    );
    assert!(
        region.culls_per_s * 3.0 < point.culls_per_s,
        "a region stream culls far less often: {region:?} against {point:?}"
    );
    srv.stop().await;
}

/// `homcull loadgen --mode walkers`: open-loop walkers send 60 poses a second each,
/// whatever the answers; region streams answer them with far fewer culls.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn open_loop_walkers_send_on_their_clock_and_count_culls() {
    use homcull::eval::walkers::{WalkersConfig, run};

    let srv = TestServer::start(|_| {}).await;
    let host = homcull::eval::loadgen::loopback(&srv.url("")).unwrap();
    let cfg = |query: &str| WalkersConfig {
        host: host.clone(),
        scene: "demo".into(),
        clients: 4,
        seconds: 1.0,
        query: query.into(),
        viewport: [480, 270],
    };
    let region = run(&cfg("?region_m=1&turn_deg=15")).await.unwrap();
    let point = run(&cfg("")).await.unwrap();
    eprintln!("{}\n{}", region.summary(), point.summary());
    for r in [&region, &point] {
        assert_eq!((r.failed_clients, r.errors), (0, 0), "{r:?}");
        // 60 a second each, on the clock, whatever the answers (a tick or two may slip).
        assert!((220..=240).contains(&r.poses_sent), "{r:?}");
        // The test server culls for every test at once: shares, not rates.
        assert!(r.answered_share > 0.1, "{r:?}: the server answers");
        assert!(r.answer_ms.p50 > 0.0, "{r:?}");
    }
    // Mostly, the next region arrives before the walkers leave the last (1 m, half
    // of it held: a third of a second at 1.4 m/s; four regions culled in turn).
    assert!(region.inside_share > 0.5, "{region:?}");
    assert_eq!(point.inside_share, 1.0);
    assert!(
        region.culls_per_client_s > 0.0
            && region.culls_per_client_s * 3.0 < point.culls_per_client_s,
        "a region stream culls far less often: {region:?} against {point:?}"
    );
    let bad = WalkersConfig {
        clients: 0,
        ..cfg("")
    };
    assert!(run(&bad).await.is_err(), "no walkers is refused");
    srv.stop().await;
}
