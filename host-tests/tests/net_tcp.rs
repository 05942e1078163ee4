//! M10 over real TCP connections: the boards' `Cycle::tcp` on one
//! embassy-net stack, robots on a second stack, one in-memory Ethernet
//! (`memnet`), embassy-time's mock clock: deterministic. Framing, a
//! message longer than the buffer, and the hostile-world defects: a peer
//! that resets while replies are written, a stalled connection, a
//! half-open one, and a controller that merely pauses.

mod memnet;

use embassy_net::tcp::TcpSocket;
use embassy_net::Stack;
use embassy_time::{Duration, Timer};
use host_tests::layouts::anydevice::{self as layout, SensDataMessage};
use memnet::with_tcp_device;
use rri_firmware::codec::decode;
use rri_firmware::engine::{Config, Engine, SensorState};
use rri_firmware::tcp::Framer;
use smoltcp::wire::Ipv4Address;
use std::cell::Cell;
use std::collections::VecDeque;

type DeviceEngine = Engine<layout::RobotProperties, layout::DeviceProperties>;

/// One poll step of the in-memory Ethernet (`memnet`).
const STEP_US: u64 = 50;

/// A short `TimeOut` (the stall rule's clock) so the tests stay quick.
const TIMEOUT_MS: u32 = 100;

fn config() -> Config {
    Config {
        timeout_ms: TIMEOUT_MS,
        ..layout::ENGINE_CONFIG
    }
}

fn message(id: u32) -> String {
    format!(r#"<RobData Id="{id}" Ts="1.0"><Ts_act>1.0</Ts_act></RobData>"#)
}

/// One robot connection with its reply framer.
struct Robot<'a> {
    socket: TcpSocket<'a>,
    framer: Framer<4096>,
    /// Ids of replies read but not yet asked for (one read may carry
    /// several replies).
    pending: VecDeque<u32>,
}

impl<'a> Robot<'a> {
    async fn connect(stack: Stack<'a>, rx: &'a mut [u8], tx: &'a mut [u8]) -> Robot<'a> {
        let mut socket = TcpSocket::new(stack, rx, tx);
        let device = Ipv4Address::from(layout::NETWORK_IPV4.expect("IPv4"));
        socket
            .connect((device, layout::CHANNEL_PORT))
            .await
            .expect("connects");
        Robot {
            socket,
            framer: Framer::new(),
            pending: VecDeque::new(),
        }
    }

    /// Writes all of `bytes`; `false` once the connection is gone.
    async fn write(&mut self, mut bytes: &[u8]) -> bool {
        while !bytes.is_empty() {
            match self.socket.write(bytes).await {
                Ok(0) | Err(_) => return false,
                Ok(n) => bytes = &bytes[n..],
            }
        }
        true
    }

    /// The next reply's Id (M8), `None` once the device has closed.
    async fn reply(&mut self) -> Option<u32> {
        let mut chunk = [0u8; 1024];
        loop {
            if let Some(id) = self.pending.pop_front() {
                return Some(id);
            }
            let n = match self.socket.read(&mut chunk).await {
                Ok(0) | Err(_) => return None,
                Ok(n) => n,
            };
            let pending = &mut self.pending;
            self.framer
                .push(&chunk[..n], |r| {
                    let mut data = layout::SensorData::default();
                    let id = decode::<SensDataMessage>(r, &mut data).expect("decodes").id;
                    pending.push_back(id);
                })
                .expect("replies fit");
        }
    }

    /// Sends message `id` and returns the Id of the reply (M8), `None`
    /// once the device has closed.
    async fn ask(&mut self, id: u32) -> Option<u32> {
        assert!(
            self.write(message(id).as_bytes()).await,
            "message {id} written"
        );
        self.reply().await
    }

    /// Waits until the device closes (reads whatever still comes).
    async fn closed(&mut self) {
        let mut chunk = [0u8; 1024];
        while let Ok(n) = self.socket.read(&mut chunk).await {
            if n == 0 {
                break;
            }
        }
    }
}

/// Milliseconds (mock time) from now until a new connection has message
/// `id` answered: how long the controller waits to be served.
async fn time_to_serve(stack: Stack<'_>, rx: &mut [u8], tx: &mut [u8], id: u32) -> u64 {
    let start = embassy_time::Instant::now();
    let mut robot = Robot::connect(stack, rx, tx).await;
    assert_eq!(robot.ask(id).await, Some(id));
    start.elapsed().as_millis()
}

/// M10: 200 messages, each written in two pieces, all answered with their
/// Id; then a message longer than the receive buffer, a framing error
/// that closes the connection (S2: CLOSED).
#[test]
fn frames_answers_and_closes_on_a_framing_error_m10() {
    let mut engine = DeviceEngine::new(layout::ENGINE_CONFIG);
    let (answered, closed_by_device) = (&Cell::new(0u32), &Cell::new(false));
    let done = with_tcp_device(
        &mut engine,
        &mut (),
        move |stack| async move {
            let (mut rx, mut tx) = ([0u8; 4096], [0u8; 4096]);
            let mut robot = Robot::connect(stack, &mut rx, &mut tx).await;
            for id in 1..=200u32 {
                let msg = message(id);
                let (first, second) = msg.as_bytes().split_at(msg.len() / 2);
                assert!(robot.write(first).await && robot.write(second).await);
                assert_eq!(robot.reply().await, Some(id), "M8 over TCP");
                answered.set(answered.get() + 1);
            }
            let big = format!(
                "<RobData Id=\"999\">{}</RobData>",
                " ".repeat(layout::MAX_RECEIVE_LEN + 10)
            );
            let _ = robot.write(big.as_bytes()).await;
            robot.closed().await;
            closed_by_device.set(true);
        },
        200_000,
    );
    assert!(done, "the robot finished ({} answered)", answered.get());
    assert_eq!(answered.get(), 200);
    assert!(closed_by_device.get());
    let s = engine.stats();
    assert_eq!((s.answered, s.framing_errors, s.closed), (200, 1, 1));
    assert_eq!(engine.state(), SensorState::Closed);
}

/// S1 over TCP: a reply leaves as soon as it is ready, even while the
/// previous one is still unacknowledged. Message 3 reaches the device
/// while reply 2 is in flight; with Nagle's algorithm (the socket
/// default) reply 3 waited for reply 2's ACK, which the robot's stack
/// delays by 10 ms (smoltcp's default): 10,050 µs, two and a half cycles
/// late. Mock time, deterministic.
#[test]
fn a_reply_does_not_wait_for_the_ack_of_the_one_before() {
    let mut engine = DeviceEngine::new(layout::ENGINE_CONFIG);
    let gap_us = &Cell::new(None);
    let done = with_tcp_device(
        &mut engine,
        &mut (),
        move |stack| async move {
            let (mut rx, mut tx) = ([0u8; 4096], [0u8; 4096]);
            let mut robot = Robot::connect(stack, &mut rx, &mut tx).await;
            // Warm: a first exchange, so the connection is established
            // both ways and nothing is in flight.
            assert_eq!(robot.ask(1).await, Some(1));
            // Message 3 one poll step after message 2, in a segment of
            // its own: it reaches the device while reply 2 is in flight.
            robot.socket.set_nagle_enabled(false);
            assert!(robot.write(message(2).as_bytes()).await);
            Timer::after(Duration::from_micros(STEP_US)).await;
            assert!(robot.write(message(3).as_bytes()).await);
            assert_eq!(robot.reply().await, Some(2));
            let first = embassy_time::Instant::now();
            assert_eq!(robot.reply().await, Some(3));
            gap_us.set(Some(first.elapsed().as_micros()));
        },
        200_000,
    );
    assert!(done, "the robot finished");
    let gap = gap_us.get().expect("both replies came");
    assert!(
        gap < 1_000,
        "the second reply came {gap} µs after the first: held for an ACK (Nagle)"
    );
}

/// Defect 3 of the hostile-world issue: a controller that resets its
/// connection while replies are still being written ends that connection
/// only; the next connection is answered.
#[test]
fn a_reset_while_replies_are_written_ends_only_that_connection() {
    let mut engine = DeviceEngine::new(config());
    let second = &Cell::new(None);
    let done = with_tcp_device(
        &mut engine,
        &mut (),
        move |stack| async move {
            let (mut rx, mut tx) = ([0u8; 4096], [0u8; 4096]);
            {
                let mut robot = Robot::connect(stack, &mut rx, &mut tx).await;
                let burst: String = (1..=40).map(message).collect();
                assert!(robot.write(burst.as_bytes()).await);
                Timer::after(Duration::from_micros(300)).await;
                robot.socket.abort();
                let _ = robot.socket.flush().await;
            }
            Timer::after(Duration::from_millis(5)).await;
            let mut robot = Robot::connect(stack, &mut rx, &mut tx).await;
            second.set(robot.ask(41).await);
        },
        100_000,
    );
    assert!(done, "the second connection was served");
    assert_eq!(second.get(), Some(41));
    let s = engine.stats();
    assert!(s.answered >= 1, "{s:?}");
    assert_eq!(s.closed, 1, "the reset connection was closed once");
}

/// Defect 4 (M10): half a message and then nothing no longer locks the
/// device out: the connection is closed once it has held the incomplete
/// message for `TimeOut`, and the controller's next connection, waiting
/// meanwhile, is answered within one `TimeOut`.
#[test]
fn an_incomplete_message_is_closed_after_timeout_and_the_waiting_controller_served_m10() {
    let mut engine = DeviceEngine::new(config());
    let (served_after, stalled_closed) = (&Cell::new(None), &Cell::new(false));
    let done = with_tcp_device(
        &mut engine,
        &mut (),
        move |stack| async move {
            let (mut rx1, mut tx1) = ([0u8; 4096], [0u8; 4096]);
            let (mut rx2, mut tx2) = ([0u8; 4096], [0u8; 4096]);
            let mut stalled = Robot::connect(stack, &mut rx1, &mut tx1).await;
            let msg = message(1);
            assert!(stalled.write(&msg.as_bytes()[..msg.len() / 2]).await);
            served_after.set(Some(time_to_serve(stack, &mut rx2, &mut tx2, 7).await));
            stalled.closed().await;
            stalled_closed.set(true);
        },
        100_000,
    );
    assert!(done);
    assert!(stalled_closed.get(), "the stalled connection was closed");
    let after = served_after.get().expect("served");
    assert!(
        (u64::from(TIMEOUT_MS)..=u64::from(TIMEOUT_MS) + 10).contains(&after),
        "served after {after} ms"
    );
    let s = engine.stats();
    assert_eq!((s.stalled_closed, s.answered), (1, 1));
}

/// Defect 4 (M10): a half-open connection (the controller restarted)
/// whose peer sent whole messages and then nothing is closed once it has
/// been silent for `TimeOut` while the controller's new connection waits.
#[test]
fn a_silent_connection_gives_way_to_a_waiting_one_after_timeout_m10() {
    let mut engine = DeviceEngine::new(config());
    let served_after = &Cell::new(None);
    let done = with_tcp_device(
        &mut engine,
        &mut (),
        move |stack| async move {
            let (mut rx1, mut tx1) = ([0u8; 4096], [0u8; 4096]);
            let (mut rx2, mut tx2) = ([0u8; 4096], [0u8; 4096]);
            let mut old = Robot::connect(stack, &mut rx1, &mut tx1).await;
            assert_eq!(old.ask(1).await, Some(1));
            served_after.set(Some(time_to_serve(stack, &mut rx2, &mut tx2, 2).await));
        },
        100_000,
    );
    assert!(done);
    let after = served_after.get().expect("served");
    assert!(
        after <= u64::from(TIMEOUT_MS) + 10,
        "served after {after} ms"
    );
    let s = engine.stats();
    assert_eq!((s.stalled_closed, s.answered), (1, 2));
}

/// M10: a controller that pauses its stream (`SiSetCyclic` rate 0) with
/// nobody else waiting keeps its connection, however long the pause.
#[test]
fn a_pause_with_nobody_waiting_keeps_the_connection_m10() {
    let mut engine = DeviceEngine::new(Config {
        dry_run: true,
        ..config()
    });
    let answered = &Cell::new(0);
    let done = with_tcp_device(
        &mut engine,
        &mut (),
        move |stack| async move {
            let (mut rx, mut tx) = ([0u8; 4096], [0u8; 4096]);
            let mut robot = Robot::connect(stack, &mut rx, &mut tx).await;
            for id in 1..=3 {
                assert_eq!(robot.ask(id).await, Some(id));
                answered.set(answered.get() + 1);
                Timer::after(Duration::from_millis(5 * u64::from(TIMEOUT_MS))).await;
            }
        },
        100_000,
    );
    assert!(done);
    assert_eq!(answered.get(), 3);
    let s = engine.stats();
    assert_eq!((s.stalled_closed, s.closed, s.answered), (0, 0, 3));
}

/// A controller that keeps sending but stops reading: once its window and
/// the device's send buffer are full, a reply cannot be written for
/// `TimeOut`; that is a counted send error and closes the connection, and
/// the next connection is served (the device is never blocked on it).
#[test]
fn a_peer_that_stops_reading_is_closed_after_timeout() {
    let mut engine = DeviceEngine::new(config());
    let served = &Cell::new(None);
    let done = with_tcp_device(
        &mut engine,
        &mut (),
        move |stack| async move {
            let (mut rx1, mut tx1) = ([0u8; 1024], [0u8; 8192]);
            let (mut rx2, mut tx2) = ([0u8; 4096], [0u8; 4096]);
            let mut deaf = Robot::connect(stack, &mut rx1, &mut tx1).await;
            let burst: String = (1..=60).map(message).collect();
            let _ = deaf.write(burst.as_bytes()).await;
            Timer::after(Duration::from_millis(20)).await;
            served.set(Some(time_to_serve(stack, &mut rx2, &mut tx2, 100).await));
        },
        100_000,
    );
    assert!(done, "the next connection was served");
    let after = served.get().expect("served");
    assert!(
        after <= 2 * u64::from(TIMEOUT_MS) + 10,
        "served after {after} ms"
    );
    let s = engine.stats();
    assert!(s.send_errors >= 1, "{s:?}");
}

/// S2 on the boards' TCP task: CONNECTED once both sockets listen, before
/// any controller connects (the host sensor does the same).
#[test]
fn s2_connected_while_listening_before_any_controller() {
    let mut engine = DeviceEngine::new(config());
    assert_eq!(engine.state(), SensorState::Undefined);
    let done = with_tcp_device(
        &mut engine,
        &mut (),
        |_stack| async { Timer::after(Duration::from_millis(5)).await },
        10_000,
    );
    assert!(done, "the robot's wait ended");
    assert_eq!(engine.state(), SensorState::Connected);
    assert_eq!(engine.stats().closed, 0);
}
