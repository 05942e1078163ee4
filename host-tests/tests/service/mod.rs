//! The harness the service's in-memory tests share (`net_http.rs`,
//! `net_upload.rs`): the service's slots on one embassy-net stack, a
//! client on another, one in-memory Ethernet (`memnet`), embassy-time's
//! mock clock.
#![allow(dead_code)]

use super::memnet::{mock_clock, net_config, poll_once, MemDriver, DEVICE_MAC, ROBOT_IP};
use embassy_futures::select::{select, Either};
use embassy_net::tcp::TcpSocket;
use embassy_net::{Stack, StackResources};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::mutex::Mutex;
use embassy_time::{Duration, Instant, MockDriver, Timer};
use rri_diag::serve::{
    self, Desk, Renderer, ServiceHalf, ServiceStats, Slot, SocketHalf, SLOTS, WINDOW,
};
use rri_diag::status::{Latency, LatencySource, LinkInfo};
use rri_diag::{Identity, Status};
use rri_firmware::fragments::Link;
use rri_firmware::snapshot::Snapshot;
use smoltcp::wire::Ipv4Address;
use std::pin::pin;

pub const DEVICE_IP: [u8; 4] = [10, 49, 65, 74];
pub const PORT: u16 = 80;

pub fn identity() -> Identity {
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

pub fn fill(out: &mut Option<Status>) {
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
pub fn with_service<F, T>(
    client: impl FnOnce(Stack<'static>) -> F,
    max_ms: u64,
) -> (Option<T>, [u32; 3])
where
    F: std::future::Future<Output = T>,
{
    with_desk(Box::leak(Box::new(Desk::new())), client, max_ms)
}

/// [`with_service`] with `desk` (a receiver installed: uploads taken).
pub fn with_desk<F, T>(
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

pub fn device() -> (Ipv4Address, u16) {
    (Ipv4Address::from(DEVICE_IP), PORT)
}

/// Connects, sends `request`, reads until the device closes (or 20 s of
/// mock time): the whole response, or the connect error.
pub async fn exchange(
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

/// [`exchange`], and how long it took in mock time.
pub async fn timed_exchange(
    stack: Stack<'_>,
    request: &[u8],
    close_after_request: bool,
) -> (Result<Vec<u8>, String>, Duration) {
    let start = Instant::now();
    let r = exchange(stack, request, close_after_request).await;
    (r, start.elapsed())
}

pub fn status_of(response: &[u8]) -> Option<u16> {
    std::str::from_utf8(response.get(9..12)?).ok()?.parse().ok()
}
