//! A homcull server started in-process on 127.0.0.1:0 for integration tests.

use std::path::{Path, PathBuf};
use std::time::Duration;

use homcull::core::engine::Backend;
use homcull::server::Config;
use homcull_proto::Pose;
use tokio::sync::oneshot;

pub struct TestServer {
    pub base: String,
    pub addr: std::net::SocketAddr,
    pub data_dir: PathBuf,
    pub adapter: String,
    stop: Option<oneshot::Sender<()>>,
    task: Option<tokio::task::JoinHandle<std::io::Result<()>>>,
    _tmp: Option<tempfile::TempDir>,
}

/// Defaults for tests: a private data dir, quick rescans, no frame-rate cap worth noticing.
pub fn config(data_dir: &Path) -> Config {
    Config {
        data_dir: data_dir.to_path_buf(),
        api_token: None,
        ws_max_fps: 10_000.0,
        rescan_s: 0,
        ..Config::default()
    }
}

impl TestServer {
    /// Starts a server with its own temporary data dir.
    pub async fn start(edit: impl FnOnce(&mut Config)) -> TestServer {
        let tmp = tempfile::tempdir().unwrap();
        let mut s = Self::start_in(tmp.path(), edit).await;
        s._tmp = Some(tmp);
        s
    }

    /// Starts a server on the given data dir and waits until `/readyz` says ready.
    pub async fn start_in(data_dir: &Path, edit: impl FnOnce(&mut Config)) -> TestServer {
        Self::start_on(Backend::from(super::gpu()), data_dir, edit).await
    }

    /// [`TestServer::start_in`] culling on `backend`.
    pub async fn start_on(
        backend: Backend,
        data_dir: &Path,
        edit: impl FnOnce(&mut Config),
    ) -> TestServer {
        let mut cfg = config(data_dir);
        edit(&mut cfg);
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let addr = listener.local_addr().unwrap();
        let adapter = backend.describe();
        let (stop, stopped) = oneshot::channel::<()>();
        let task = tokio::spawn(homcull::server::serve(listener, cfg, backend, async {
            let _ = stopped.await;
        }));
        let base = format!("http://{addr}");
        let client = reqwest::Client::new();
        for _ in 0..600 {
            assert!(
                !task.is_finished(),
                "the server stopped before it was ready"
            );
            if let Ok(r) = client.get(format!("{base}/readyz")).send().await {
                if r.status() == 200 {
                    break;
                }
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        TestServer {
            base,
            addr,
            data_dir: data_dir.to_path_buf(),
            adapter,
            stop: Some(stop),
            task: Some(task),
            _tmp: None,
        }
    }

    pub fn url(&self, path: &str) -> String {
        format!("{}{path}", self.base)
    }

    pub fn ws_url(&self, path: &str) -> String {
        format!("ws://{}{path}", self.addr)
    }

    /// Graceful shutdown; returns once the server task has finished.
    pub async fn stop(mut self) {
        if let Some(s) = self.stop.take() {
            let _ = s.send(());
        }
        if let Some(t) = self.task.take() {
            tokio::time::timeout(Duration::from_secs(30), t)
                .await
                .expect("server stops within 30 s")
                .unwrap()
                .unwrap();
        }
    }

    /// Waits (without a shutdown signal) for the server to stop by itself; its result.
    pub async fn ended(&mut self, within: Duration) -> std::io::Result<()> {
        let task = self.task.take().expect("the server task");
        tokio::time::timeout(within, task)
            .await
            .expect("the server stopped by itself in time")
            .unwrap()
    }

    /// Sends the shutdown signal without waiting.
    pub fn signal_stop(&mut self) {
        if let Some(s) = self.stop.take() {
            let _ = s.send(());
        }
    }
}

/// `GET url`; the answer's JSON body (panics on any failure).
pub async fn get_json<T: serde::de::DeserializeOwned>(
    http: &reqwest::Client,
    url: impl reqwest::IntoUrl,
) -> T {
    http.get(url).send().await.unwrap().json().await.unwrap()
}

/// `GET url`; the answer's body bytes (panics on any failure).
pub async fn get_bytes(http: &reqwest::Client, url: impl reqwest::IntoUrl) -> Vec<u8> {
    http.get(url)
        .send()
        .await
        .unwrap()
        .bytes()
        .await
        .unwrap()
        .to_vec()
}

/// `POST url` with a JSON body; the answer's JSON body (panics on any failure).
pub async fn post_json<T: serde::de::DeserializeOwned>(
    http: &reqwest::Client,
    url: impl reqwest::IntoUrl,
    body: &impl serde::Serialize,
) -> T {
    http.post(url)
        .json(body)
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap()
}

/// A street-level walk through the demo city: along the x axis on the z = 0 street from
/// x = −150 m to 150 m, eye 1.7 m up, looking roughly along the walk with a slow sway.
pub fn street_walk(n: usize, viewport: [u32; 2]) -> Vec<Pose> {
    (0..n)
        .map(|i| {
            let x = -150.0 + 300.0 * i as f32 / n as f32;
            homcull::eval::loadgen::street_pose([x, 1.7, 0.0], i as f32, viewport)
        })
        .collect()
}
