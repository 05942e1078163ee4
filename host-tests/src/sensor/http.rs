//! The host sensor's diagnostics: the firmware's own service
//! (`rri_diag`: request parser, page, JSON, metrics), the same
//! bytes a board serves, from a thread on std sockets
//! (`cargo sensor-host -- --http 127.0.0.1:8080`).
//!
//! The engine runs in the sensor's thread and publishes a snapshot after
//! every turn, exactly as the board's cycle does ([`HostDiag`]); this
//! thread only reads it. Each connection gets a thread of its own (at most
//! [`CONNECTIONS`] at once; more are answered 503), the request head
//! [`REQUEST_TIMEOUT`] to arrive (408), one request per connection.

use rri_diag::events::Events;
use rri_diag::http::{self, Parsed, Parser};
use rri_diag::status::{Latency, LatencySource, LinkInfo};
use rri_diag::{Identity, LastBad, Out, Status};
use rri_firmware::engine::Instant;
use rri_firmware::snapshot::{Published, Snapshot};
use std::io::{self, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// Connections served at once.
pub const CONNECTIONS: usize = 8;
/// The request head must arrive within this.
pub const REQUEST_TIMEOUT: Duration = Duration::from_secs(2);

/// What the sensor thread publishes for the service: the engine's
/// snapshot after every turn, the last bad message, the events.
#[derive(Default)]
pub struct HostDiag {
    pub published: Published,
    pub last_bad: LastBad,
    pub events: Events,
}

impl HostDiag {
    /// The sensor thread, after a turn: publish, and log what changed
    /// since `last` as events.
    pub fn turn(&self, last: &Snapshot, now: &Snapshot, at: Instant) {
        self.published.publish(now);
        self.events.between(at, last, now);
    }

    fn status(&self, now: Instant) -> Status {
        let snapshot = self.published.latest();
        Status {
            snapshot,
            now,
            link: LinkInfo {
                up: true,
                speed_mbps: None,
                full_duplex: None,
            },
            nic: None,
            stack: None,
            latency: Latency {
                source: LatencySource::Socket,
                histogram: snapshot.stats.latency,
            },
            bad: self.last_bad.get(),
            events: self.events.copy(),
            reset: None,
            update: None,
        }
    }
}

/// A response held whole (the host has a heap).
struct Bytes(Vec<u8>);

impl Out for Bytes {
    fn bytes(&mut self, b: &[u8]) {
        self.0.extend_from_slice(b);
    }
}

/// The response to the request in `head` (everything the client sent).
pub fn answer(head: &[u8], id: &Identity, status: &Status) -> Vec<u8> {
    let mut out = Bytes(Vec::new());
    match Parser::new().feed(head) {
        Parsed::Request(r) => rri_diag::respond(&mut out, r, id, status),
        Parsed::Refused(s) => http::error(&mut out, s),
        Parsed::More => http::error(&mut out, http::Status::RequestTimeout),
    }
    out.0
}

/// Serves `listener` until `stop`; `now` is the sensor's clock.
pub fn serve(
    listener: TcpListener,
    diag: Arc<HostDiag>,
    id: Identity,
    now: impl Fn() -> Instant + Send + Sync + 'static,
    stop: Arc<AtomicBool>,
) -> io::Result<()> {
    listener.set_nonblocking(true)?;
    let busy = Arc::new(AtomicUsize::new(0));
    let now = Arc::new(now);
    while !stop.load(Ordering::Relaxed) {
        let (stream, _) = match listener.accept() {
            Ok(c) => c,
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(10));
                continue;
            }
            Err(_) => continue,
        };
        let _ = stream.set_nonblocking(false);
        if busy.fetch_add(1, Ordering::AcqRel) >= CONNECTIONS {
            busy.fetch_sub(1, Ordering::AcqRel);
            let mut out = Bytes(Vec::new());
            http::error(&mut out, http::Status::Unavailable);
            let mut stream = stream;
            let _ = stream.write_all(&out.0);
            continue;
        }
        let (diag, busy, now) = (diag.clone(), busy.clone(), now.clone());
        std::thread::spawn(move || {
            let _ = connection(stream, &diag, &id, &*now);
            busy.fetch_sub(1, Ordering::AcqRel);
        });
    }
    Ok(())
}

/// One connection: the request head within [`REQUEST_TIMEOUT`], the
/// response, close.
fn connection(
    mut stream: TcpStream,
    diag: &HostDiag,
    id: &Identity,
    now: &dyn Fn() -> Instant,
) -> io::Result<()> {
    let deadline = std::time::Instant::now() + REQUEST_TIMEOUT;
    let mut parser = Parser::new();
    let mut head = Vec::new();
    let mut buf = [0u8; 512];
    let verdict = loop {
        let left = deadline.saturating_duration_since(std::time::Instant::now());
        if left.is_zero() {
            break Parsed::Refused(http::Status::RequestTimeout);
        }
        stream.set_read_timeout(Some(left))?;
        match stream.read(&mut buf) {
            Ok(0) => break parser.parsed(),
            Ok(n) => {
                head.extend_from_slice(&buf[..n]);
                match parser.feed(&buf[..n]) {
                    Parsed::More => {}
                    v => break v,
                }
            }
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::WouldBlock | io::ErrorKind::TimedOut
                ) =>
            {
                break Parsed::Refused(http::Status::RequestTimeout)
            }
            Err(e) => return Err(e),
        }
    };
    let status = diag.status(now());
    let mut out = Bytes(Vec::new());
    match verdict {
        Parsed::Request(r) => rri_diag::respond(&mut out, r, id, &status),
        Parsed::Refused(s) => http::error(&mut out, s),
        // The client closed before a whole request.
        Parsed::More => return Ok(()),
    }
    stream.set_write_timeout(Some(Duration::from_secs(5)))?;
    stream.write_all(&out.0)?;
    stream.shutdown(std::net::Shutdown::Write)?;
    // Let the client read and close first (its FIN), briefly.
    stream.set_read_timeout(Some(Duration::from_secs(1)))?;
    while matches!(stream.read(&mut buf), Ok(n) if n > 0) {}
    Ok(())
}
