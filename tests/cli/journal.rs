//! `homcull serve --state journal` (the default) as a process: placements a writer
//! sent survive `kill -9` and a restart at the same version, `--state memory` forgets
//! them, and a journal that cannot be read refuses updates instead of losing them.

use std::path::Path;
use std::time::Duration;

use crate::common::process::{ServeProcess, spawn_serve};

use serde_json::{Value, json};

struct Server {
    process: ServeProcess,
    base: String,
}

impl Server {
    /// `homcull serve` on a free loopback port over `data_dir`, once it is ready.
    async fn start(data_dir: &Path, state: &str) -> Server {
        let mut args: Vec<std::ffi::OsString> = [
            "--backend",
            "cpu",
            "--rescan-s",
            "0",
            "--state",
            state,
            "--data-dir",
        ]
        .into_iter()
        .map(Into::into)
        .collect();
        args.push(data_dir.as_os_str().to_owned());
        let process = spawn_serve(args);
        let s = Server {
            base: format!("http://{}", process.addr),
            process,
        };
        let http = reqwest::Client::new();
        for _ in 0..600 {
            let r = http.get(format!("{}/readyz", s.base)).send().await;
            if r.is_ok_and(|r| r.status() == 200) {
                return s;
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        panic!("the server did not get ready");
    }

    /// `kill -9`: no shutdown, no flush.
    fn kill(mut self) {
        self.process.child.kill().unwrap();
        self.process.child.wait().unwrap();
    }

    async fn post(&self, path: &str, body: Value) -> (u16, Value) {
        let r = reqwest::Client::new()
            .post(format!("{}{path}", self.base))
            .json(&body)
            .send()
            .await
            .unwrap();
        (r.status().as_u16(), r.json().await.unwrap())
    }

    /// The visible set and scene version of the demo street pose.
    async fn cull(&self) -> (Vec<u64>, u64) {
        let pose = json!({"position": [-60.0, 1.7, 0.0], "look_at": [0.0, 1.7, 0.0], "viewport": [320, 180]});
        let (status, r) = self
            .post("/v1/scenes/demo/cull", json!({"pose": pose}))
            .await;
        assert_eq!(status, 200, "{r}");
        let ids = r["visible"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_u64().unwrap())
            .collect();
        (ids, r["stats"]["scene_version"].as_u64().unwrap())
    }
}

/// Moves each object of `ids` far up until one is accepted (objects that share
/// vertices with another cannot move alone): the one moved and the version.
async fn move_one_away(s: &Server, ids: &[u64]) -> (u64, u64) {
    for &id in ids {
        let update = json!({"objects": [{"id": id, "translation": [0.0, 500.0, 0.0]}]});
        let (status, r) = s.post("/v1/scenes/demo/transforms", update).await;
        if status == 200 {
            return (id, r["version"].as_u64().unwrap());
        }
    }
    panic!("no visible object could be moved");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn placements_survive_kill_and_restart_at_the_same_version() {
    let dir = tempfile::tempdir().unwrap();
    let s = Server::start(dir.path(), "journal").await;
    let (as_loaded, v0) = s.cull().await;
    assert_eq!(v0, 0);
    let (moved, v1) = move_one_away(&s, &as_loaded).await;
    // A second update, with a motion (its infinite validity must survive too).
    let drift = json!({"objects": [{"id": moved, "translation": [0.0, 600.0, 0.0], "velocity": [0.0, 0.0, 1.0]}]});
    let (status, r) = s.post("/v1/scenes/demo/transforms", drift).await;
    assert_eq!(status, 200, "{r}");
    let v2 = r["version"].as_u64().unwrap();
    assert_eq!((v1 + 1, v2), (2, 2));
    let (placed, v) = s.cull().await;
    assert_eq!(v, 2);
    assert!(!placed.contains(&moved), "the moved object left the view");
    s.kill();

    let s = Server::start(dir.path(), "journal").await;
    assert_eq!(
        s.cull().await,
        (placed.clone(), 2),
        "same placements, same version"
    );
    let (status, r) = s
        .post(
            "/v1/scenes/demo/transforms",
            json!({"objects": [{"id": moved}]}),
        )
        .await;
    assert_eq!((status, r["version"].as_u64()), (200, Some(3)), "{r}");
    assert_eq!(s.cull().await, (as_loaded.clone(), 3), "moved back home");
    s.kill();

    // In memory, a restart forgets: the file's placements at version 0.
    let s = Server::start(dir.path(), "memory").await;
    assert_eq!(s.cull().await, (as_loaded.clone(), 0));
    s.kill();
    // The journal was left alone by the memory run.
    let s = Server::start(dir.path(), "journal").await;
    assert_eq!(s.cull().await, (as_loaded, 3));
    s.kill();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_unreadable_journal_refuses_updates_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let s = Server::start(dir.path(), "journal").await;
    let (ids, _) = s.cull().await;
    move_one_away(&s, &ids).await;
    s.kill();
    std::fs::write(dir.path().join("state/demo/snapshot.json"), b"{not json").unwrap();

    let s = Server::start(dir.path(), "journal").await;
    let (status, r) = s
        .post(
            "/v1/scenes/demo/transforms",
            json!({"objects": [{"id": ids[0]}]}),
        )
        .await;
    assert_eq!(status, 503, "{r}");
    assert_eq!(r["error"]["code"], "state_unavailable", "{r}");
    let ready: Value = reqwest::get(format!("{}/readyz", s.base))
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    assert_eq!(ready["state"]["backend"], "journal", "{ready}");
    assert_eq!(
        ready["state"]["unavailable_scenes"],
        json!(["demo"]),
        "{ready}"
    );
    // Culls go on.
    s.cull().await;
    s.kill();
}
