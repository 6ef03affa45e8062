//! Abusive connections and a dying worker: slow-header and idle keep-alive connections
//! are closed after the header timeout; one address holds at most its cap of
//! connections and streams (429 past it); a WebSocket client that stops reading is
//! dropped within the send timeout although its frames still fit the kernel's buffers;
//! an upload over its load budget is refused and never stored; a cull worker that dies
//! is restarted, and one that dies too often makes `/readyz` say so and the server
//! stop with an error.

use crate::common;

use std::time::{Duration, Instant};

use common::hostile;
use common::rest::error_of;
use common::server::{TestServer, get_json, street_walk};
use common::ws::{connect, pose_frame};
use futures_util::{SinkExt, StreamExt};
use homcull_proto::SceneList;
use serde_json::json;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

/// Reads until the peer closes; the time that took, or `None` if it stays open `within`.
async fn closed_within(tcp: &mut TcpStream, within: Duration) -> Option<Duration> {
    let t = Instant::now();
    let mut buf = [0u8; 4096];
    loop {
        match tokio::time::timeout_at((t + within).into(), tcp.read(&mut buf)).await {
            Err(_) => return None,
            Ok(Ok(0)) | Ok(Err(_)) => return Some(t.elapsed()),
            Ok(Ok(_)) => {}
        }
    }
}

/// Everything a connection answers until it closes (or for a second).
async fn read_answer(tcp: &mut TcpStream) -> String {
    let mut out = Vec::new();
    let _ = tokio::time::timeout(Duration::from_secs(1), tcp.read_to_end(&mut out)).await;
    String::from_utf8_lossy(&out).into_owned()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn slow_header_and_idle_connections_are_closed_after_the_header_timeout() {
    let srv = TestServer::start(|c| c.header_timeout_s = 1).await;
    let http = reqwest::Client::new();
    let mut slow = Vec::new();
    for _ in 0..20 {
        let mut tcp = TcpStream::connect(srv.addr).await.unwrap();
        tcp.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n")
            .await
            .unwrap();
        slow.push(tcp);
    }
    // A keep-alive connection that got its answer and then says nothing.
    let mut idle = TcpStream::connect(srv.addr).await.unwrap();
    idle.write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n")
        .await
        .unwrap();
    let mut first = [0u8; 12];
    idle.read_exact(&mut first).await.unwrap();
    assert_eq!(&first, b"HTTP/1.1 200");
    let r = http.get(srv.url("/healthz")).send().await.unwrap();
    assert_eq!(r.status(), 200, "others are served meanwhile");
    for tcp in slow.iter_mut().chain([&mut idle]) {
        let took = closed_within(tcp, Duration::from_secs(5)).await;
        assert!(
            took.is_some(),
            "a silent connection stays open past the header timeout"
        );
    }
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_address_holds_at_most_its_cap_of_connections_and_streams() {
    let srv = TestServer::start(|c| c.max_connections_per_address = 3).await;
    // The start-up's readiness polls closed their connection when their client went.
    tokio::time::sleep(Duration::from_millis(300)).await;
    let ws1 = connect(&srv, "").await;
    let _ws2 = connect(&srv, "").await;
    let mut third = TcpStream::connect(srv.addr).await.unwrap();
    third
        .write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n")
        .await
        .unwrap();
    let mut head = [0u8; 12];
    third.read_exact(&mut head).await.unwrap();
    assert_eq!(
        &head, b"HTTP/1.1 200",
        "two streams and one connection fit a cap of 3"
    );
    let mut fourth = TcpStream::connect(srv.addr).await.unwrap();
    let answer = read_answer(&mut fourth).await;
    assert!(answer.starts_with("HTTP/1.1 429"), "{answer}");
    assert!(answer.contains("too_many_connections"), "{answer}");
    // A stream that ends gives its place back.
    let mut ws1 = ws1;
    let _ = ws1.close(None).await;
    drop(ws1);
    tokio::time::sleep(Duration::from_millis(300)).await;
    let mut fifth = TcpStream::connect(srv.addr).await.unwrap();
    fifth
        .write_all(b"GET /healthz HTTP/1.1\r\nHost: x\r\n\r\n")
        .await
        .unwrap();
    fifth.read_exact(&mut head).await.unwrap();
    assert_eq!(&head, b"HTTP/1.1 200", "a closed stream frees its place");
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_refused_stream_upgrade_leaves_its_connection_counted() {
    let srv = TestServer::start(|c| {
        c.max_connections_per_address = 2;
        c.max_ws_clients = 1;
    })
    .await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    let _ws = connect(&srv, "").await;
    // A second stream is over the WebSocket client cap: 503, and its connection stays.
    let mut refused = TcpStream::connect(srv.addr).await.unwrap();
    refused
        .write_all(
            b"GET /v1/scenes/demo/stream HTTP/1.1\r\nHost: x\r\nConnection: Upgrade\r\n\
              Upgrade: websocket\r\nSec-WebSocket-Version: 13\r\n\
              Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\r\n",
        )
        .await
        .unwrap();
    let mut head = [0u8; 12];
    refused.read_exact(&mut head).await.unwrap();
    assert_eq!(&head, b"HTTP/1.1 503");
    let mut third = TcpStream::connect(srv.addr).await.unwrap();
    let answer = read_answer(&mut third).await;
    assert!(
        answer.starts_with("HTTP/1.1 429"),
        "the open connection of the refused upgrade no longer counted: {answer}"
    );
    drop(refused);
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stream_client_that_stops_reading_is_dropped_within_the_send_timeout() {
    let srv = TestServer::start(|c| c.ws_send_timeout_s = 1).await;
    let mut ws = connect(&srv, "").await;
    let poses = street_walk(8, [160, 90]);
    // Send poses for 4 s and read nothing: ~80 small frames, far from filling buffers.
    let t = Instant::now();
    let mut seq = 0;
    while t.elapsed() < Duration::from_secs(4) {
        seq += 1;
        if ws
            .send(pose_frame(seq, &poses[seq as usize % 8], false))
            .await
            .is_err()
        {
            break; // dropped already
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    // Now read: the buffered frames, then the end. A stream still open would leave
    // `next` waiting for frames no pose asks for.
    let ended = tokio::time::timeout(Duration::from_secs(5), async {
        while let Some(Ok(_)) = ws.next().await {}
    })
    .await;
    assert!(ended.is_ok(), "the server kept the non-reading client");
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_upload_over_its_load_budget_is_refused_and_not_stored() {
    let srv = TestServer::start(|c| {
        c.no_demo = true;
        c.load_timeout_s = 0;
    })
    .await;
    let http = reqwest::Client::new();
    let r = http
        .post(srv.url("/v1/scenes?name=slow"))
        .body(hostile::many_instances(200_000))
        .send()
        .await
        .unwrap();
    assert_eq!(error_of(r).await, (422, "load_timeout".to_string()));
    tokio::time::sleep(Duration::from_secs(3)).await; // the load finishes meanwhile
    let list: SceneList = get_json(&http, srv.url("/v1/scenes")).await;
    assert!(list.scenes.is_empty(), "{:?}", list.scenes);
    let stored = std::fs::read_dir(srv.data_dir.join("scenes"))
        .unwrap()
        .count();
    assert_eq!(stored, 0);
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn many_instances_of_one_mesh_upload_within_seconds() {
    let srv = TestServer::start(|c| c.no_demo = true).await;
    let http = reqwest::Client::new();
    let t = Instant::now();
    let r = http
        .post(srv.url("/v1/scenes?name=instances"))
        .body(hostile::many_instances(30_000))
        .send()
        .await
        .unwrap();
    assert_eq!(r.status(), 201);
    // Before the bounded BVH build this took 77 s (quadratic on identical boxes).
    assert!(t.elapsed() < Duration::from_secs(10), "{:?}", t.elapsed());
    srv.stop().await;
}

fn cull_body() -> serde_json::Value {
    json!({"pose": {"position": [0.0, 1.7, 0.0], "look_at": [30.0, 1.7, 0.0],
                    "viewport": [160, 90]}})
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_worker_that_dies_is_restarted_and_culls_go_on() {
    let srv = TestServer::start(|c| c.worker_panics = 1).await;
    let http = reqwest::Client::new();
    let url = srv.url("/v1/scenes/demo/cull");
    let r = http.post(&url).json(&cull_body()).send().await.unwrap();
    assert_eq!(error_of(r).await.0, 500, "the job the worker held fails");
    let r = http.post(&url).json(&cull_body()).send().await.unwrap();
    assert_eq!(r.status(), 200, "the restarted worker culls");
    let ready: serde_json::Value = get_json(&http, srv.url("/readyz")).await;
    assert_eq!(
        (ready["worker"].as_str(), ready["worker_restarts"].as_u64()),
        (Some("running"), Some(1))
    );
    srv.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_worker_that_keeps_dying_stops_the_server_with_an_error() {
    let mut srv = TestServer::start(|c| {
        c.worker_panics = 100;
        c.worker_restarts = 1;
    })
    .await;
    let http = reqwest::Client::new();
    let url = srv.url("/v1/scenes/demo/cull");
    for _ in 0..2 {
        let r = http.post(&url).json(&cull_body()).send().await.unwrap();
        assert_eq!(error_of(r).await.0, 500);
    }
    // The failed job's answer can come a moment before the worker is marked stopped.
    let mut r = http.get(srv.url("/readyz")).send().await.unwrap();
    for _ in 0..50 {
        if r.status() == 503 {
            break;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
        r = http.get(srv.url("/readyz")).send().await.unwrap();
    }
    assert_eq!(r.status(), 503, "a stopped worker is not ready");
    let ready: serde_json::Value = r.json().await.unwrap();
    assert_eq!(ready["worker"], "stopped");
    let r = http.post(&url).json(&cull_body()).send().await.unwrap();
    assert_eq!(error_of(r).await, (503, "worker_stopped".to_string()));
    let t = Instant::now();
    let ended = srv.ended(Duration::from_secs(20)).await;
    let err = ended.expect_err("the server must stop with an error");
    assert!(err.to_string().contains("cull worker"), "{err}");
    assert!(t.elapsed() < Duration::from_secs(15));
}
