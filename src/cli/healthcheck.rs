//! `homcull healthcheck`: a GET of `/healthz` for container probes, so the image
//! needs no curl. Exit 0 when it answers 200 in time.

use std::time::Duration;

/// The default URL: the port of `HOMCULL_ADDR` (or 8080) on loopback.
pub fn default_url() -> String {
    let port = std::env::var("HOMCULL_ADDR")
        .ok()
        .and_then(|a| a.parse::<std::net::SocketAddr>().ok())
        .map_or(8080, |a| a.port());
    format!("http://127.0.0.1:{port}/healthz")
}

/// Returns Ok if `url` (`http://` only) answers 200 within `timeout`.
pub fn check(url: &str, timeout: Duration) -> Result<(), String> {
    if !url.starts_with("http://") {
        return Err(format!("only http:// URLs are supported, got `{url}`"));
    }
    let client = reqwest::blocking::Client::builder()
        .no_proxy()
        .timeout(timeout)
        .connect_timeout(timeout)
        .build()
        .map_err(|e| e.to_string())?;
    let res = client.get(url).send().map_err(|e| format!("{url}: {e}"))?;
    if res.status() == reqwest::StatusCode::OK {
        Ok(())
    } else {
        Err(format!("{url} answered `{}`", res.status()))
    }
}
