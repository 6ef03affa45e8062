//! The stream options `lookahead_ms` and `hold_ms` (server/motion.rs): a client walking
//! at 1.4 m/s, one pose per 60 Hz frame, along four stretches of the demo city's street.
//!
//! Without options the streamed set is exactly `POST /cull`'s. With them it must stay a
//! superset (conservative), reveal objects before the camera gets there (fewer late
//! reveals: objects in pose k+1's cull that the set streamed for pose k lacked, which a
//! thin client drawing one round trip behind would show late), and change less (delta
//! frames at most a tenth of a full frame).

use crate::common;

use std::time::{Duration, Instant};

use common::server::TestServer;
use common::ws::{
    Tracker, connect, connect_hello, full_frame_len, next_frame, pose_frame, rest_cull,
};
use futures_util::SinkExt;
use homcull_proto::Pose;

const FRAME: Duration = Duration::from_micros(16_667);
const SPEED: f32 = 1.4;
const SMOOTHED: &str = "?lookahead_ms=150&hold_ms=300";

fn stretch(x0: f32, n: usize) -> Vec<Pose> {
    let step = SPEED * FRAME.as_secs_f32();
    (0..n)
        .map(|i| {
            let x = x0 + step * i as f32;
            homcull::eval::loadgen::street_pose([x, 1.7, 0.0], x + 150.0, [480, 270])
        })
        .collect()
}

/// What one client saw on one stretch.
struct Walk {
    sets: Vec<Vec<u32>>,
    delta_bytes: usize,
    full_bytes_equivalent: usize,
}

/// Sends `poses` at 60 Hz (waiting for each answer, which takes less than a frame at
/// this viewport) and records the set after every answer.
async fn walk(srv: &TestServer, query: &str, poses: &[Pose]) -> Walk {
    let mut ws = connect(srv, query).await;
    let mut t = Tracker::default();
    let mut sets = Vec::new();
    let mut full_equivalent = 0;
    let start = Instant::now();
    for (i, pose) in poses.iter().enumerate() {
        tokio::time::sleep_until((start + FRAME * i as u32).into()).await;
        let seq = i as u32 + 1;
        ws.send(pose_frame(seq, pose, false)).await.unwrap();
        assert_eq!(t.apply(&next_frame(&mut ws).await), seq);
        if i > 0 {
            full_equivalent += full_frame_len(&t.set);
        }
        sets.push(t.set.clone());
    }
    Walk {
        sets,
        delta_bytes: t.delta_bytes,
        full_bytes_equivalent: full_equivalent,
    }
}

/// Objects in pose k+1's cull missing from the set streamed for pose k.
fn late_reveals(sets: &[Vec<u32>], rest: &[Vec<u32>]) -> usize {
    (1..rest.len())
        .map(|k| {
            rest[k]
                .iter()
                .filter(|id| sets[k - 1].binary_search(id).is_err())
                .count()
        })
        .sum()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn lookahead_and_hold_stay_conservative_reveal_early_and_change_less() {
    let srv = TestServer::start(|c| c.full_every = 10_000).await;
    let http = reqwest::Client::new();
    let (mut late_plain, mut late_smooth) = (0, 0);
    let (mut plain_bytes, mut smooth_bytes, mut as_full) = (0, 0, 0);
    let (mut extra, mut total) = (0usize, 0usize);
    for x0 in [-150.0, -75.0, 0.0, 75.0] {
        let poses = stretch(x0, 120);
        let mut rest = Vec::new();
        for p in &poses {
            rest.push(rest_cull(&http, &srv, p).await);
        }
        let plain = walk(&srv, "", &poses).await;
        assert_eq!(
            plain.sets, rest,
            "without options the stream is POST /cull's set"
        );
        let smooth = walk(&srv, SMOOTHED, &poses).await;
        for (k, (s, r)) in smooth.sets.iter().zip(&rest).enumerate() {
            let missing: Vec<_> = r.iter().filter(|id| s.binary_search(id).is_err()).collect();
            assert!(
                missing.is_empty(),
                "x0 {x0}, pose {k}: the smoothed set lacks {missing:?} of POST /cull's set"
            );
            extra += s.len() - r.len();
            total += r.len();
        }
        late_plain += late_reveals(&plain.sets, &rest);
        late_smooth += late_reveals(&smooth.sets, &rest);
        plain_bytes += plain.delta_bytes;
        smooth_bytes += smooth.delta_bytes;
        as_full += smooth.full_bytes_equivalent;
    }
    let ratio = smooth_bytes as f64 / as_full as f64;
    eprintln!(
        "4 × 120 poses at 1.4 m/s, 60 Hz: late reveals {late_plain} plain vs {late_smooth} \
         with {SMOOTHED}; delta bytes {plain_bytes} plain vs {smooth_bytes} smoothed \
         ({ratio:.3} of full frames); the smoothed set holds {:.1} % more objects",
        100.0 * extra as f64 / total as f64
    );
    assert!(
        late_plain > 0,
        "walking reveals objects: the check can fail"
    );
    assert!(
        late_smooth * 4 <= late_plain,
        "the lookahead reveals most objects a round trip early: {late_smooth} vs {late_plain}"
    );
    assert!(
        ratio <= 0.1,
        "with a hold, deltas are at most a tenth of a full frame: {ratio:.3}"
    );
    assert!(smooth_bytes < plain_bytes);
    assert!(
        extra * 5 <= total,
        "the smoothed set stays close to the cull's: {extra} extra over {total}"
    );
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn out_of_range_smoothing_options_are_refused() {
    use tokio_tungstenite::tungstenite::Error;
    let srv = TestServer::start(|_| {}).await;
    for q in [
        "lookahead_ms=1001",
        "hold_ms=10001",
        "hold_ms=-1",
        "lookahead_ms=x",
        "threshold=x",
        "refine=maybe",
        "threshold=2",
        "lod_px=4,16",
    ] {
        let url = srv.ws_url(&format!("/v1/scenes/demo/stream?{q}"));
        match tokio_tungstenite::connect_async(url).await {
            Err(Error::Http(resp)) => {
                assert_eq!(resp.status(), 400, "{q}");
                let body: serde_json::Value =
                    serde_json::from_slice(resp.body().as_deref().unwrap_or_default()).unwrap();
                let code = body["error"]["code"].as_str().unwrap();
                assert!(
                    code == "invalid_options" || code == "bad_query",
                    "{q}: {body}"
                );
            }
            Ok(_) => panic!("{q}: the upgrade was accepted"),
            Err(e) => panic!("{q}: {e}"),
        }
    }
    srv.stop().await;
}

/// The stream's cull options come from the one declaration (`CullOptionsQuery`):
/// numbers and booleans read from the query string, the stream's defaults where none
/// is given, and the hello echoes what the stream will cull with.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stream_options_read_typed_from_the_query_over_the_streams_defaults() {
    let srv = TestServer::start(|_| {}).await;
    let (_ws, hello) = connect_hello(&srv, "").await;
    let defaults = serde_json::to_value(homcull_proto::CullOptions::defaults(
        homcull_proto::Surface::Stream,
    ))
    .unwrap();
    assert_eq!(hello["options"], defaults, "{hello}");
    assert_eq!(hello["options"]["refine"], false);
    let q = "?method=hzb&threshold=0.5&deb=tiles&refine=true&lod_px=64,8&hold_ms=100";
    let (_ws, hello) = connect_hello(&srv, q).await;
    let o = &hello["options"];
    assert_eq!(o["method"], "hzb", "{hello}");
    assert_eq!(o["threshold"], 0.5);
    assert_eq!(o["deb"], "tiles");
    assert_eq!(o["refine"], true);
    assert_eq!(o["lod"]["px"], serde_json::json!([64.0, 8.0]));
    srv.stop().await;
}
