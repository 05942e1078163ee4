//! A plain HTTP/1.1 GET over std's TCP, for the device's diagnostics
//! (`--device-status`, the host tools), and the `PUT` of an update file
//! (`cargo update-device`): the device answers with `Content-Length` and
//! closes; no TLS, the device serves none.

use std::io::{Read, Write};
use std::net::{TcpStream, ToSocketAddrs};
use std::time::{Duration, Instant};

/// The most of a response read.
const MAX_RESPONSE: usize = 1 << 20;

/// A response: status code, headers (names lower case), body.
#[derive(Clone, Debug)]
pub struct Response {
    pub status: u16,
    pub headers: Vec<(String, String)>,
    pub body: Vec<u8>,
}

impl Response {
    /// The first header named `name` (any case).
    pub fn header(&self, name: &str) -> Option<&str> {
        let name = name.to_ascii_lowercase();
        self.headers
            .iter()
            .find(|(k, _)| *k == name)
            .map(|(_, v)| v.as_str())
    }
}

/// `http://host[:port][/path]` as (host, port, path).
fn split_url(url: &str) -> Result<(String, u16, String), String> {
    let rest = url
        .strip_prefix("http://")
        .ok_or_else(|| format!("{url}: only http:// URLs (the device serves no TLS)"))?;
    let (authority, path) = match rest.find('/') {
        Some(i) => (&rest[..i], rest[i..].to_string()),
        None => (rest, "/".to_string()),
    };
    let (host, port) = match authority.rsplit_once(':') {
        Some((h, p)) => (
            h.to_string(),
            p.parse().map_err(|_| format!("{url}: bad port {p}"))?,
        ),
        None => (authority.to_string(), 80),
    };
    if host.is_empty() {
        return Err(format!("{url}: no host"));
    }
    Ok((host, port, path))
}

/// GETs `url` within `timeout`; the body must be as long as the
/// response's `Content-Length` says.
pub fn get(url: &str, timeout: Duration) -> Result<Response, String> {
    let (mut s, host, port, path) = connect(url, timeout)?;
    let end = Instant::now() + timeout;
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: {host}:{port}\r\nConnection: close\r\nUser-Agent: rri-robot\r\n\r\n"
    )
    .map_err(|e| format!("{url}: {e}"))?;
    let (raw, error) = read_until_close(&mut s, end, url, timeout)?;
    if let Some(e) = error {
        return Err(format!("{url}: {e}"));
    }
    parse(&raw).map_err(|e| format!("{url}: {e}"))
}

/// Connects to `url`'s host within `timeout` (writes bounded by it too):
/// the stream, the host, the port and the path.
fn connect(url: &str, timeout: Duration) -> Result<(TcpStream, String, u16, String), String> {
    let (host, port, path) = split_url(url)?;
    let addr = (host.as_str(), port)
        .to_socket_addrs()
        .map_err(|e| format!("{url}: {e}"))?
        .next()
        .ok_or_else(|| format!("{url}: no address"))?;
    let s = TcpStream::connect_timeout(&addr, timeout).map_err(|e| format!("{url}: {e}"))?;
    s.set_write_timeout(Some(timeout))
        .map_err(|e| e.to_string())?;
    Ok((s, host, port, path))
}

/// Reads until the server closes, by `end`: the bytes, and the error that
/// ended the reading instead of a close, if one did. `Err` when the
/// response is not whole by `end` or longer than [`MAX_RESPONSE`].
fn read_until_close(
    s: &mut TcpStream,
    end: Instant,
    url: &str,
    timeout: Duration,
) -> Result<(Vec<u8>, Option<std::io::Error>), String> {
    let mut raw = Vec::new();
    let mut buf = [0u8; 4096];
    loop {
        let left = end.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(format!("{url}: no whole response within {timeout:?}"));
        }
        s.set_read_timeout(Some(left)).map_err(|e| e.to_string())?;
        match s.read(&mut buf) {
            Ok(0) => return Ok((raw, None)),
            Ok(n) => raw.extend_from_slice(&buf[..n]),
            Err(e) => return Ok((raw, Some(e))),
        }
        if raw.len() > MAX_RESPONSE {
            return Err(format!("{url}: response longer than {MAX_RESPONSE} bytes"));
        }
    }
}

/// What a `PUT` (or a `DELETE`, with no body) sends: `body` under the
/// path (with its query), declared as `declared` bytes long (a test may
/// send fewer: the connection is then half-closed after them, as a client
/// cut off).
pub struct Put<'a> {
    /// `PUT` or `DELETE`.
    pub method: &'a str,
    pub path: &'a str,
    pub body: &'a [u8],
    pub declared: usize,
}

/// PUTs `put` to the device at `url` (`http://host[:port]/`), calling
/// `progress` with the bytes sent so far; the whole exchange within
/// `timeout`. A device that refuses early closes while the body is still
/// on its way: the write error is not the answer, its response is, so the
/// response is read whatever the writes met. `Ok(None)`: the connection
/// ended without a byte of response (a device with every connection slot
/// busy refuses the connection; behind QEMU's user networking that shows
/// as a close, not a refused connect).
pub fn put(
    url: &str,
    put: &Put<'_>,
    timeout: Duration,
    progress: &mut dyn FnMut(usize),
) -> Result<Option<Response>, String> {
    let (mut s, host, port, _) = connect(url, timeout)?;
    let end = Instant::now() + timeout;
    let head = format!(
        "{} {} HTTP/1.1\r\nHost: {host}:{port}\r\nContent-Type: application/octet-stream\r\nContent-Length: {}\r\nConnection: close\r\nUser-Agent: rri-update-device\r\n\r\n",
        put.method, put.path, put.declared
    );
    let mut write_error = s.write_all(head.as_bytes()).err();
    let mut sent = 0;
    for chunk in put.body.chunks(4096) {
        if write_error.is_some() || Instant::now() > end {
            break;
        }
        match s.write_all(chunk) {
            Ok(()) => {
                sent += chunk.len();
                progress(sent);
            }
            Err(e) => write_error = Some(e),
        }
    }
    if put.body.len() < put.declared {
        let _ = s.shutdown(std::net::Shutdown::Write);
    }
    let (raw, error) = read_until_close(&mut s, end, url, timeout)?;
    // A reset after the response (the device closed while our bytes were
    // still coming) ends it like a close, and so does one before any.
    if let Some(e) = error {
        if raw.is_empty() && e.kind() != std::io::ErrorKind::ConnectionReset {
            let during = match write_error {
                Some(w) => format!(" (after {sent} bytes the writes met: {w})"),
                None => String::new(),
            };
            return Err(format!("{url}: {e}{during}"));
        }
    }
    if raw.is_empty() {
        return Ok(None);
    }
    parse(&raw).map(Some).map_err(|e| format!("{url}: {e}"))
}

/// A whole HTTP/1.x response.
pub fn parse(raw: &[u8]) -> Result<Response, String> {
    let split = raw
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .ok_or("no end of the response head")?;
    let head = std::str::from_utf8(&raw[..split]).map_err(|_| "the head is not UTF-8")?;
    let mut lines = head.split("\r\n");
    let status_line = lines.next().unwrap_or("");
    let status = status_line
        .strip_prefix("HTTP/1.")
        .and_then(|r| r.get(2..5))
        .and_then(|c| c.parse().ok())
        .ok_or_else(|| format!("bad status line {status_line:?}"))?;
    let headers: Vec<(String, String)> = lines
        .filter_map(|l| l.split_once(':'))
        .map(|(k, v)| (k.trim().to_ascii_lowercase(), v.trim().to_string()))
        .collect();
    let body = raw[split + 4..].to_vec();
    let r = Response {
        status,
        headers,
        body,
    };
    if let Some(len) = r.header("content-length") {
        let len: usize = len.parse().map_err(|_| "bad Content-Length")?;
        if len != r.body.len() {
            return Err(format!(
                "Content-Length {len}, but {} bytes came",
                r.body.len()
            ));
        }
    }
    Ok(r)
}

/// `URL` as given, or the device's address: `/status.json` on it unless
/// the URL names a path.
pub fn status_url(url: &str) -> String {
    let trimmed = url.trim_end_matches('/');
    if trimmed.ends_with(".json") {
        trimmed.to_string()
    } else {
        format!("{trimmed}/status.json")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn urls_name_host_port_and_path() {
        assert_eq!(
            split_url("http://127.0.0.1:8080/status.json").unwrap(),
            ("127.0.0.1".into(), 8080, "/status.json".into())
        );
        assert_eq!(
            split_url("http://10.49.65.74").unwrap(),
            ("10.49.65.74".into(), 80, "/".into())
        );
        assert!(split_url("https://x/").is_err());
        assert_eq!(status_url("http://h:1/"), "http://h:1/status.json");
        assert_eq!(
            status_url("http://h:1/status.json"),
            "http://h:1/status.json"
        );
    }

    #[test]
    fn a_response_must_be_as_long_as_it_says() {
        let ok = parse(b"HTTP/1.1 200 OK\r\nContent-Length: 2\r\n\r\nhi").unwrap();
        assert_eq!((ok.status, ok.body.as_slice()), (200, &b"hi"[..]));
        assert!(parse(b"HTTP/1.1 200 OK\r\nContent-Length: 3\r\n\r\nhi").is_err());
        assert!(parse(b"junk").is_err());
    }
}
