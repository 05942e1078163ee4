//! The diagnostics service's two halves (`rri_diag::serve`: the network
//! half that moves bytes, the service half that parses and renders) on an
//! embassy-net stack, clients on a second stack, one in-memory Ethernet
//! (`memnet`), embassy-time's mock clock: what the QEMU board cannot show
//! through slirp (which accepts every connection and buffers every
//! response on the host's side): a client that never reads, a client that
//! half-closes, a slot count that refuses, and the timeouts, in mock
//! time.

mod memnet;

use embassy_futures::select::{select, Either};
use embassy_net::tcp::TcpSocket;
use embassy_net::{Stack, StackResources};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::mutex::Mutex;
use embassy_time::{Duration, Instant, MockDriver, Timer};
use memnet::{mock_clock, net_config, poll_once, MemDriver, DEVICE_MAC, ROBOT_IP};
use rri_diag::serve::{
    self, Desk, Renderer, ServiceHalf, ServiceStats, Slot, SocketHalf, SLOTS, WINDOW,
};
use rri_diag::status::{Latency, LatencySource, LinkInfo};
use rri_diag::{Identity, Status};
use rri_firmware::fragments::Link;
use rri_firmware::snapshot::Snapshot;
use smoltcp::wire::Ipv4Address;
use std::pin::pin;

const DEVICE_IP: [u8; 4] = [10, 49, 65, 74];
const PORT: u16 = 80;

fn identity() -> Identity {
    Identity {
        device: "AnyDevice",
        device_type: "t",
        device_class: "c",
        version: "0.1.0",
        commit: "test",
        board: "memnet",
        sensor: "none",
        sensor_file: "none",
        mac: Some(DEVICE_MAC),
        ip: DEVICE_IP,
        prefix: 24,
        gateway: None,
        protocol: rri_firmware::schema::Protocol::Udp,
        port: 3002,
        http_port: PORT,
        config: rri_firmware::layout::ENGINE_CONFIG,
        received: &rri_firmware::layout::RECEIVED_INFO,
        sent: &rri_firmware::layout::SENT_INFO,
    }
}

fn fill(out: &mut Option<Status>) {
    *out = Some(Status {
        snapshot: Snapshot::default(),
        now: rri_firmware::engine::Instant(Instant::now().as_micros()),
        link: LinkInfo::default(),
        nic: None,
        stack: None,
        latency: Latency {
            source: LatencySource::Socket,
            histogram: Default::default(),
        },
        bad: None,
        events: Default::default(),
        reset: None,
        update: None,
    });
}

/// The service (its `SLOTS` slots) on one stack, `client` on another;
/// polls everything, 1 ms of mock time per step, until the client is
/// done or `max_ms` passed. Returns the client's output and the service's
/// counters.
fn with_service<F, T>(
    client: impl FnOnce(Stack<'static>) -> F,
    max_ms: u64,
) -> (Option<T>, [u32; 3])
where
    F: std::future::Future<Output = T>,
{
    with_desk(Box::leak(Box::new(Desk::new())), client, max_ms)
}

/// [`with_service`] with `desk` (a receiver installed: uploads taken).
fn with_desk<F, T>(
    desk: &'static Desk,
    client: impl FnOnce(Stack<'static>) -> F,
    max_ms: u64,
) -> (Option<T>, [u32; 3])
where
    F: std::future::Future<Output = T>,
{
    let _clock = mock_clock();
    MockDriver::get().reset();
    let (device_driver, client_driver, _, _) = MemDriver::pair();
    let device_res = Box::leak(Box::new(StackResources::<{ SLOTS + 1 }>::new()));
    let client_res = Box::leak(Box::new(StackResources::<8>::new()));
    let (device, mut device_runner) =
        embassy_net::new(device_driver, net_config(DEVICE_IP), device_res, 1);
    let (robot, mut client_runner) =
        embassy_net::new(client_driver, net_config(ROBOT_IP), client_res, 2);
    let stats: &'static ServiceStats = Box::leak(Box::new(ServiceStats::new()));
    // No cycle here: its link never holds.
    let cycle: &'static Link = Box::leak(Box::new(Link::new()));
    let slots: &'static [Slot; SLOTS] = Box::leak(Box::new([const { Slot::new() }; SLOTS]));
    let window: &'static mut [u8; WINDOW] = Box::leak(Box::new([0; WINDOW]));
    let renderer: &'static Mutex<CriticalSectionRawMutex, Renderer> =
        Box::leak(Box::new(Mutex::new(Renderer::new(window))));
    let id: &'static Identity = Box::leak(Box::new(identity()));
    let mut halves: Vec<_> = slots
        .iter()
        .map(|slot| {
            let socket_half: &'static mut SocketHalf = Box::leak(Box::new(SocketHalf::new()));
            let service_half: &'static mut ServiceHalf = Box::leak(Box::new(ServiceHalf::new()));
            let rx: &'static mut [u8] = Box::leak(vec![0u8; serve::SOCKET_RX].into_boxed_slice());
            let tx: &'static mut [u8] = Box::leak(vec![0u8; serve::SOCKET_TX].into_boxed_slice());
            (
                Box::pin(serve::connection(
                    device,
                    PORT,
                    slot,
                    socket_half,
                    serve::Guest { stats, cycle },
                    rx,
                    tx,
                )),
                Box::pin(serve::service(
                    slot,
                    service_half,
                    renderer,
                    id,
                    fill,
                    Some(desk),
                )),
            )
        })
        .collect();
    let mut device_net = pin!(device_runner.run());
    let mut client_net = pin!(client_runner.run());
    let mut client = pin!(client(robot));
    let mut out = None;
    for _ in 0..max_ms {
        let _ = poll_once(device_net.as_mut());
        let _ = poll_once(client_net.as_mut());
        for (net, service) in halves.iter_mut() {
            let _ = poll_once(net.as_mut());
            let _ = poll_once(service.as_mut());
        }
        if let std::task::Poll::Ready(v) = poll_once(client.as_mut()) {
            out = Some(v);
            break;
        }
        MockDriver::get().advance(Duration::from_millis(1));
    }
    let load = |c: &std::sync::atomic::AtomicU32| c.load(std::sync::atomic::Ordering::Relaxed);
    (
        out,
        [
            load(&stats.accepted),
            load(&stats.responses),
            load(&stats.aborted),
        ],
    )
}

fn device() -> (Ipv4Address, u16) {
    (Ipv4Address::from(DEVICE_IP), PORT)
}

/// Connects, sends `request`, reads until the device closes (or 20 s of
/// mock time): the whole response, or the connect error.
async fn exchange(
    stack: Stack<'_>,
    request: &[u8],
    close_after_request: bool,
) -> Result<Vec<u8>, String> {
    let mut rx = [0u8; 4096];
    let mut tx = [0u8; 1024];
    let mut s = TcpSocket::new(stack, &mut rx, &mut tx);
    s.connect(device())
        .await
        .map_err(|e| format!("connect: {e:?}"))?;
    let mut rest = request;
    while !rest.is_empty() {
        let n = s.write(rest).await.map_err(|e| format!("write: {e:?}"))?;
        rest = &rest[n..];
    }
    if close_after_request {
        s.close();
    }
    let mut got = Vec::new();
    let mut buf = [0u8; 512];
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        match select(s.read(&mut buf), Timer::at(deadline)).await {
            Either::First(Ok(0)) | Either::First(Err(_)) => break,
            Either::First(Ok(n)) => got.extend_from_slice(&buf[..n]),
            Either::Second(()) => {
                return Err(format!("no close within 20 s; got {} bytes", got.len()))
            }
        }
    }
    // Close our side too, as a client does (the device's slot is free
    // once the handshake is done).
    s.close();
    let _ = select(s.flush(), Timer::after(Duration::from_secs(1))).await;
    Ok(got)
}

fn status_of(response: &[u8]) -> Option<u16> {
    std::str::from_utf8(response.get(9..12)?).ok()?.parse().ok()
}

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
        |stack| async move {
            let start = Instant::now();
            let r = exchange(stack, b"GET /metr", false).await;
            (r, start.elapsed())
        },
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

/// A receiver that keeps what it is given (no flash, no signature): the
/// service's half of an upload alone. A file is "good" when its bytes
/// are `0, 1, 2, …` (mod 251) and at most [`SINK_CAPACITY`] long.
struct Sink {
    got: std::sync::Arc<std::sync::Mutex<Vec<u8>>>,
    declared: usize,
}

const SINK_CAPACITY: usize = 64 * 1024;

fn pattern(len: usize) -> Vec<u8> {
    (0..len).map(|i| (i % 251) as u8).collect()
}

impl rri_update::Receive for Sink {
    fn begin(&mut self, declared: usize) -> Result<(), rri_update::Refused> {
        if declared > SINK_CAPACITY {
            return Err(rri_update::Refused::TooLarge {
                declared,
                capacity: SINK_CAPACITY,
            });
        }
        self.declared = declared;
        self.got.lock().unwrap().clear();
        Ok(())
    }
    fn push(&mut self, bytes: &[u8]) -> Result<(), rri_update::Refused> {
        self.got.lock().unwrap().extend_from_slice(bytes);
        Ok(())
    }
    fn finish(&mut self, _force: bool) -> Result<rri_update::Trailer, rri_update::Refused> {
        let got = self.got.lock().unwrap();
        if *got != pattern(self.declared) {
            return Err(rri_update::Refused::BadSignature);
        }
        Ok(rri_update::Trailer::new(
            "memnet",
            rri_update::Version::parse("1.2.3").unwrap(),
            got.len() as u32,
            0,
        )
        .unwrap())
    }
    fn abandon(&mut self) {}
    fn swaps(&self) -> bool {
        true
    }
    fn running(&self) -> rri_update::Version {
        rri_update::Version::parse("1.0.0").unwrap()
    }
}

/// A desk with a [`Sink`] installed, and what the sink got.
fn desk_with_sink() -> (&'static Desk, std::sync::Arc<std::sync::Mutex<Vec<u8>>>) {
    let desk: &'static Desk = Box::leak(Box::new(Desk::new()));
    let got = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let sink = Box::leak(Box::new(Sink {
        got: got.clone(),
        declared: 0,
    }));
    assert!(desk.install(sink));
    (desk, got)
}

fn put_head(len: usize) -> Vec<u8> {
    format!("PUT /firmware HTTP/1.1\r\nHost: x\r\nContent-Length: {len}\r\n\r\n").into_bytes()
}

fn body_of(response: &[u8]) -> String {
    let text = String::from_utf8_lossy(response);
    text.split_once("\r\n\r\n")
        .map_or(String::new(), |(_, b)| b.trim_end().to_string())
}

#[test]
fn an_upload_reaches_the_receiver_whole_and_its_outcome_is_the_answer() {
    // Issue 43: the body's first bytes come in the head's last read; all
    // of it, and nothing past its Content-Length, reaches the receiver.
    let (desk, got) = desk_with_sink();
    let file = pattern(20_000);
    let mut request = put_head(file.len());
    request.extend_from_slice(&file);
    request.extend_from_slice(b"GET / HTTP/1.1\r\n\r\n");
    let (out, [accepted, responses, aborted]) = with_desk(
        desk,
        move |stack| async move { exchange(stack, &request, false).await },
        30_000,
    );
    let response = out.expect("finished").expect("answered");
    assert_eq!(status_of(&response), Some(200), "{}", body_of(&response));
    assert_eq!(
        body_of(&response),
        "version 1.2.3 checked and marked: it is swapped in at the next reset"
    );
    assert_eq!(*got.lock().unwrap(), file);
    assert_eq!((accepted, responses, aborted), (1, 1, 0));
    // The status says the same.
    let u = desk.update().expect("updates taken");
    assert!(
        matches!(u.last, rri_update::Outcome::Marked { .. }),
        "{u:?}"
    );
}

#[test]
fn a_stalled_upload_is_abandoned_after_the_body_stall_and_a_closed_one_at_once() {
    for close in [false, true] {
        let (desk, got) = desk_with_sink();
        let mut request = put_head(10_000);
        request.extend_from_slice(&pattern(4_000));
        let (out, _) = with_desk(
            desk,
            move |stack| async move {
                let start = Instant::now();
                let r = exchange(stack, &request, close).await;
                (r, start.elapsed())
            },
            30_000,
        );
        let (response, after) = out.expect("finished");
        let response = response.expect("answered");
        assert_eq!(status_of(&response), Some(400));
        assert_eq!(
            body_of(&response),
            "abandoned after 4000 of 10000 bytes; nothing was marked"
        );
        assert_eq!(got.lock().unwrap().len(), 4_000);
        if close {
            // The client's close: no more can come, so no wait.
            assert!(after < Duration::from_millis(500), "{after:?}");
        } else {
            assert!(
                after >= serve::BODY_STALL && after < serve::BODY_STALL + Duration::from_secs(1),
                "{after:?}"
            );
        }
    }
}

#[test]
fn a_second_upload_while_one_arrives_is_refused_and_a_refusal_is_answered_at_once() {
    let (desk, _) = desk_with_sink();
    let (out, _) = with_desk(
        desk,
        |stack| async move {
            // The first sends half its body and waits; the second is
            // refused with 409 meanwhile; the first then completes.
            let mut rx = [0u8; 1024];
            let mut tx = [0u8; 8192];
            let mut first = TcpSocket::new(stack, &mut rx, &mut tx);
            first.connect(device()).await.expect("connects");
            let file = pattern(8_000);
            let mut head = put_head(file.len());
            head.extend_from_slice(&file[..4_000]);
            let mut rest: &[u8] = &head;
            while !rest.is_empty() {
                let n = first.write(rest).await.expect("writes");
                rest = &rest[n..];
            }
            Timer::after(Duration::from_millis(500)).await;
            let second = exchange(stack, &put_head(100), false).await;
            let mut rest: &[u8] = &file[4_000..];
            while !rest.is_empty() {
                let n = first.write(rest).await.expect("writes");
                rest = &rest[n..];
            }
            let mut got = Vec::new();
            let mut buf = [0u8; 256];
            while let Ok(n) = first.read(&mut buf).await {
                if n == 0 {
                    break;
                }
                got.extend_from_slice(&buf[..n]);
            }
            // Too large: refused before a byte of its body is read.
            let large = exchange(stack, &put_head(SINK_CAPACITY + 1), false).await;
            (second, got, large)
        },
        30_000,
    );
    let (second, first, large) = out.expect("finished");
    let second = second.expect("answered");
    assert_eq!(status_of(&second), Some(409));
    assert_eq!(
        body_of(&second),
        "another upload is arriving: one at a time"
    );
    assert_eq!(status_of(&first), Some(200), "{}", body_of(&first));
    let large = large.expect("answered");
    assert_eq!(status_of(&large), Some(413));
    assert!(
        body_of(&large).contains("(65537 bytes, the most is 65536)"),
        "{}",
        body_of(&large)
    );
}

#[test]
fn without_a_receiver_the_service_stays_read_only() {
    let (out, _) = with_service(
        |stack| async move { exchange(stack, &put_head(10), false).await },
        30_000,
    );
    let response = out.expect("finished").expect("answered");
    assert_eq!(status_of(&response), Some(405));
    let text = String::from_utf8_lossy(&response);
    assert!(text.contains("Allow: GET, HEAD"), "{text}");
}
