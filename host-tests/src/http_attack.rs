//! A hostile HTTP catalogue against the device's diagnostics service
//! (`cargo demo -- --http-attack`): every request a careless or hostile
//! client can make, each with the answer it must get (a 4xx, or a close)
//! within a bounded time, then the page served again. The demo runs it
//! while the robot simulator drives the device and requires every robot
//! message answered throughout.
//!
//! Through QEMU's user networking every connection is accepted on the
//! host's side by slirp first, so a connection the device refuses (every
//! slot busy) is seen here as a close or a reset, never as "refused"; and
//! slirp reads the device's responses into the host's socket buffers, so
//! a client that does not read cannot make the device wait (the
//! in-memory test `net_http` checks that bound against embassy-net
//! itself, and a client that half-closes after its request, which slirp
//! turns into a close of the whole connection).

use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::time::{Duration, Instant};

/// The longest any case may take: the service's request timeout (2 s)
/// and response timeout (5 s), with room for a loaded host.
pub const BOUND: Duration = Duration::from_secs(12);

/// What a failure says of a connection that got nothing at all within
/// [`BOUND`]: no byte and no close. Through QEMU's user networking that
/// is what a connection looks like when the frames slirp sends the device
/// (the SYN and its retries, or the request) are dropped by the emulated
/// NIC ("Slirp: Failed to send packet" on a stalled host); the demo counts
/// it as the host's only when robot messages were lost before the
/// firmware in the same run ([`only_silence`]).
pub const NOTHING_AT_ALL: &str = "got nothing at all";

/// What came back on one connection.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Answer {
    /// The status of the first response, if one came.
    pub status: Option<u16>,
    /// Responses in the stream (pipelining shows as more than one).
    pub responses: usize,
    /// The device closed (or reset) the connection.
    pub closed: bool,
    pub after: Duration,
}

impl Answer {
    /// No byte came and the connection stayed open.
    fn nothing(&self) -> bool {
        self.status.is_none() && self.responses == 0 && !self.closed
    }
}

/// The failure of a connection that got nothing at all.
fn silence(a: &Answer) -> String {
    format!(
        "a connection {NOTHING_AT_ALL} within {:?} (no byte, no close)",
        a.after
    )
}

/// Whether every one of the catalogue's `failures` is a connection that
/// got nothing at all ([`NOTHING_AT_ALL`]); any other failure (a wrong
/// status, a response where a close was due, a slow close) is not.
pub fn only_silence(failures: &[String]) -> bool {
    !failures.is_empty() && failures.iter().all(|f| f.contains(NOTHING_AT_ALL))
}

fn connect(to: SocketAddr) -> std::io::Result<TcpStream> {
    let s = TcpStream::connect_timeout(&to, Duration::from_secs(5))?;
    s.set_nodelay(true)?;
    Ok(s)
}

/// Reads until the device closes or `BOUND` passes.
fn answer(mut s: TcpStream, start: Instant) -> Answer {
    let mut got = Vec::new();
    let mut buf = [0u8; 4096];
    let mut closed = false;
    while start.elapsed() < BOUND {
        let _ = s.set_read_timeout(Some(Duration::from_millis(200)));
        match s.read(&mut buf) {
            Ok(0) => {
                closed = true;
                break;
            }
            Ok(n) => got.extend_from_slice(&buf[..n]),
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(_) => {
                closed = true;
                break;
            }
        }
    }
    let text = String::from_utf8_lossy(&got);
    let status = text
        .strip_prefix("HTTP/1.1 ")
        .and_then(|r| r.get(..3))
        .and_then(|c| c.parse().ok());
    Answer {
        status,
        responses: text.matches("HTTP/1.1 ").count(),
        closed,
        after: start.elapsed(),
    }
}

/// Sends `request` on one connection and reads the answer.
fn ask_once(to: SocketAddr, request: &[u8]) -> Result<Answer, String> {
    let start = Instant::now();
    let mut s = connect(to).map_err(|e| format!("connect: {e}"))?;
    s.write_all(request).map_err(|e| format!("send: {e}"))?;
    Ok(answer(s, start))
}

/// A connection turned away at once: closed within this, nothing read.
/// With both of the service's slots busy smoltcp refuses a connection
/// (QEMU's user-mode network then closes the client's end), and the
/// catalogue runs beside the browser's page loads and the simulator's
/// `--device-status` reads, which take slots too.
const TURNED_AWAY: Duration = Duration::from_millis(100);

/// [`ask_once`], again while the connection is turned away because both
/// slots are busy (up to 5 s): a case's answer is what the service says
/// to the request, not that its slots were taken by another client.
fn ask(to: SocketAddr, request: &[u8]) -> Result<Answer, String> {
    let start = Instant::now();
    loop {
        let a = ask_once(to, request)?;
        let refused = a.closed && a.responses == 0 && a.after < TURNED_AWAY;
        if !refused || start.elapsed() > Duration::from_secs(5) {
            return Ok(a);
        }
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// One case: its name, and the check of what came back.
pub struct Case {
    pub name: &'static str,
    run: fn(SocketAddr) -> Result<String, String>,
}

fn expect(a: &Answer, status: u16) -> Result<String, String> {
    match (a.status, a.closed) {
        (Some(s), true) if s == status => Ok(format!("{s}, closed after {:?}", a.after)),
        _ if a.nothing() => Err(silence(a)),
        _ => Err(format!(
            "expected {status} and a close within {BOUND:?}; got {:?}, closed {}, after {:?}",
            a.status, a.closed, a.after
        )),
    }
}

fn status_for(to: SocketAddr, request: &[u8], status: u16) -> Result<String, String> {
    expect(&ask(to, request)?, status)
}

/// Every case of the catalogue.
pub fn catalogue() -> Vec<Case> {
    vec![
        Case {
            name: "request line of 300 bytes",
            run: |to| {
                let path = "a".repeat(300);
                status_for(to, format!("GET /{path} HTTP/1.1\r\n\r\n").as_bytes(), 414)
            },
        },
        Case {
            name: "headers of 3,000 bytes",
            run: |to| {
                let header = format!("X-Big: {}\r\n", "b".repeat(3000));
                status_for(
                    to,
                    format!("GET / HTTP/1.1\r\n{header}\r\n").as_bytes(),
                    431,
                )
            },
        },
        Case {
            name: "unknown method BREW",
            run: |to| status_for(to, b"BREW / HTTP/1.1\r\n\r\n", 501),
        },
        Case {
            name: "DELETE",
            run: |to| status_for(to, b"DELETE /metrics HTTP/1.1\r\n\r\n", 405),
        },
        Case {
            name: "POST with a body",
            run: |to| {
                status_for(
                    to,
                    b"POST /status.json HTTP/1.1\r\nContent-Length: 11\r\n\r\nhello world",
                    405,
                )
            },
        },
        Case {
            name: "path traversal",
            run: |to| {
                status_for(to, b"GET /../../etc/passwd HTTP/1.1\r\n\r\n", 404)?;
                status_for(to, b"GET /%2e%2e/metrics HTTP/1.1\r\n\r\n", 404)
            },
        },
        Case {
            name: "non-UTF-8 in the request line",
            run: |to| status_for(to, b"GET /\xff\xfe HTTP/1.1\r\n\r\n", 400),
        },
        Case {
            name: "pipelined requests (one answered, then a close)",
            run: |to| {
                let a = ask(
                    to,
                    b"GET /metrics HTTP/1.1\r\n\r\nGET / HTTP/1.1\r\n\r\nGET /status.json HTTP/1.1\r\n\r\n",
                )?;
                if a.responses != 1 {
                    return Err(format!("{} responses, not one", a.responses));
                }
                expect(&a, 200)
            },
        },
        Case {
            name: "keep-alive asked for (answered, then a close)",
            run: |to| {
                status_for(
                    to,
                    b"GET /status.json HTTP/1.1\r\nConnection: keep-alive\r\n\r\n",
                    200,
                )
            },
        },
        Case {
            name: "half-open: connected, nothing sent",
            // Through `ask`: a connection turned away because the browser's
            // page load holds the slots is tried again, not taken for this.
            run: |to| expect(&ask(to, b"")?, 408),
        },
        Case {
            name: "half-open: request half sent, then nothing",
            run: |to| expect(&ask(to, b"GET /metr")?, 408),
        },
        Case {
            name: "three slow clients at once, a byte a second",
            run: |to| {
                // Two slots: each slow client gets 408 when its time is up,
                // or (the slots busy) is turned away at once.
                let slow: Vec<_> = (0..3)
                    .map(|_| {
                        std::thread::spawn(move || -> Result<Answer, String> {
                            let start = Instant::now();
                            let mut s = connect(to).map_err(|e| e.to_string())?;
                            for b in b"GET / HTTP/1.1\r\n\r\n" {
                                if s.write_all(&[*b]).is_err() {
                                    break;
                                }
                                std::thread::sleep(Duration::from_secs(1));
                                if start.elapsed() > Duration::from_secs(4) {
                                    break;
                                }
                            }
                            Ok(answer(s, start))
                        })
                    })
                    .collect();
                let (mut timed_out, mut turned_away) = (0, 0);
                for t in slow {
                    let a = t
                        .join()
                        .map_err(|_| "a slow client panicked".to_string())??;
                    match (a.status, a.closed) {
                        (Some(408), true) => timed_out += 1,
                        (None, true) => turned_away += 1,
                        _ => return Err(format!("a slow client got {a:?}")),
                    }
                }
                if timed_out == 0 {
                    return Err("no slow client got its 408".into());
                }
                Ok(format!(
                    "{timed_out} got 408, {turned_away} turned away at once"
                ))
            },
        },
        Case {
            name: "a client that never reads its response",
            run: |to| {
                let mut s = connect(to).map_err(|e| e.to_string())?;
                s.write_all(b"GET /status.json HTTP/1.1\r\n\r\n")
                    .map_err(|e| e.to_string())?;
                std::thread::sleep(Duration::from_secs(3));
                // Meanwhile the others are served.
                let a = ask(to, b"GET /metrics HTTP/1.1\r\n\r\n")?;
                drop(s);
                expect(&a, 200)
            },
        },
        Case {
            name: "ten times the slots at once (20 connections)",
            run: |to| {
                let all: Vec<_> = (0..20)
                    .map(|_| {
                        std::thread::spawn(move || {
                            ask_once(to, b"GET /status.json HTTP/1.1\r\n\r\n")
                        })
                    })
                    .collect();
                let mut served = 0;
                let mut turned_away = 0;
                for t in all {
                    let a = t.join().map_err(|_| "a client panicked".to_string())??;
                    match (a.status, a.closed) {
                        (Some(200), true) => served += 1,
                        (None, true) | (Some(503), true) => turned_away += 1,
                        _ if a.nothing() => return Err(silence(&a)),
                        _ => return Err(format!("a connection got {a:?}")),
                    }
                }
                if served == 0 {
                    return Err("none of 20 was served".into());
                }
                Ok(format!(
                    "{served} served, {turned_away} turned away at once"
                ))
            },
        },
    ]
}

/// Runs every case, then checks the page, the JSON and the metrics are
/// served again. Every line of the result says what happened; `Err` if
/// any case failed.
pub fn run(to: SocketAddr) -> Result<Vec<String>, Vec<String>> {
    let mut lines = Vec::new();
    let mut failed = false;
    for case in catalogue() {
        match (case.run)(to) {
            Ok(what) => lines.push(format!("ok   {}: {what}", case.name)),
            Err(why) => {
                failed = true;
                lines.push(format!("FAIL {}: {why}", case.name));
            }
        }
    }
    for path in ["/", "/status.json", "/metrics"] {
        let request = format!("GET {path} HTTP/1.1\r\nAccept-Encoding: gzip\r\n\r\n");
        match ask(to, request.as_bytes()).and_then(|a| expect(&a, 200)) {
            Ok(what) => lines.push(format!("ok   served again: {path}: {what}")),
            Err(why) => {
                failed = true;
                lines.push(format!("FAIL served again: {path}: {why}"));
            }
        }
    }
    if failed {
        Err(lines)
    } else {
        Ok(lines)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn silence_is_told_from_every_other_failure() {
        let nothing = Answer {
            after: BOUND,
            ..Answer::default()
        };
        let closed = Answer {
            closed: true,
            ..nothing.clone()
        };
        let wrong = Answer {
            status: Some(500),
            responses: 1,
            closed: true,
            ..nothing.clone()
        };
        assert!(nothing.nothing() && !closed.nothing() && !wrong.nothing());
        let silent = expect(&nothing, 200).unwrap_err();
        assert!(only_silence(&[silent.clone(), silent.clone()]));
        // A wrong status, or a close where a 408 was due, is never silence.
        let other = expect(&wrong, 200).unwrap_err();
        assert!(!only_silence(&[silent.clone(), other]));
        assert!(!only_silence(&[expect(&closed, 408).unwrap_err()]));
        assert!(!only_silence(&[]));
    }
}
