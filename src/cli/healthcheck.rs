//! `homcull healthcheck`: a GET of `/healthz` for container probes, so the image
//! needs no curl and the binary no HTTP client crate: one HTTP/1.1 request over a
//! plain TCP socket. Exit 0 when it answers 200 in time.

use std::io::{Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

/// The default URL: the port of `HOMCULL_ADDR` (or 8080) on loopback.
pub fn default_url() -> String {
    let port = std::env::var("HOMCULL_ADDR")
        .ok()
        .and_then(|a| a.parse::<std::net::SocketAddr>().ok())
        .map_or(8080, |a| a.port());
    format!("http://127.0.0.1:{port}/healthz")
}

/// Returns Ok if `url` (`http://host[:port][/path]` only) answers 200 within `timeout`.
pub fn check(url: &str, timeout: Duration) -> Result<(), String> {
    let (host, port, path) = parse_http_url(url)?;
    let deadline = Instant::now() + timeout;
    let addr = (host.as_str(), port)
        .to_socket_addrs()
        .map_err(|e| format!("{url}: {e}"))?
        .next()
        .ok_or_else(|| format!("{url}: `{host}` resolves to no address"))?;
    let mut stream =
        TcpStream::connect_timeout(&addr, timeout).map_err(|e| format!("{url}: {e}"))?;
    let left = || {
        deadline
            .saturating_duration_since(Instant::now())
            .max(Duration::from_millis(1))
    };
    stream
        .set_write_timeout(Some(left()))
        .map_err(|e| e.to_string())?;
    let request =
        format!("GET {path} HTTP/1.1\r\nHost: {host}:{port}\r\nConnection: close\r\n\r\n");
    stream
        .write_all(request.as_bytes())
        .map_err(|e| format!("{url}: {e}"))?;
    // The status line is all that is needed; read until it is complete.
    let mut head = Vec::new();
    let mut buf = [0u8; 512];
    while !head.windows(2).any(|w| w == b"\r\n") {
        stream
            .set_read_timeout(Some(left()))
            .map_err(|e| e.to_string())?;
        let n = stream.read(&mut buf).map_err(|e| format!("{url}: {e}"))?;
        if n == 0 {
            return Err(format!("{url}: the connection closed before a status line"));
        }
        head.extend_from_slice(&buf[..n]);
        if head.len() > 8192 {
            return Err(format!("{url}: no status line in the first 8 KiB"));
        }
    }
    let line = String::from_utf8_lossy(&head);
    let line = line.lines().next().unwrap_or_default();
    match line.split_whitespace().nth(1) {
        Some("200") => Ok(()),
        Some(_) => Err(format!("{url} answered `{}`", line.trim())),
        None => Err(format!("{url}: not an HTTP status line: `{}`", line.trim())),
    }
}

/// Splits `http://host[:port][/path]` into its host, port (80 by default) and path
/// (`/` by default).
fn parse_http_url(url: &str) -> Result<(String, u16, String), String> {
    let rest = url
        .strip_prefix("http://")
        .ok_or_else(|| format!("only http:// URLs are supported, got `{url}`"))?;
    let (authority, path) = match rest.find('/') {
        Some(i) => (&rest[..i], &rest[i..]),
        None => (rest, "/"),
    };
    // `[v6]:port`, `[v6]`, `host:port` or `host`.
    let (host, port) = match authority.strip_prefix('[') {
        Some(v6) => {
            let (h, after) = v6
                .split_once(']')
                .ok_or_else(|| format!("`{url}`: `[` without `]`"))?;
            (h, after.strip_prefix(':'))
        }
        None => match authority.rsplit_once(':') {
            Some((h, p)) => (h, Some(p)),
            None => (authority, None),
        },
    };
    let port = match port {
        Some(p) => p
            .parse::<u16>()
            .map_err(|e| format!("`{url}`: port `{p}`: {e}"))?,
        None => 80,
    };
    if host.is_empty() {
        return Err(format!("`{url}` names no host"));
    }
    Ok((host.to_string(), port, path.to_string()))
}

#[cfg(test)]
mod tests {
    use super::parse_http_url;

    #[test]
    fn urls_split_into_host_port_and_path() {
        let p = |u: &str| parse_http_url(u).unwrap();
        assert_eq!(
            p("http://127.0.0.1:8080/healthz"),
            ("127.0.0.1".into(), 8080, "/healthz".into())
        );
        assert_eq!(p("http://localhost"), ("localhost".into(), 80, "/".into()));
        assert_eq!(p("http://[::1]:9/x?y"), ("::1".into(), 9, "/x?y".into()));
        assert_eq!(p("http://[::1]"), ("::1".into(), 80, "/".into()));
        assert!(parse_http_url("https://a/").is_err());
        assert!(parse_http_url("http://:80/").is_err());
        assert!(parse_http_url("http://a:x/").is_err());
    }
}
