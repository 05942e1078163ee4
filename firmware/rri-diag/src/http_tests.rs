//! Unit tests of [`super`]: the request parser's bounds and answers.

use super::*;

/// Every byte a response writer gives.
struct All(Vec<u8>);

impl super::super::Out for All {
    fn bytes(&mut self, b: &[u8]) {
        self.0.extend_from_slice(b);
    }
}

fn parse(bytes: &[u8]) -> Parsed {
    Parser::new().feed(bytes)
}

fn ok(route: Route) -> Parsed {
    Parsed::Request(Request {
        route,
        head_only: false,
        gzip: false,
        body: None,
        cancel: false,
    })
}

#[test]
fn the_three_paths_with_crlf_or_bare_lf_and_any_split() {
    let req = b"GET /metrics HTTP/1.1\r\nHost: x\r\nAccept: */*\r\n\r\n";
    assert_eq!(parse(req), ok(Route::Metrics));
    for split in 0..req.len() {
        let mut p = Parser::new();
        let first = p.feed(&req[..split]);
        assert_eq!(first, Parsed::More, "split at {split}");
        assert_eq!(p.feed(&req[split..]), ok(Route::Metrics));
    }
    assert_eq!(parse(b"GET / HTTP/1.0\n\n"), ok(Route::Page));
    assert_eq!(
        parse(b"\r\nGET /status.json?x=1 HTTP/1.1\r\n\r\n"),
        ok(Route::Json)
    );
    assert_eq!(
        parse(b"HEAD /index.html HTTP/1.1\r\n\r\n"),
        Parsed::Request(Request {
            route: Route::Page,
            head_only: true,
            gzip: false,
            body: None,
            cancel: false,
        })
    );
}

#[test]
fn accept_encoding_gzip_is_seen_in_any_case_and_split() {
    let req = b"GET / HTTP/1.1\r\nAccept: text/html\r\naccept-Encoding: br, GZip, deflate\r\n\r\n";
    let gz = Parsed::Request(Request {
        route: Route::Page,
        head_only: false,
        gzip: true,
        body: None,
        cancel: false,
    });
    for split in 0..req.len() {
        let mut p = Parser::new();
        p.feed(&req[..split]);
        assert_eq!(p.feed(&req[split..]), gz, "split at {split}");
    }
    for no in [
        &b"GET / HTTP/1.1\r\nAccept-Encoding: br\r\n\r\n"[..],
        b"GET / HTTP/1.1\r\nX-Accept-Encoding: gzip\r\n\r\n",
        b"GET / HTTP/1.1\r\nAccept: gzip\r\n\r\n",
        b"GET / HTTP/1.1\r\nAccept-Encoding: gzi\r\nX: p\r\n\r\n",
    ] {
        assert_eq!(parse(no), ok(Route::Page), "{no:?}");
    }
    assert_eq!(
        parse(b"GET / HTTP/1.1\r\nAccept-Encoding: ggzip\r\n\r\n"),
        gz
    );
}

#[test]
fn an_unfinished_request_waits_for_more() {
    assert_eq!(parse(b"GET / HTTP/1.1\r\nHost: x\r\n"), Parsed::More);
    assert_eq!(parse(b"GE"), Parsed::More);
}

#[test]
fn other_methods_are_refused_not_served() {
    for m in [
        "POST", "PUT", "DELETE", "PATCH", "OPTIONS", "TRACE", "CONNECT",
    ] {
        let req = format!("{m} / HTTP/1.1\r\n\r\n");
        assert_eq!(
            parse(req.as_bytes()),
            Parsed::Refused(Status::MethodNotAllowed),
            "{m}"
        );
    }
    assert_eq!(
        parse(b"BREW / HTTP/1.1\r\n\r\n"),
        Parsed::Refused(Status::NotImplemented)
    );
    assert_eq!(
        parse(b"get / HTTP/1.1\r\n\r\n"),
        Parsed::Refused(Status::NotImplemented)
    );
    // A POST is refused at its request line: its body is never read.
    assert_eq!(
        parse(b"POST /metrics HTTP/1.1\r\nContent-Length: 5\r\n\r\nhello"),
        Parsed::Refused(Status::MethodNotAllowed)
    );
}

#[test]
fn unknown_and_traversing_paths_are_not_found() {
    for path in [
        "/../etc/passwd",
        "/%2e%2e/",
        "/metrics/",
        "//",
        "/status.json/../metrics",
    ] {
        let req = format!("GET {path} HTTP/1.1\r\n\r\n");
        assert_eq!(
            parse(req.as_bytes()),
            Parsed::Refused(Status::NotFound),
            "{path}"
        );
    }
    assert_eq!(
        parse(b"GET http://x/ HTTP/1.1\r\n\r\n"),
        Parsed::Refused(Status::BadRequest)
    );
    assert_eq!(
        parse(b"GET * HTTP/1.1\r\n\r\n"),
        Parsed::Refused(Status::BadRequest)
    );
}

#[test]
fn malformed_lines_and_non_ascii_are_bad_requests() {
    for req in [
        &b"GET /\r\n\r\n"[..],
        b"GET  / HTTP/1.1\r\n\r\n",
        b"GET / HTTP/1.1 x\r\n\r\n",
        b"GET /\xff HTTP/1.1\r\n\r\n",
        b"GET /\x00 HTTP/1.1\r\n\r\n",
        b"GET / HTTP/1.1\r\nHost: a\x00b\r\n\r\n",
        b"GET / HTTPS/1.1\r\n\r\n",
        b"\r\n\r\n\r\n\r\n\r\n",
    ] {
        assert_eq!(parse(req), Parsed::Refused(Status::BadRequest), "{req:?}");
    }
    assert_eq!(
        parse(b"GET / HTTP/2.0\r\n\r\n"),
        Parsed::Refused(Status::VersionNotSupported)
    );
    // Non-UTF-8 in a header value is obs-text: tolerated, never read.
    assert_eq!(
        parse(b"GET / HTTP/1.1\r\nX: \xff\xfe\r\n\r\n"),
        ok(Route::Page)
    );
}

#[test]
fn oversize_request_lines_and_headers_are_refused_at_the_limit() {
    let long = format!("GET /{} HTTP/1.1\r\n\r\n", "a".repeat(LINE_MAX));
    let mut p = Parser::new();
    assert_eq!(p.feed(long.as_bytes()), Parsed::Refused(Status::UriTooLong));
    // Without an end, it is refused as soon as the limit is passed.
    assert_eq!(
        Parser::new().feed(&[b'a'; LINE_MAX + 1]),
        Parsed::Refused(Status::UriTooLong)
    );
    let mut p = Parser::new();
    assert_eq!(p.feed(b"GET / HTTP/1.1\r\n"), Parsed::More);
    assert_eq!(
        p.feed(&[b'h'; HEADERS_MAX + 1]),
        Parsed::Refused(Status::HeadersTooLarge)
    );
    // Exactly at the limit is fine.
    let mut p = Parser::new();
    p.feed(b"GET / HTTP/1.1\r\n");
    let mut header = vec![b'x'; HEADERS_MAX - 4];
    header.extend_from_slice(b"\r\n\r\n");
    assert_eq!(p.feed(&header), ok(Route::Page));
}

#[test]
fn pipelined_requests_after_the_first_are_ignored() {
    let mut p = Parser::new();
    let both = b"GET /metrics HTTP/1.1\r\n\r\nGET / HTTP/1.1\r\n\r\n";
    assert_eq!(p.feed(both), ok(Route::Metrics));
    assert_eq!(p.feed(b"more"), ok(Route::Metrics));
}

#[test]
fn responses_close_the_connection_and_say_their_length() {
    let mut a = All(Vec::new());
    error(&mut a, Status::MethodNotAllowed);
    let text = String::from_utf8(a.0).unwrap();
    let (head, body) = text.split_once("\r\n\r\n").unwrap();
    assert!(
        head.starts_with("HTTP/1.1 405 Method Not Allowed\r\n"),
        "{head}"
    );
    assert!(head.contains("\r\nConnection: close"));
    assert!(head.contains("\r\nAllow: GET, HEAD"));
    assert!(head.contains(&format!("\r\nContent-Length: {}", body.len())));
    assert_eq!(body, "405 Method Not Allowed\n");
}

fn put(length: u32, force: bool) -> Parsed {
    Parsed::Request(Request {
        route: Route::Firmware,
        head_only: false,
        gzip: false,
        body: Some(Body { length, force }),
        cancel: false,
    })
}

#[test]
fn put_firmware_is_a_request_only_with_updates_built_in() {
    let req = b"PUT /firmware HTTP/1.1\r\nHost: d\r\nContent-Length: 211504\r\n\r\nBODY";
    // Read-only: any PUT is 405 (Allow: GET, HEAD), /firmware 404.
    assert_eq!(parse(req), Parsed::Refused(Status::MethodNotAllowed));
    assert_eq!(
        parse(b"GET /firmware HTTP/1.1\r\n\r\n"),
        Parsed::Refused(Status::NotFound)
    );
    for split in 0..req.len() {
        let mut p = Parser::with_updates();
        let first = p.feed(&req[..split]);
        let verdict = if first == Parsed::More {
            let v = p.feed(&req[split..]);
            // The body starts right after the head, in this feed's bytes.
            assert_eq!(&req[split..][p.body_start()..], b"BODY", "split at {split}");
            v
        } else {
            // The rest of this feed and all of the next are the body.
            let rest = [&req[..split][p.body_start()..], &req[split..]].concat();
            assert_eq!(rest, b"BODY", "split at {split}");
            first
        };
        assert_eq!(verdict, put(211_504, false), "split at {split}");
    }
    let mut p = Parser::with_updates();
    assert_eq!(
        p.feed(b"PUT /firmware?x=2&force=1 HTTP/1.1\r\ncontent-length:\t 7 \r\n\r\n"),
        put(7, true)
    );
}

#[test]
fn put_firmware_needs_one_plain_content_length_and_other_methods_stay_refused() {
    let with = |bytes: &[u8]| Parser::with_updates().feed(bytes);
    for (req, status) in [
        (
            &b"PUT /firmware HTTP/1.1\r\n\r\n"[..],
            Status::LengthRequired,
        ),
        (
            b"PUT /firmware HTTP/1.1\r\nContent-Length: 12x\r\n\r\n",
            Status::BadRequest,
        ),
        (
            b"PUT /firmware HTTP/1.1\r\nContent-Length: \r\n\r\n",
            Status::BadRequest,
        ),
        (
            b"PUT /firmware HTTP/1.1\r\nContent-Length: 4294967296\r\n\r\n",
            Status::BadRequest,
        ),
        (
            b"PUT /firmware HTTP/1.1\r\nContent-Length: 5\r\nContent-Length: 5\r\n\r\n",
            Status::BadRequest,
        ),
        (
            b"PUT /firmware HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n",
            Status::NotImplemented,
        ),
        (
            b"PUT /status.json HTTP/1.1\r\nContent-Length: 5\r\n\r\n",
            Status::MethodNotAllowed,
        ),
        (
            b"POST /firmware HTTP/1.1\r\nContent-Length: 5\r\n\r\n",
            Status::MethodNotAllowed,
        ),
        (b"GET /firmware HTTP/1.1\r\n\r\n", Status::PutOnly),
        (
            b"PUT /firmwares HTTP/1.1\r\nContent-Length: 5\r\n\r\n",
            Status::NotFound,
        ),
    ] {
        assert_eq!(
            with(req),
            Parsed::Refused(status),
            "{}",
            String::from_utf8_lossy(req)
        );
    }
    assert_eq!(
        with(b"PUT /firmware HTTP/1.1\r\nContent-Length: 4294967295\r\n\r\n"),
        put(u32::MAX, false)
    );
    // GET is as before with updates built in; a Content-Length there is
    // ignored (a GET's body is never read).
    assert_eq!(
        with(b"GET /metrics HTTP/1.1\r\nContent-Length: x\r\n\r\n"),
        ok(Route::Metrics)
    );
}

#[test]
fn delete_firmware_cancels_without_a_body_and_only_with_updates_built_in() {
    let cancel = Parsed::Request(Request {
        route: Route::Firmware,
        head_only: false,
        gzip: false,
        body: None,
        cancel: true,
    });
    let with = |bytes: &[u8]| Parser::with_updates().feed(bytes);
    assert_eq!(
        with(b"DELETE /firmware HTTP/1.1\r\nHost: d\r\n\r\n"),
        cancel
    );
    assert_eq!(
        with(b"DELETE /firmware HTTP/1.1\r\nContent-Length: 0\r\n\r\n"),
        cancel
    );
    for (req, status) in [
        // A body would be another request's bytes, never read.
        (
            &b"DELETE /firmware HTTP/1.1\r\nContent-Length: 3\r\n\r\nabc"[..],
            Status::BadRequest,
        ),
        (
            b"DELETE /firmware HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n",
            Status::BadRequest,
        ),
        (
            b"DELETE /status.json HTTP/1.1\r\n\r\n",
            Status::MethodNotAllowed,
        ),
        (b"DELETE /nothing HTTP/1.1\r\n\r\n", Status::NotFound),
    ] {
        assert_eq!(
            with(req),
            Parsed::Refused(status),
            "{}",
            String::from_utf8_lossy(req)
        );
    }
    // Read-only: DELETE is 405 like any other method it does not take.
    assert_eq!(
        parse(b"DELETE /firmware HTTP/1.1\r\n\r\n"),
        Parsed::Refused(Status::MethodNotAllowed)
    );
    // /firmware's 405 names both methods it takes.
    let mut a = All(Vec::new());
    error(&mut a, Status::PutOnly);
    let text = String::from_utf8(a.0).unwrap();
    assert!(text.contains("\r\nAllow: PUT, DELETE\r\n"), "{text}");
}
