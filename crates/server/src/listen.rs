//! The accept loop: hyper's HTTP/1 server under the axum app, with what `axum::serve`
//! leaves out and a server facing the open internet needs.
//!
//! - **Header-read timeout**: a connection must send a request's headers within
//!   `header_timeout_s` of opening or of its previous answer. That closes slow-header
//!   connections (a few bytes a minute) and idle keep-alive connections alike.
//! - **Per-address cap**: one address holds at most `max_connections_per_address` open
//!   connections ([`AddressBook`]); a connection over it gets a 429 and is closed,
//!   before any of its bytes are read. A connection upgraded to a WebSocket stream
//!   hands its slot to the stream ([`ConnectionSlot`]), so a stream counts as the
//!   connection it was, for as long as it lives.
//! - **Drain**: on shutdown the loop stops accepting, asks every connection to close
//!   once its request in flight is answered, and waits for them.

use std::collections::HashMap;
use std::future::Future;
use std::net::IpAddr;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use axum::Router;
use hyper::body::Incoming;
use hyper_util::rt::{TokioIo, TokioTimer};
use tokio::io::AsyncWriteExt;
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::watch;
use tower::ServiceExt;

/// A connection's slot, in its requests' extensions: the stream route takes it over.
#[derive(Clone, Debug)]
pub struct ConnectionSlot(Arc<Mutex<Option<AddressSlot>>>);

impl ConnectionSlot {
    /// The slot, moved out of the connection (`None` if already taken).
    pub fn take(&self) -> Option<AddressSlot> {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).take()
    }
}

/// Open connections and streams per peer address, against a cap (0: no cap).
#[derive(Debug)]
pub struct AddressBook {
    cap: usize,
    open: Mutex<HashMap<IpAddr, usize>>,
}

/// One connection or stream counted against its address; frees itself when dropped.
#[derive(Debug)]
pub struct AddressSlot {
    book: Arc<AddressBook>,
    ip: IpAddr,
}

impl AddressBook {
    pub fn new(cap: usize) -> Arc<Self> {
        Arc::new(AddressBook {
            cap,
            open: Mutex::default(),
        })
    }

    /// A slot for `ip`, unless it holds its cap already.
    pub fn try_take(self: &Arc<Self>, ip: IpAddr) -> Option<AddressSlot> {
        let mut open = self.open.lock().unwrap_or_else(|p| p.into_inner());
        let n = open.entry(ip).or_insert(0);
        if self.cap > 0 && *n >= self.cap {
            return None;
        }
        *n += 1;
        Some(AddressSlot {
            book: self.clone(),
            ip,
        })
    }

    /// Slots held, over every address.
    #[cfg(test)]
    fn total(&self) -> usize {
        self.open
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .values()
            .sum()
    }
}

impl Drop for AddressSlot {
    fn drop(&mut self) {
        let mut open = self.book.open.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(n) = open.get_mut(&self.ip) {
            *n -= 1;
            if *n == 0 {
                open.remove(&self.ip);
            }
        }
    }
}

/// What a connection over its address's cap gets before it is closed.
fn too_many() -> Vec<u8> {
    let body = r#"{"error":{"code":"too_many_connections","message":"too many connections from one address"}}"#;
    format!(
        "HTTP/1.1 429 Too Many Requests\r\ncontent-type: application/json\r\n\
         connection: close\r\ncontent-length: {}\r\n\r\n{body}",
        body.len()
    )
    .into_bytes()
}

/// Serves `app` on `listener` until `shutdown` resolves, then drains the connections
/// (see the module docs). Returns when every connection has closed; the caller bounds
/// the wait.
pub async fn serve(
    listener: TcpListener,
    app: Router,
    book: Arc<AddressBook>,
    header_timeout: Duration,
    shutdown: impl Future<Output = ()>,
) {
    let mut http = hyper::server::conn::http1::Builder::new();
    http.timer(TokioTimer::new())
        .header_read_timeout(header_timeout);
    let (stop_tx, stop) = watch::channel(false);
    tokio::pin!(shutdown);
    loop {
        let (tcp, peer) = tokio::select! {
            accepted = listener.accept() => match accepted {
                Ok(a) => a,
                Err(e) => {
                    // Out of file descriptors and the like: wait, do not spin.
                    tracing::warn!("accepting a connection: {e}");
                    tokio::time::sleep(Duration::from_millis(50)).await;
                    continue;
                }
            },
            _ = &mut shutdown => break,
        };
        let Some(slot) = book.try_take(peer.ip()) else {
            metrics::counter!("homcull_connections_refused_total").increment(1);
            tokio::spawn(refuse(tcp));
            continue;
        };
        // Small frames must leave at once: no Nagle delay on any connection.
        let _ = tcp.set_nodelay(true);
        let app = app.clone();
        let slot = ConnectionSlot(Arc::new(Mutex::new(Some(slot))));
        let held = slot.clone(); // dropped with the connection, unless a stream took it
        let service = hyper::service::service_fn(move |mut req: hyper::Request<Incoming>| {
            req.extensions_mut().insert(slot.clone());
            app.clone().oneshot(req)
        });
        let conn = http
            .serve_connection(TokioIo::new(tcp), service)
            .with_upgrades();
        let mut stop = stop.clone();
        tokio::spawn(async move {
            let _held = held;
            tokio::pin!(conn);
            let done = tokio::select! {
                r = conn.as_mut() => Some(r),
                _ = stop.wait_for(|s| *s) => None,
            };
            let result = match done {
                Some(r) => r,
                None => {
                    conn.as_mut().graceful_shutdown();
                    conn.await
                }
            };
            if let Err(e) = result {
                tracing::debug!(%peer, "connection ended: {e}");
            }
        });
    }
    drop(listener);
    let _ = stop_tx.send(true);
    while connections_open(&stop_tx) {
        tokio::time::sleep(Duration::from_millis(5)).await;
    }
}

/// Whether a connection task is still running (each holds a receiver).
fn connections_open(stop: &watch::Sender<bool>) -> bool {
    stop.receiver_count() > 1
}

/// Answers 429 to a connection over its address's cap, without reading from it.
async fn refuse(mut tcp: TcpStream) {
    let _ = tokio::time::timeout(Duration::from_secs(1), async {
        let _ = tcp.write_all(&too_many()).await;
        let _ = tcp.shutdown().await;
    })
    .await;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_refusal_is_a_whole_http_response() {
        let bytes = too_many();
        let text = std::str::from_utf8(&bytes).unwrap();
        let (head, body) = text.split_once("\r\n\r\n").unwrap();
        let len: usize = head
            .lines()
            .find_map(|l| l.strip_prefix("content-length: "))
            .unwrap()
            .parse()
            .unwrap();
        assert_eq!(len, body.len());
        let _: serde_json::Value = serde_json::from_str(body).unwrap();
    }

    #[test]
    fn an_address_holds_at_most_its_cap_and_slots_free_themselves() {
        let book = AddressBook::new(2);
        let a: IpAddr = "127.0.0.1".parse().unwrap();
        let b: IpAddr = "127.0.0.2".parse().unwrap();
        let one = book.try_take(a).unwrap();
        let _two = book.try_take(a).unwrap();
        assert!(book.try_take(a).is_none());
        let _other = book.try_take(b).expect("another address has its own count");
        drop(one);
        assert!(book.try_take(a).is_some());
        assert_eq!(book.total(), 2);
        let free = AddressBook::new(0);
        let held: Vec<_> = (0..1000).map(|_| free.try_take(a).unwrap()).collect();
        assert_eq!(free.total(), held.len());
    }
}
