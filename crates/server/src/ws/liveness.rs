//! Whether a WebSocket client still reads: the sender pings it, the reader notes the
//! pongs, and a ping left unanswered for the send timeout ends the stream. Without it
//! a client that stops reading is noticed only once the kernel's buffers are full,
//! which for small frames can take minutes of culls nobody reads.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Whether a client still reads: when the last ping went out and the last pong came
/// back, in microseconds since the stream opened.
pub(super) struct Liveness {
    opened: Instant,
    /// 0: no ping outstanding.
    ping_sent_us: AtomicU64,
    pong_us: AtomicU64,
    /// The last ping's round trip, microseconds (0: none answered yet).
    rtt_us: AtomicU64,
}

/// What a ping tick does.
#[derive(Debug, PartialEq)]
pub(super) enum Tick {
    /// Send a ping.
    Ping,
    /// A ping is out and not yet overdue.
    Wait,
    /// A ping has gone unanswered for the send timeout.
    Unanswered,
}

impl Liveness {
    pub(super) fn new() -> Self {
        Liveness {
            opened: Instant::now(),
            ping_sent_us: AtomicU64::new(0),
            pong_us: AtomicU64::new(0),
            rtt_us: AtomicU64::new(0),
        }
    }

    fn now_us(&self) -> u64 {
        self.opened.elapsed().as_micros() as u64 + 1 // never 0
    }

    pub(super) fn ponged(&self) {
        let now = self.now_us();
        let sent = self.ping_sent_us.load(Ordering::SeqCst);
        if sent != 0 && self.pong_us.load(Ordering::SeqCst) <= sent {
            self.rtt_us.store(now - sent, Ordering::SeqCst);
        }
        self.pong_us.store(now, Ordering::SeqCst);
    }

    /// The round trip of the last ping answered (zero before the first).
    pub(super) fn rtt(&self) -> Duration {
        Duration::from_micros(self.rtt_us.load(Ordering::SeqCst))
    }

    pub(super) fn on_tick(&self, timeout: Duration) -> Tick {
        let sent = self.ping_sent_us.load(Ordering::SeqCst);
        let answered = self.pong_us.load(Ordering::SeqCst) > sent;
        let now = self.now_us();
        if sent != 0 && !answered {
            return if now - sent >= timeout.as_micros() as u64 {
                Tick::Unanswered
            } else {
                Tick::Wait
            };
        }
        self.ping_sent_us.store(now, Ordering::SeqCst);
        Tick::Ping
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ping_unanswered_for_the_timeout_ends_the_stream_and_a_pong_clears_it() {
        let live = Liveness::new();
        let timeout = Duration::from_millis(40);
        assert_eq!(live.on_tick(timeout), Tick::Ping);
        assert_eq!(live.on_tick(timeout), Tick::Wait);
        assert_eq!(live.rtt(), Duration::ZERO, "no pong yet");
        std::thread::sleep(Duration::from_millis(5));
        live.ponged();
        assert!(live.rtt() >= Duration::from_millis(5), "{:?}", live.rtt());
        live.ponged();
        assert!(
            live.rtt() >= Duration::from_millis(5),
            "a second pong is no round trip"
        );
        assert_eq!(live.on_tick(timeout), Tick::Ping, "answered: ping again");
        std::thread::sleep(Duration::from_millis(50));
        assert_eq!(live.on_tick(timeout), Tick::Unanswered);
    }
}
