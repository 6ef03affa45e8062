//! Soak: legitimate clients side by side with abusive ones for a fixed time, on
//! loopback, stopping by itself (`HOMCULL_SOAK_S`, default 20 s; CI runs the default).
//!
//! Legitimate clients (from 127.0.0.1): two WebSocket walkers and one REST client
//! culling a street walk through the demo city, every answer checked against the
//! answer the quiet server gave for the same pose. Abusive clients (from 127.0.0.2, a
//! loopback address of its own, so that the per-address cap is the one that meets
//! them): stream clients that never read, idle sockets, slow headers, floods of garbage
//! frames, hostile uploads and batches over the work budget, each reconnecting when
//! dropped.
//!
//! What must hold: every legitimate answer is correct and none fails; their p99 stays
//! under [`LEGIT_P99_MS`]; `/healthz` stays quick; afterwards the open file descriptors
//! return to their baseline and resident memory to within [`RSS_SLACK_MIB`] of it; the
//! scene stored before the soak is still there, byte for byte, and nothing else was
//! stored.

mod common;

use std::net::{IpAddr, SocketAddr};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use common::server::{TestServer, get_bytes, street_walk};
use common::ws::{Tracker, Ws, connect, next_frame, pose_frame, rest_cull};
use common::{hostile, open_fds, rss_mib};
use futures_util::{SinkExt, StreamExt};
use homcull::eval::percentiles::Percentiles;
use homcull_proto::{Pose, SceneList};
use serde_json::json;
use tokio::io::AsyncWriteExt;
use tokio::net::{TcpSocket, TcpStream};
use tokio::sync::Mutex;
use tokio_tungstenite::tungstenite::Message;

/// Bound on the legitimate clients' p99 answer time (lavapipe on 2 cores, 160×90).
const LEGIT_P99_MS: f64 = 2_000.0;
/// Bound on `/healthz`'s slowest answer during the soak.
const HEALTHZ_MAX_MS: f64 = 1_000.0;
/// Resident memory may end this far above its baseline (allocator arenas, caches).
const RSS_SLACK_MIB: f64 = 64.0;

const ABUSER: &str = "127.0.0.2";

/// A TCP connection to the server from the abusers' address.
async fn abuser_tcp(server: SocketAddr) -> std::io::Result<TcpStream> {
    let socket = TcpSocket::new_v4()?;
    socket.bind(SocketAddr::new(ABUSER.parse().unwrap(), 0))?;
    socket.connect(server).await
}

/// A stream from the abusers' address (`None` if refused, e.g. by the address cap).
async fn abuser_ws(srv: &TestServer) -> Option<Ws> {
    let tcp = abuser_tcp(srv.addr).await.ok()?;
    let url = srv.ws_url("/v1/scenes/demo/stream");
    let (ws, _) =
        tokio_tungstenite::client_async(url, tokio_tungstenite::MaybeTlsStream::Plain(tcp))
            .await
            .ok()?;
    Some(ws)
}

/// What the legitimate clients saw.
#[derive(Default)]
struct Legit {
    rtt_ms: Vec<f64>,
    wrong: usize,
    failed: usize,
}

async fn ws_walker(srv: &TestServer, walk: &[Pose], want: &[Vec<u32>], until: Instant) -> Legit {
    let mut out = Legit::default();
    let mut ws = connect(srv, "").await;
    let mut t = Tracker::default();
    let mut seq = 0u32;
    while Instant::now() < until {
        let i = seq as usize % walk.len();
        seq += 1;
        let sent = Instant::now();
        if ws.send(pose_frame(seq, &walk[i], false)).await.is_err() {
            out.failed += 1;
            break;
        }
        let frame = next_frame(&mut ws).await;
        if !matches!(
            frame,
            homcull_proto::frame::Frame::Full(_) | homcull_proto::frame::Frame::Delta(_)
        ) {
            out.failed += 1;
            continue;
        }
        assert_eq!(t.apply(&frame), seq);
        out.rtt_ms.push(sent.elapsed().as_secs_f64() * 1e3);
        if t.set != want[i] {
            out.wrong += 1;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let _ = ws.close(None).await;
    out
}

async fn rest_client(srv: &TestServer, walk: &[Pose], want: &[Vec<u32>], until: Instant) -> Legit {
    let mut out = Legit::default();
    let http = reqwest::Client::new();
    let url = srv.url("/v1/scenes/demo/cull");
    let mut i = 0;
    while Instant::now() < until {
        let sent = Instant::now();
        let body = json!({ "pose": walk[i], "options": { "refine": false } });
        match http.post(&url).json(&body).send().await {
            Ok(r) if r.status() == 200 => {
                let got: homcull_proto::CullResponse = r.json().await.unwrap();
                out.rtt_ms.push(sent.elapsed().as_secs_f64() * 1e3);
                if got.visible != want[i] {
                    out.wrong += 1;
                }
            }
            _ => out.failed += 1,
        }
        i = (i + 1) % walk.len();
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    out
}

/// Every kind of abuse, over and over until `until`; counts the rounds.
async fn abuse(srv: Arc<TestServer>, walk: Vec<Pose>, until: Instant, rounds: Arc<AtomicU64>) {
    let local: IpAddr = ABUSER.parse().unwrap();
    let http = reqwest::Client::builder()
        .local_address(local)
        .build()
        .unwrap();
    let held = Arc::new(Mutex::new(Vec::new())); // idle sockets and slow headers
    let mut k = 0usize;
    while Instant::now() < until {
        k += 1;
        // A stream client that sends poses and never reads.
        if let Some(mut ws) = abuser_ws(&srv).await {
            let walk = walk.clone();
            tokio::spawn(async move {
                for (i, p) in walk.iter().cycle().take(100).enumerate() {
                    if ws.send(pose_frame(i as u32, p, false)).await.is_err() {
                        break;
                    }
                    tokio::time::sleep(Duration::from_millis(30)).await;
                }
            });
        }
        // A flood of garbage frames.
        if let Some(mut ws) = abuser_ws(&srv).await {
            for _ in 0..70 {
                if ws
                    .send(Message::Binary(vec![0xAB; 40].into()))
                    .await
                    .is_err()
                {
                    break;
                }
            }
            let _ = tokio::time::timeout(Duration::from_secs(2), async {
                while let Some(Ok(_)) = ws.next().await {}
            })
            .await;
        }
        // Idle sockets and slow headers, held until the server closes them.
        for slow in [false, true] {
            if let Ok(mut tcp) = abuser_tcp(srv.addr).await {
                if slow {
                    let _ = tcp.write_all(b"GET /healthz HTTP/1.1\r\nHo").await;
                }
                held.lock().await.push(tcp);
            }
        }
        // A hostile upload, and a batch far over the work budget.
        let files = hostile::all_refused();
        let (_, glb) = &files[k % files.len()];
        let r = http
            .post(srv.url("/v1/scenes?name=hostile"))
            .body(glb.clone())
            .send()
            .await;
        assert!(r.is_err() || r.unwrap().status().is_client_error());
        let huge: Vec<Pose> = walk
            .iter()
            .cycle()
            .take(1024)
            .map(|p| Pose {
                viewport: [4096, 4096],
                ..p.clone()
            })
            .collect();
        let r = http
            .post(srv.url("/v1/scenes/demo/cull/batch"))
            .json(&json!({ "poses": huge }))
            .send()
            .await;
        assert!(r.is_err() || r.unwrap().status() == 413);
        rounds.fetch_add(1, Ordering::Relaxed);
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    held.lock().await.clear();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn legitimate_clients_stay_correct_and_quick_among_abusive_ones() {
    let secs: u64 = std::env::var("HOMCULL_SOAK_S")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(20);
    let srv = Arc::new(
        TestServer::start(|c| {
            c.ws_send_timeout_s = 2;
            c.ws_idle_timeout_s = 3;
            c.header_timeout_s = 2;
            c.max_connections_per_address = 16;
        })
        .await,
    );
    let walk = street_walk(16, [160, 90]);
    let http = reqwest::Client::new();
    let mut want = Vec::new();
    for p in &walk {
        want.push(rest_cull(&http, &srv, p).await);
    }
    let stored = http
        .post(srv.url("/v1/scenes?name=keep"))
        .body(common::rest::small_glb())
        .send()
        .await
        .unwrap();
    assert_eq!(stored.status(), 201);
    let kept: homcull_proto::SceneInfo = stored.json().await.unwrap();
    let kept_glb = get_bytes(&http, srv.url(&format!("/v1/scenes/{}/glb", kept.id))).await;
    drop(http);
    // Warm up every path once before the baseline (allocator arenas, first-use caches).
    let warm = Instant::now() + Duration::from_secs(3);
    abuse(srv.clone(), walk.clone(), warm, Arc::default()).await;
    tokio::time::sleep(Duration::from_secs(4)).await; // the abusers' sockets are closed
    let (fds0, rss0) = (open_fds(), rss_mib());

    let until = Instant::now() + Duration::from_secs(secs);
    let rounds = Arc::new(AtomicU64::new(0));
    let abusers = tokio::spawn(abuse(srv.clone(), walk.clone(), until, rounds.clone()));
    let health = {
        let srv = srv.clone();
        tokio::spawn(async move {
            let http = reqwest::Client::new();
            let mut worst: f64 = 0.0;
            while Instant::now() < until {
                let t = Instant::now();
                let r = http.get(srv.url("/healthz")).send().await.unwrap();
                assert_eq!(r.status(), 200);
                worst = worst.max(t.elapsed().as_secs_f64() * 1e3);
                tokio::time::sleep(Duration::from_millis(200)).await;
            }
            worst
        })
    };
    let (a, b, c) = tokio::join!(
        ws_walker(&srv, &walk, &want, until),
        ws_walker(&srv, &walk, &want, until),
        rest_client(&srv, &walk, &want, until),
    );
    abusers.await.unwrap();
    let healthz_worst = health.await.unwrap();

    let mut rtts = Vec::new();
    for l in [&a, &b, &c] {
        assert_eq!(l.wrong, 0, "a legitimate client got a wrong answer");
        assert_eq!(l.failed, 0, "a legitimate request failed");
        assert!(!l.rtt_ms.is_empty());
        rtts.extend_from_slice(&l.rtt_ms);
    }
    let p = Percentiles::of(rtts.clone());
    eprintln!(
        "soak {secs} s: {} legitimate answers, p50 {:.1} ms, p99 {:.1} ms; {} abuse rounds; \
         /healthz worst {healthz_worst:.1} ms",
        rtts.len(),
        p.p50,
        p.p99,
        rounds.load(Ordering::Relaxed)
    );
    assert!(p.p99 < LEGIT_P99_MS, "legitimate p99 {:.1} ms", p.p99);
    assert!(
        healthz_worst < HEALTHZ_MAX_MS,
        "/healthz took {healthz_worst:.1} ms"
    );
    assert!(rounds.load(Ordering::Relaxed) > 0);

    // Nothing leaks: once the abusers' sockets are closed, descriptors and memory return.
    let settle = Instant::now() + Duration::from_secs(15);
    while open_fds() > fds0 && Instant::now() < settle {
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    let (fds1, rss1) = (open_fds(), rss_mib());
    eprintln!("fds {fds0} -> {fds1}, RSS {rss0:.1} -> {rss1:.1} MiB");
    assert!(fds1 <= fds0, "file descriptors {fds0} -> {fds1}");
    assert!(
        rss1 < rss0 + RSS_SLACK_MIB,
        "RSS {rss0:.1} -> {rss1:.1} MiB"
    );

    // Nothing stored is lost, nothing hostile stored.
    let http = reqwest::Client::new();
    let list: SceneList = common::server::get_json(&http, srv.url("/v1/scenes")).await;
    let ids: Vec<&str> = list.scenes.iter().map(|s| s.id.as_str()).collect();
    let mut want_ids = vec!["demo", kept.id.as_str()];
    want_ids.sort_unstable();
    assert_eq!(ids, want_ids);
    let glb = get_bytes(&http, srv.url(&format!("/v1/scenes/{}/glb", kept.id))).await;
    assert_eq!(glb, kept_glb);
    let on_disk = std::fs::read_dir(srv.data_dir.join("scenes"))
        .unwrap()
        .count();
    assert_eq!(on_disk, 1, "only the kept scene is stored");
    drop(http);
    Arc::try_unwrap(srv)
        .ok()
        .expect("every client is done")
        .stop()
        .await;
}
