//! The diagnostics service's two halves (`rri_diag::serve`: the network
//! half that moves bytes, the service half that parses and renders) on an
//! embassy-net stack, clients on a second stack, one in-memory Ethernet
//! (`memnet`), embassy-time's mock clock: what the QEMU board cannot show
//! through slirp (which accepts every connection and buffers every
//! response on the host's side): a client that never reads, a client that
//! half-closes, a slot count that refuses, and the timeouts, in mock
//! time.

mod memnet;
mod service;

use embassy_net::tcp::TcpSocket;
use embassy_time::{Duration, Instant, Timer};
use rri_diag::serve;
use service::{device, exchange, status_of, timed_exchange, with_service};
#[test]
fn a_request_is_answered_whole_and_the_connection_closed() {
    let (out, [accepted, responses, aborted]) = with_service(
        |stack| async move {
            exchange(
                stack,
                b"GET /status.json HTTP/1.1\r\nHost: x\r\n\r\n",
                false,
            )
            .await
        },
        30_000,
    );
    let response = out.expect("the client finished").expect("answered");
    let text = String::from_utf8(response).unwrap();
    let (head, body) = text.split_once("\r\n\r\n").unwrap();
    assert!(head.starts_with("HTTP/1.1 200 OK"), "{head}");
    assert!(
        head.contains(&format!("Content-Length: {}", body.len())),
        "{head}"
    );
    let v: serde_json::Value = serde_json::from_str(body).expect("JSON");
    assert_eq!(v["device"]["name"], "AnyDevice");
    assert_eq!((accepted, responses, aborted), (1, 1, 0));
}

#[test]
fn a_client_that_half_closes_after_its_request_is_still_answered() {
    // Issue 42 #10: every byte of the body, not the status line only (the
    // device closed, saw the client's FIN at once and aborted, dropping the
    // tail its socket still held).
    for path in ["/metrics", "/status.json", "/"] {
        let request = format!("GET {path} HTTP/1.0\r\n\r\n");
        let (out, _) = with_service(
            move |stack| async move { exchange(stack, request.as_bytes(), true).await },
            30_000,
        );
        let response = out.expect("finished").expect("answered");
        let text = String::from_utf8_lossy(&response);
        assert_eq!(status_of(&response), Some(200), "{path}: {text}");
        let split = response
            .windows(4)
            .position(|w| w == b"\r\n\r\n")
            .expect("a head");
        let head = String::from_utf8_lossy(&response[..split]);
        let length: usize = head
            .lines()
            .find_map(|l| l.strip_prefix("Content-Length: "))
            .and_then(|v| v.trim().parse().ok())
            .expect("a Content-Length");
        assert_eq!(
            response.len() - split - 4,
            length,
            "{path}: the body as long as its Content-Length"
        );
    }
}

#[test]
fn a_half_open_connection_gets_408_after_the_request_timeout() {
    let (out, _) = with_service(
        |stack| async move { timed_exchange(stack, b"GET /metr", false).await },
        30_000,
    );
    let (response, after) = out.expect("finished");
    let response = response.expect("answered");
    assert_eq!(status_of(&response), Some(408));
    assert!(
        after >= serve::REQUEST_TIMEOUT && after < serve::REQUEST_TIMEOUT + Duration::from_secs(1),
        "{after:?}"
    );
}

#[test]
fn a_client_that_never_reads_loses_its_slot_within_the_response_timeout() {
    let (out, [_, _, aborted]) = with_service(
        |stack| async move {
            // A receive window of 64 bytes, never read: the page's 3.3 KB
            // cannot all leave the device.
            let mut rx = [0u8; 64];
            let mut tx = [0u8; 256];
            let mut stuck = TcpSocket::new(stack, &mut rx, &mut tx);
            stuck.connect(device()).await.expect("connects");
            stuck
                .write(b"GET / HTTP/1.1\r\nAccept-Encoding: gzip\r\n\r\n")
                .await
                .expect("writes");
            let start = Instant::now();
            // Meanwhile the other slot serves.
            let other = exchange(stack, b"GET /metrics HTTP/1.1\r\n\r\n", false).await;
            // The stuck one is closed by the device within its bounds.
            loop {
                let state = stuck.state();
                if matches!(
                    state,
                    embassy_net::tcp::State::Closed | embassy_net::tcp::State::TimeWait
                ) || start.elapsed() > Duration::from_secs(20)
                {
                    break;
                }
                Timer::after(Duration::from_millis(10)).await;
            }
            (other, stuck.state(), start.elapsed())
        },
        40_000,
    );
    let (other, state, after) = out.expect("finished");
    assert_eq!(status_of(&other.expect("served")), Some(200));
    assert!(
        matches!(
            state,
            embassy_net::tcp::State::Closed | embassy_net::tcp::State::TimeWait
        ),
        "{state:?} after {after:?}"
    );
    // The stalled client lost its connection once it took nothing for
    // STALL_TIMEOUT, long before its response deadline.
    assert!(
        after <= serve::STALL_TIMEOUT + Duration::from_secs(1),
        "{after:?}"
    );
    assert_eq!(aborted, 1);
}

#[test]
fn more_connections_than_slots_are_turned_away_at_once_and_the_slots_serve_again() {
    let (out, [accepted, ..]) = with_service(
        |stack| async move {
            // Three at once against two slots: two answered, one refused.
            let (a, b, c) = embassy_futures::join::join3(
                exchange(stack, b"GET /status.json HTTP/1.1\r\n\r\n", false),
                exchange(stack, b"GET /status.json HTTP/1.1\r\n\r\n", false),
                exchange(stack, b"GET /status.json HTTP/1.1\r\n\r\n", false),
            )
            .await;
            let again = exchange(stack, b"GET /metrics HTTP/1.1\r\n\r\n", false).await;
            ([a, b, c], again)
        },
        40_000,
    );
    let (three, again) = out.expect("finished");
    let served = three
        .iter()
        .filter(|r| r.as_ref().is_ok_and(|r| status_of(r) == Some(200)))
        .count();
    let refused = three
        .iter()
        .filter(|r| r.as_ref().is_err_and(|e| e.starts_with("connect")))
        .count();
    assert_eq!((served, refused), (2, 1), "{three:?}");
    assert_eq!(status_of(&again.expect("served again")), Some(200));
    assert_eq!(accepted, 3);
}
