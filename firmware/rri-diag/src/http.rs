//! The smallest HTTP/1.1 server side the diagnostics need: a request
//! parser with fixed limits ([`Parser`]) and the response head
//! ([`head`]). `GET` and `HEAD` of three paths; with updates built in
//! ([`Parser::with_updates`]) also `PUT /firmware` with a
//! `Content-Length` (the body is the service's, [`Parser::body_start`]
//! says where it begins), the one request that changes anything, and
//! only what a signature allows (`rri_update`). Every other request is an
//! error status, one request per connection (`Connection: close`), so no
//! client can hold more than one request's worth of state.
//!
//! Limits (each answered with its status, then the connection closes):
//! a request line longer than [`LINE_MAX`] bytes (414), a header section
//! longer than [`HEADERS_MAX`] bytes (431), a method other than `GET` and
//! `HEAD` (405 for the methods RFC 9110 defines, 501 for any other token),
//! a path other than `/`, `/status.json`, `/metrics` (404; nothing is
//! ever looked up, so `/../` is just another unknown path), a version
//! other than HTTP/1.0 or 1.1 (505), and anything malformed, control
//! bytes and bytes from 0x80 in the request line included (400). How long
//! a client may take is the service's rule (408), not the parser's.
//!
//! The parser takes bytes as they come (any split) and keeps only the
//! request line: its work is one step per byte, bounded by the limits.

mod response;
pub use response::{error, head, Status};

/// Longest request line accepted (method, target, version, CRLF).
pub const LINE_MAX: usize = 256;
/// Longest header section accepted after the request line.
pub const HEADERS_MAX: usize = 2048;
/// Empty lines tolerated before the request line (RFC 9112 §2.2).
const LEADING_EMPTY_LINES: u8 = 4;

/// What the client asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Route {
    /// `GET /`: the status page (HTML).
    Page,
    /// `GET /status.json`.
    Json,
    /// `GET /metrics`: Prometheus text exposition.
    Metrics,
    /// `PUT /firmware`: an update file (with updates built in).
    Firmware,
}

impl Route {
    /// The path it is served at.
    pub const fn path(self) -> &'static str {
        match self {
            Route::Page => "/",
            Route::Json => "/status.json",
            Route::Metrics => "/metrics",
            Route::Firmware => "/firmware",
        }
    }

    /// Its `Content-Type`.
    pub const fn content_type(self) -> &'static str {
        match self {
            Route::Page => "text/html; charset=utf-8",
            Route::Json => "application/json",
            Route::Metrics => "text/plain; version=0.0.4; charset=utf-8",
            Route::Firmware => "text/plain; charset=utf-8",
        }
    }
}

/// A request the service answers with content.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Request {
    /// What to send.
    pub route: Route,
    /// `HEAD`: the head alone.
    pub head_only: bool,
    /// The client takes gzip (`Accept-Encoding` names it): the page is
    /// kept compressed ([`super::page`]). `gzip;q=0` is taken as yes.
    pub gzip: bool,
    /// `PUT /firmware`: the body that follows the head.
    pub body: Option<Body>,
    /// `DELETE /firmware`: cancel a marked update before its swap.
    pub cancel: bool,
}

/// The body of a `PUT /firmware`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Body {
    /// Its `Content-Length`.
    pub length: u32,
    /// `?force=1`: an older version is taken too.
    pub force: bool,
}

/// What the bytes so far amount to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Parsed {
    /// Not a whole request yet.
    More,
    /// A request to answer with content.
    Request(Request),
    /// A request to answer with this error status.
    Refused(Status),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    /// Reading the request line (after any leading empty lines).
    Line {
        empty: u8,
    },
    /// Reading header lines; `at_line_start`: the last byte ended a line.
    Headers {
        at_line_start: bool,
        request: Request,
    },
    Done(Parsed),
}

/// An HTTP/1.x request parser with fixed limits: [`Parser::feed`] the
/// bytes as they arrive until it says something other than
/// [`Parsed::More`].
pub struct Parser {
    stage: Stage,
    line: heapless::Vec<u8, LINE_MAX>,
    header_bytes: usize,
    /// `PUT /firmware` is a request (else 405, as any other `PUT`).
    updates: bool,
    /// The header line's name so far, lower-cased (a longer name is none
    /// of ours: [`Field::Other`]).
    name: heapless::Vec<u8, NAME_MAX>,
    field: Field,
    /// Bytes of `gzip` matched in an `Accept-Encoding` value.
    gzip_at: u8,
    /// `Content-Length`: whether one was sent, its value so far (`None`
    /// before its first digit), and whether it was malformed (a second
    /// one, a non-digit, more than `u32`, no digit).
    length_sent: bool,
    length: Option<u64>,
    length_bad: bool,
    /// A `Transfer-Encoding` was sent (a body in chunks: not taken).
    transfer: bool,
    /// Where in the last [`Parser::feed`]'s bytes the verdict came.
    body_start: usize,
}

/// Which header line the parser is in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Field {
    /// Reading its name.
    Name,
    AcceptEncoding,
    ContentLength,
    TransferEncoding,
    /// A header this parser does not read.
    Other,
}

/// The longest header name the parser reads (`transfer-encoding`).
const NAME_MAX: usize = 17;
const GZIP: &[u8] = b"gzip";

impl Default for Parser {
    fn default() -> Self {
        Self::new()
    }
}

impl Parser {
    /// Waiting for a request line; read-only (`PUT` is 405).
    pub const fn new() -> Self {
        Parser {
            stage: Stage::Line { empty: 0 },
            line: heapless::Vec::new(),
            header_bytes: 0,
            updates: false,
            name: heapless::Vec::new(),
            field: Field::Name,
            gzip_at: 0,
            length_sent: false,
            length: None,
            length_bad: false,
            transfer: false,
            body_start: 0,
        }
    }

    /// Waiting for a request line; `PUT /firmware` is a request.
    pub const fn with_updates() -> Self {
        let mut p = Self::new();
        p.updates = true;
        p
    }

    /// Where, in the bytes of the [`Parser::feed`] that gave the verdict,
    /// the head ended: what follows is the start of a `PUT`'s body.
    pub fn body_start(&self) -> usize {
        self.body_start
    }

    /// Follows one byte of a header line (not a line end).
    fn header_field(&mut self, b: u8, request: &mut Request) {
        match self.field {
            Field::Name if b == b':' => {
                self.field = match self.name.as_slice() {
                    b"accept-encoding" => Field::AcceptEncoding,
                    b"content-length" => {
                        self.length_bad |= self.length_sent;
                        self.length_sent = true;
                        Field::ContentLength
                    }
                    b"transfer-encoding" => {
                        self.transfer = true;
                        Field::TransferEncoding
                    }
                    _ => Field::Other,
                };
            }
            Field::Name => {
                if self.name.push(b.to_ascii_lowercase()).is_err() {
                    self.field = Field::Other;
                }
            }
            Field::AcceptEncoding => {
                // Match `gzip`, case-insensitively, anywhere in the value.
                let next = GZIP.get(usize::from(self.gzip_at)).copied();
                self.gzip_at = if next == Some(b.to_ascii_lowercase()) {
                    self.gzip_at + 1
                } else {
                    u8::from(b.eq_ignore_ascii_case(&b'g'))
                };
                request.gzip |= usize::from(self.gzip_at) == GZIP.len();
            }
            Field::ContentLength => match b {
                b' ' | b'\t' => {}
                b'0'..=b'9' => {
                    let n = self
                        .length
                        .unwrap_or(0)
                        .saturating_mul(10)
                        .saturating_add(u64::from(b - b'0'));
                    self.length_bad |= n > u64::from(u32::MAX);
                    self.length = Some(n.min(u64::from(u32::MAX) + 1));
                }
                _ => self.length_bad = true,
            },
            Field::TransferEncoding | Field::Other => {}
        }
    }

    /// At the end of the header lines: the verdict on `request`.
    fn headers_done(&self, request: Request) -> Parsed {
        if request.route != Route::Firmware {
            return Parsed::Request(request);
        }
        if request.cancel {
            // A cancellation has no body: one would be another request's
            // bytes, which are never read.
            return match (self.transfer, self.length, self.length_bad) {
                (false, None | Some(0), false) => Parsed::Request(request),
                _ => Parsed::Refused(Status::BadRequest),
            };
        }
        if self.transfer {
            return Parsed::Refused(Status::NotImplemented);
        }
        match (self.length, self.length_bad) {
            (_, true) => Parsed::Refused(Status::BadRequest),
            (None, false) if self.length_sent => Parsed::Refused(Status::BadRequest),
            (None, false) => Parsed::Refused(Status::LengthRequired),
            (Some(n), false) => {
                let mut request = request;
                if let Some(body) = request.body.as_mut() {
                    body.length = u32::try_from(n).unwrap_or(u32::MAX);
                }
                Parsed::Request(request)
            }
        }
    }

    /// The verdict so far, without more bytes.
    pub fn parsed(&self) -> Parsed {
        match self.stage {
            Stage::Done(p) => p,
            _ => Parsed::More,
        }
    }

    /// Takes `bytes`; the verdict once there is one (bytes after it are
    /// ignored: one request per connection).
    pub fn feed(&mut self, bytes: &[u8]) -> Parsed {
        for (i, &b) in bytes.iter().enumerate() {
            let next = match self.stage {
                Stage::Done(p) => return p,
                Stage::Line { empty } => self.line_byte(b, empty),
                Stage::Headers {
                    at_line_start,
                    request,
                } => self.header_byte(b, at_line_start, request),
            };
            if matches!(next, Stage::Done(_)) {
                self.body_start = i + 1;
            }
            self.stage = next;
        }
        self.parsed()
    }

    fn line_byte(&mut self, b: u8, empty: u8) -> Stage {
        if b == b'\n' {
            let line = strip_cr(&self.line);
            if line.is_empty() {
                self.line.clear();
                return if empty < LEADING_EMPTY_LINES {
                    Stage::Line { empty: empty + 1 }
                } else {
                    Stage::Done(Parsed::Refused(Status::BadRequest))
                };
            }
            return match request_line(line, self.updates) {
                Ok(request) => Stage::Headers {
                    at_line_start: true,
                    request,
                },
                Err(status) => Stage::Done(Parsed::Refused(status)),
            };
        }
        if self.line.push(b).is_err() {
            return Stage::Done(Parsed::Refused(Status::UriTooLong));
        }
        Stage::Line { empty }
    }

    fn header_byte(&mut self, b: u8, at_line_start: bool, request: Request) -> Stage {
        self.header_bytes += 1;
        if self.header_bytes > HEADERS_MAX {
            return Stage::Done(Parsed::Refused(Status::HeadersTooLarge));
        }
        let mut request = request;
        match b {
            // An empty line ends the headers (CRLF, or a bare LF).
            b'\n' if at_line_start => Stage::Done(self.headers_done(request)),
            b'\n' => {
                self.length_bad |= self.field == Field::ContentLength && self.length.is_none();
                self.name.clear();
                (self.field, self.gzip_at) = (Field::Name, 0);
                Stage::Headers {
                    at_line_start: true,
                    request,
                }
            }
            // The CR of an empty line's CRLF leaves us at the line's start.
            b'\r' => Stage::Headers {
                at_line_start,
                request,
            },
            // A NUL anywhere in a header is malformed (RFC 9110 §5.5).
            0 => Stage::Done(Parsed::Refused(Status::BadRequest)),
            _ => {
                self.header_field(b, &mut request);
                Stage::Headers {
                    at_line_start: false,
                    request,
                }
            }
        }
    }
}

fn strip_cr(line: &[u8]) -> &[u8] {
    line.strip_suffix(b"\r").unwrap_or(line)
}

/// Methods RFC 9110 defines (405 rather than 501).
const KNOWN_METHODS: [&[u8]; 7] = [
    b"POST", b"PUT", b"DELETE", b"CONNECT", b"OPTIONS", b"TRACE", b"PATCH",
];

/// `METHOD SP request-target SP HTTP-version` (RFC 9112 §3).
fn request_line(line: &[u8], updates: bool) -> Result<Request, Status> {
    if line
        .iter()
        .any(|&b| !(0x21..=0x7e).contains(&b) && b != b' ')
    {
        return Err(Status::BadRequest);
    }
    let mut parts = line.split(|&b| b == b' ');
    let (Some(method), Some(target), Some(version), None) =
        (parts.next(), parts.next(), parts.next(), parts.next())
    else {
        return Err(Status::BadRequest);
    };
    if method.is_empty() || !method.iter().all(|&b| is_tchar(b)) {
        return Err(Status::BadRequest);
    }
    let (head_only, put, cancel) = match method {
        b"GET" => (false, false, false),
        b"HEAD" => (true, false, false),
        b"PUT" if updates => (false, true, false),
        b"DELETE" if updates => (false, false, true),
        m if KNOWN_METHODS.contains(&m) => return Err(Status::MethodNotAllowed),
        _ => return Err(Status::NotImplemented),
    };
    match version {
        b"HTTP/1.1" | b"HTTP/1.0" => {}
        [b'H', b'T', b'T', b'P', b'/', major, b'.', minor]
            if major.is_ascii_digit() && minor.is_ascii_digit() =>
        {
            return Err(Status::VersionNotSupported)
        }
        _ => return Err(Status::BadRequest),
    }
    if target.first() != Some(&b'/') {
        return Err(Status::BadRequest);
    }
    let mut parts = target.splitn(2, |&b| b == b'?');
    let path = parts.next().unwrap_or(target);
    let query = parts.next().unwrap_or(&[]);
    let route = match path {
        b"/" | b"/index.html" => Route::Page,
        b"/status.json" => Route::Json,
        b"/metrics" => Route::Metrics,
        b"/firmware" if updates => Route::Firmware,
        _ => return Err(Status::NotFound),
    };
    // `PUT` and `DELETE` are for the firmware alone, and the firmware
    // takes only those.
    match (put || cancel, route == Route::Firmware) {
        (true, false) => return Err(Status::MethodNotAllowed),
        (false, true) => return Err(Status::PutOnly),
        _ => {}
    }
    let body = put.then(|| Body {
        length: 0,
        force: query.split(|&b| b == b'&').any(|p| p == b"force=1"),
    });
    Ok(Request {
        route,
        head_only,
        gzip: false,
        body,
        cancel,
    })
}

/// RFC 9110 §5.6.2 token characters.
fn is_tchar(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b"!#$%&'*+-.^_`|~".contains(&b)
}

#[cfg(test)]
#[path = "http_tests.rs"]
mod tests;
