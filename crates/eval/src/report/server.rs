//! Section 6: an in-process server on 127.0.0.1:0 driven by the load generator.

use std::fmt::Write as _;
use std::time::Duration;

use anyhow::{Result, bail};

use super::context::{Report, progress};
use super::plot::{Chart, Series};
use super::targets::Target;
use crate::loadgen::{LoadConfig, LoadReport};
use homcull_server::Config;

/// Polls `/readyz` until it answers 200 (the demo city is loaded).
async fn wait_ready(addr: std::net::SocketAddr) -> Result<()> {
    let client = reqwest::Client::builder().no_proxy().build()?;
    for _ in 0..1200 {
        if let Ok(r) = client.get(format!("http://{addr}/readyz")).send().await {
            if r.status() == 200 {
                return Ok(());
            }
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    bail!("the in-process server did not become ready in 120 s")
}

/// Starts a server (batching on or off), runs the loadgen for each `(mode, clients)`
/// job, stops it.
async fn runs(
    r: &Report,
    batching: bool,
    jobs: &[(&str, usize)],
    data_dir: &std::path::Path,
    done: usize,
    total: usize,
) -> Result<Vec<LoadReport>> {
    let cfg = Config {
        data_dir: data_dir.to_path_buf(),
        api_token: None,
        ws_max_fps: 10_000.0,
        rescan_s: 0,
        no_batching: !batching,
        // Every load client comes from loopback.
        max_connections_per_address: 0,
        ..Config::default()
    };
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let addr = listener.local_addr()?;
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let shutdown = async {
        let _ = stopped.await;
    };
    let mut task = tokio::spawn(homcull_server::serve(
        listener,
        cfg,
        r.backend.clone(),
        shutdown,
    ));
    tokio::select! {
        ended = &mut task => {
            let why = match ended {
                Ok(Err(e)) => e.to_string(),
                Ok(Ok(())) => "it stopped".into(),
                Err(e) => e.to_string(),
            };
            bail!("the server on {} did not start: {why}", data_dir.display());
        }
        ready = wait_ready(addr) => ready?,
    }
    let mut out = Vec::new();
    for (i, &(mode, clients)) in jobs.iter().enumerate() {
        progress(
            "server",
            done + i,
            total,
            &format!(
                "{mode}: {clients} clients, batching {}",
                if batching { "on" } else { "off" }
            ),
        );
        let a = LoadConfig {
            url: format!("http://{addr}"),
            scene: "demo".into(),
            clients,
            seconds: r.plan.load_seconds,
            mode: mode.into(),
            batch: 64,
            transforms_per_s: 0.0,
        };
        out.push(crate::loadgen::run(&a).await?);
    }
    let _ = stop.send(());
    let _ = tokio::time::timeout(Duration::from_secs(30), task).await;
    Ok(out)
}

/// Load generator jobs of one server run: WebSocket at every client count, and with
/// batching on also REST, one pose per request against batches of 64.
fn jobs(clients: &[usize], batching: bool) -> Vec<(&'static str, usize)> {
    let mut j: Vec<(&str, usize)> = clients.iter().map(|&c| ("ws", c)).collect();
    if batching {
        let rest = [1, *clients.iter().filter(|&&c| c <= 10).max().unwrap_or(&1)];
        for c in rest.into_iter().collect::<std::collections::BTreeSet<_>>() {
            j.extend([("single", c), ("batch", c)]);
        }
    }
    j
}

pub(super) fn section(r: &mut Report) -> Result<()> {
    let data_dir =
        std::env::temp_dir().join(format!("homcull-report-server-{}", std::process::id()));
    let rt = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()?;
    let plans = [true, false].map(|b| (b, jobs(&r.plan.clients, b)));
    let total = plans.iter().map(|(_, j)| j.len()).sum();
    let mut done = 0;
    let mut results = Vec::new();
    for (batching, jobs) in &plans {
        let dir = data_dir.join(if *batching { "on" } else { "off" });
        std::fs::create_dir_all(&dir)?;
        let res = rt.block_on(runs(r, *batching, jobs, &dir, done, total));
        let _ = std::fs::remove_dir_all(&dir);
        done += jobs.len();
        results.push((*batching, res?));
    }
    let _ = std::fs::remove_dir_all(&data_dir);
    let _ = writeln!(
        r.md,
        "\n## 6. Server\n\n\
         An in-process `homcull serve` on 127.0.0.1:0 (demo city, GPU batch 64, frame cap \
         10,000 fps) driven by `homcull loadgen` for {:.0} s per row, 960×540 poses along \
         a street walk. `ws`: each WebSocket client keeps one pose in flight (closed loop); \
         `single`: one pose per `POST /cull`; `batch`: 64 poses per `POST /cull/batch` \
         (poses/s counts poses, the round trip is per request). \"batching off\" runs \
         every pose in its own GPU submission (`--no-batching`). Times in ms; /healthz is \
         probed while the load runs.\n\n\
         | batching | mode | clients | poses/s | rtt p50 | rtt p95 | rtt p99 | /healthz p99 | errors | fewest poses per client |\n\
         |---|---|---:|---:|---:|---:|---:|---:|---:|---:|",
        r.plan.load_seconds
    );
    let mut series = Vec::new();
    for (batching, reps) in &results {
        let on = if *batching { "on" } else { "off" };
        for l in reps {
            let _ = writeln!(
                r.md,
                "| {on} | {} | {} | {:.0} | {:.2} | {:.2} | {:.2} | {:.2} | {} | {} |",
                l.mode,
                l.clients,
                l.poses_per_s,
                l.rtt_ms.p50,
                l.rtt_ms.p95,
                l.rtt_ms.p99,
                l.healthz_ms.p99,
                l.errors,
                l.min_client_poses
            );
        }
        series.push(Series {
            label: format!("WebSocket, batching {on}"),
            points: reps
                .iter()
                .filter(|l| l.mode == "ws")
                .map(|l| (l.clients as f64, l.poses_per_s))
                .collect(),
        });
    }
    let ws = |b: bool, c: usize| {
        results
            .iter()
            .find(|(on, _)| *on == b)
            .and_then(|(_, reps)| reps.iter().find(|l| l.mode == "ws" && l.clients == c))
            .map(|l| l.poses_per_s)
    };
    let rest = |mode: &str| {
        results[0]
            .1
            .iter()
            .find(|l| l.mode == mode && l.clients == 1)
            .map(|l| l.poses_per_s)
    };
    let ratio = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) if b > 0.0 => format!("{:.2}×", a / b),
        _ => "–".into(),
    };
    server_targets(r, &results);
    let most = *r.plan.clients.iter().max().unwrap_or(&1);
    let _ = writeln!(
        r.md,
        "\nBatching on ÷ off, WebSocket poses/s at {most} clients: {}. REST, one client: \
         batches of 64 ÷ one pose per request: {}.",
        ratio(ws(true, most), ws(false, most)),
        ratio(rest("batch"), rest("single"))
    );
    r.plot(
        "server.png",
        &Chart {
            title: "server throughput vs WebSocket clients (demo city)",
            x_label: "clients",
            y_label: "poses per second",
            log_x: true,
            log_y: false,
        },
        &series,
    )
}

/// The server's targets from the load runs (`results`: batching on, then off).
fn server_targets(r: &mut Report, results: &[(bool, Vec<LoadReport>)]) {
    let ws = |on: bool, clients: usize| {
        results
            .iter()
            .find(|(b, _)| *b == on)
            .and_then(|(_, reps)| reps.iter().find(|l| l.mode == "ws" && l.clients == clients))
    };
    if let (Some(on), Some(off)) = (ws(true, 32), ws(false, 32))
        && off.poses_per_s > 0.0
    {
        r.targets.push(Target::bound(
            4,
            "WebSocket poses/s under 32 clients, batching on ÷ off",
            on.poses_per_s / off.poses_per_s,
            5.0,
            true,
            "×",
        ));
    }
    if let Some(p50) = ws(true, 1)
        .and_then(|l| l.rtt_minus_server_ms)
        .map(|p| p.p50)
    {
        r.targets.push(Target::bound(
            4,
            "WebSocket round trip − in-process cull time, p50, 1 client",
            p50,
            0.5,
            false,
            " ms",
        ));
    }
    if let Some(l) = ws(true, 500) {
        r.targets.push(Target::bound(
            4,
            "/healthz p99 under 500 WebSocket clients",
            l.healthz_ms.p99,
            50.0,
            false,
            " ms",
        ));
        r.targets.push(Target {
            issue: 4,
            what: "every one of 500 WebSocket clients keeps getting answers".into(),
            measured: format!("fewest answers to one client: {}", l.min_client_poses),
            met: l.min_client_poses > 0 && l.errors == 0,
        });
    }
}
