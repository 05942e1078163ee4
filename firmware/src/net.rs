//! The transport tasks every board runs (feature `net`): an `embassy-net`
//! socket on the channel port (UDP, or TCP with M10 framing), handing each
//! robot message to the cycle engine and its reply back to the sender. The board supplies the
//! network stack (its Ethernet driver) and the clock; nothing here names a
//! chip, and the host tests run this very code over an in-memory Ethernet.

use crate::engine::{Application, Clock, Endpoint, Engine, Instant, Outcome};
use crate::fragments::Link;
use crate::properties::{DeviceSet, RobotSet};
use crate::tcp::StallGuard;
use embassy_futures::select::{select, Either};
use embassy_net::tcp::TcpSocket;
use embassy_net::udp::{PacketMetadata, RecvError, UdpSocket};
use embassy_net::{IpAddress, IpEndpoint, Stack};
use embassy_time::{Duration, Timer};

/// The device clock over `embassy-time` (microseconds since boot).
#[derive(Clone, Copy, Debug, Default)]
pub struct EmbassyClock;

impl Clock for EmbassyClock {
    fn now(&self) -> Instant {
        Instant(embassy_time::Instant::now().as_micros())
    }
}

/// How often the engine's time-driven work runs (TimeOut supervision,
/// periodic sends): well inside the 4 ms robot cycle.
pub const POLL_INTERVAL: Duration = Duration::from_micros(500);

/// Socket queue depth: datagrams waiting in each direction (the bytes of
/// `QUEUE` longest messages each way).
pub const QUEUE: usize = 4;

/// Robot datagrams the UDP socket can hold at once, whatever their size
/// (within the `QUEUE` × `MAX_RECEIVE_LEN` bytes): a controller with
/// several `SiSetCyclic` sends one message per property in the same cycle
/// (M11), so a burst of every robot property must fit. With room for only
/// `QUEUE` (4), a QEMU board sent 4 properties at once lost 125 of 3,439
/// messages in 10 s; with this, none.
pub const RX_PACKETS: usize = crate::properties::MAX_PROPERTIES;

/// IPv4 + UDP headers: what a datagram adds to its payload on the wire.
const IPV4_UDP_HEADERS: usize = 20 + 8;

/// What the board's firmware learns of each turn of the cycle loop, after
/// the reply (if any) has been queued: publish a snapshot for the watchers,
/// record timings. Everything here runs after the answer, so nothing a
/// monitor does delays it.
pub trait Monitor<R: RobotSet, D: DeviceSet> {
    /// A free-running counter read just before and just after the engine's
    /// work on a message (bench builds read the board's cycle counter).
    fn count(&self) -> u32 {
        0
    }
    /// The robot message `message` from `from` was handled with
    /// `outcome`; `counts` are [`Monitor::count`] before and after the
    /// engine.
    fn message(
        &mut self,
        _engine: &Engine<R, D>,
        _message: &[u8],
        _from: Endpoint,
        _outcome: &Outcome,
        _counts: (u32, u32),
    ) {
    }
    /// The engine's time-driven work ran.
    fn polled(&mut self, _engine: &Engine<R, D>) {}
}

/// No monitor.
impl<R: RobotSet, D: DeviceSet> Monitor<R, D> for () {}

/// Buffers of the UDP cycle task, all sized by the generated layout:
/// `RX` = `layout::MAX_RECEIVE_LEN`, `TX` = `layout::MAX_SEND_LEN`.
///
/// Only bytes, all zero: a `static` of it goes to `.bss` and costs no
/// flash. (The sockets' packet metadata, whose empty value is not all
/// zeros, lives in the cycle task itself: in a static beside the bytes it
/// would pull the whole 25 KB into `.data`, i.e. into flash.)
///
/// Each starts where a UDP payload sits in a frame ([`AsInFrame`]).
pub struct UdpBuffers<const RX: usize, const TX: usize> {
    rx: AsInFrame<[[u8; RX]; QUEUE]>,
    tx: AsInFrame<[[u8; TX]; QUEUE]>,
    datagram: AsInFrame<[u8; RX]>,
    reply: AsInFrame<[u8; TX]>,
}

/// `T` two bytes past a 4-byte boundary: where a UDP payload sits in an
/// Ethernet frame that starts on one (42 bytes in; every driver's frame
/// buffer here does, and so do the fragment guard's). A datagram's payload
/// is copied from its frame into the socket's ring (smoltcp starts each
/// datagram that comes to an empty ring at the ring's start), from there
/// into the cycle's buffer, and the reply the other way; `memcpy` with
/// both ends aligned alike costs a third of a copy whose ends are not
/// (Thumb-2: 3,855 against 12,540 instructions for 3,557 bytes, `cargo
/// qemu-bench`).
#[repr(C, align(4))]
pub struct AsInFrame<T> {
    lead: [u8; 2],
    /// The bytes.
    pub bytes: T,
}

impl<T> AsInFrame<T> {
    /// `bytes`, placed as in a frame.
    pub const fn new(bytes: T) -> Self {
        AsInFrame {
            lead: [0; 2],
            bytes,
        }
    }
}

impl<const RX: usize, const TX: usize> Default for UdpBuffers<RX, TX> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const RX: usize, const TX: usize> UdpBuffers<RX, TX> {
    /// All buffers zeroed; `const`, so it can initialise a `static`. Does
    /// not compile when the layout's longest reply does not fit smoltcp's
    /// IPv4 fragmentation buffer (then raise
    /// `SMOLTCP_FRAGMENTATION_BUFFER_SIZE`). Robot messages longer than a
    /// frame are reassembled in front of the stack, in buffers sized by the
    /// layout ([`crate::fragments`]).
    pub const fn new() -> Self {
        // A long reply leaves in IPv4 fragments: smoltcp's buffer for them
        // (a cargo feature of `smoltcp` in firmware/Cargo.toml, or
        // SMOLTCP_FRAGMENTATION_BUFFER_SIZE at build time) must hold it.
        const {
            assert!(
                TX + IPV4_UDP_HEADERS <= smoltcp::config::FRAGMENTATION_BUFFER_SIZE,
                "the layout's MAX_SEND_LEN does not fit smoltcp's IPv4 fragmentation buffer: raise SMOLTCP_FRAGMENTATION_BUFFER_SIZE"
            );
        }
        UdpBuffers {
            rx: AsInFrame::new([[0; RX]; QUEUE]),
            tx: AsInFrame::new([[0; TX]; QUEUE]),
            datagram: AsInFrame::new([0; RX]),
            reply: AsInFrame::new([0; TX]),
        }
    }
}

fn endpoint(e: IpEndpoint) -> Option<Endpoint> {
    match e.addr {
        IpAddress::Ipv4(ip) => Some(Endpoint::new(ip.octets(), e.port)),
        #[allow(unreachable_patterns)]
        _ => None,
    }
}

fn ip_endpoint(e: Endpoint) -> IpEndpoint {
    IpEndpoint::new(IpAddress::v4(e.ip[0], e.ip[1], e.ip[2], e.ip[3]), e.port)
}

/// Sends the message the engine wrote to the first `len` bytes of `reply`
/// to `to`; a send that fails is counted ([`Engine::send_failed`]). A
/// `len` beyond the buffer (the engine never returns one) is counted the
/// same way, never sent as an empty or cut datagram.
async fn send_datagram<R: RobotSet, D: DeviceSet>(
    socket: &UdpSocket<'_>,
    engine: &mut Engine<R, D>,
    reply: &[u8],
    to: Endpoint,
    len: usize,
) {
    let sent = match reply.get(..len) {
        Some(bytes) => socket.send_to(bytes, ip_endpoint(to)).await.is_ok(),
        None => false,
    };
    if !sent {
        engine.send_failed();
    }
}

/// The cycle task's parts, named once for both transports: the network
/// stack and the channel port it serves, and the engine, application,
/// clock and monitor every robot message goes through. [`Cycle::udp`] or
/// [`Cycle::tcp`] runs it forever.
pub struct Cycle<'c, R: RobotSet, D: DeviceSet, A, C, M> {
    /// The board's network stack.
    pub stack: Stack<'c>,
    /// The channel's port (`layout::CHANNEL_PORT`, from the GSI folder).
    pub port: u16,
    /// The cycle engine.
    pub engine: &'c mut Engine<R, D>,
    /// The user's application (its outputs become the replies).
    pub app: &'c mut A,
    /// The device clock.
    pub clock: &'c C,
    /// Told of every turn of the loop, after the reply.
    pub monitor: &'c mut M,
    /// Shared with the fragment guard in front of the board's driver: the
    /// cycle tells it who the controller is and copies its counters into
    /// the engine's (S5, [`crate::fragments`]).
    pub link: &'c Link,
}

impl<'c, R, D, A, C, M> Cycle<'c, R, D, A, C, M>
where
    R: RobotSet,
    D: DeviceSet,
    A: Application<R, D>,
    C: Clock,
    M: Monitor<R, D>,
{
    /// The stack, the port, and what every turn goes through.
    fn split(self) -> (Stack<'c>, u16, Turn<'c, R, D, A, C, M>) {
        let Cycle {
            stack,
            port,
            engine,
            app,
            clock,
            monitor,
            link,
        } = self;
        (stack, port, Turn::new(engine, app, clock, monitor, link))
    }

    /// Runs the UDP cycle forever: receive → engine → reply, and the
    /// engine's time-driven work every [`POLL_INTERVAL`].
    pub async fn udp<const RX: usize, const TX: usize>(
        self,
        buffers: &mut UdpBuffers<RX, TX>,
    ) -> ! {
        let (stack, port, mut turn) = self.split();
        let UdpBuffers {
            rx,
            tx,
            datagram,
            reply,
        } = buffers;
        let (rx, tx) = (&mut rx.bytes, &mut tx.bytes);
        let (datagram, reply) = (&mut datagram.bytes, &mut reply.bytes);
        let mut rx_meta = [PacketMetadata::EMPTY; RX_PACKETS];
        let mut tx_meta = [PacketMetadata::EMPTY; QUEUE];
        let mut socket = UdpSocket::new(
            stack,
            &mut rx_meta,
            rx.as_flattened_mut(),
            &mut tx_meta,
            tx.as_flattened_mut(),
        );
        let bound = socket.bind(port);
        turn.link.channel_open();
        if bound.is_err() {
            turn.engine.init_failed();
            // S2: ERROR 112600 for good; keep the engine's clock-driven work
            // alive so the state stays readable.
            loop {
                Timer::after(POLL_INTERVAL).await;
            }
        }
        turn.engine.listening();
        loop {
            match select(socket.recv_from(datagram), Timer::after(POLL_INTERVAL)).await {
                Either::First(Ok((len, meta))) => {
                    let received = turn.now();
                    let Some(from) = endpoint(meta.endpoint) else {
                        continue;
                    };
                    // The socket copied `len` bytes into `datagram`; a length
                    // beyond it (never returned) is counted as a datagram
                    // too long for the buffer, not handed on empty or cut.
                    let Some(bytes) = datagram.get(..len) else {
                        turn.engine.datagram_too_long();
                        continue;
                    };
                    let handled = turn.message(from, bytes, received, reply);
                    if let Outcome::Reply { to, len } = handled.outcome {
                        send_datagram(&socket, turn.engine, reply, to, len).await;
                    }
                    turn.done(bytes, from, &handled);
                }
                Either::First(Err(RecvError::Truncated)) => {
                    turn.engine.datagram_too_long();
                    turn.link.turn_done(false);
                }
                Either::Second(()) => {
                    if let Some((to, len)) = turn.poll(reply) {
                        send_datagram(&socket, turn.engine, reply, to, len).await;
                    }
                    turn.polled();
                }
            }
        }
    }

    /// Runs the TCP cycle forever: one controller connection served
    /// at a time (S2: `CONNECTED` when it is accepted, `CLOSED` when it goes),
    /// its byte stream cut into messages (M10), each answered on the same
    /// connection. A message longer than the receive buffer is a framing
    /// error, a reply that cannot be written a counted send error; both close
    /// the connection. A second socket listens meanwhile: a connection that
    /// stalls (M10, [`StallGuard`]) is closed and the waiting one served, so a
    /// half-open connection locks the controller out for `TimeOut` at most.
    pub async fn tcp<const SOCK: usize, const RX: usize, const TX: usize>(
        self,
        buffers: &mut TcpBuffers<SOCK, RX, TX>,
    ) -> ! {
        let (stack, port, mut turn) = self.split();
        let TcpBuffers {
            rx,
            tx,
            chunk,
            framer,
            reply,
        } = buffers;
        let [rx_a, rx_b] = rx;
        let [tx_a, tx_b] = tx;
        let mut a = TcpSocket::new(stack, rx_a, tx_a);
        let mut b = TcpSocket::new(stack, rx_b, tx_b);
        // A reply is one small segment a cycle. Nagle's algorithm (on by
        // default) would hold it while the previous reply is still
        // unacknowledged, that is until the controller's next message or
        // its delayed-ACK timer (40 ms on Linux): several cycles late. A
        // reply leaves as soon as it is ready. smoltcp keeps the setting
        // across the sockets' close and listen.
        a.set_nagle_enabled(false);
        b.set_nagle_enabled(false);
        turn.link.channel_open();
        let (mut served, mut standby) = (&mut a, &mut b);
        let mut listened = false;
        loop {
            // Both sockets listen; serve whichever connects first.
            if !(listen(served, port) && listen(standby, port)) {
                turn.engine.init_failed();
                Timer::after(POLL_INTERVAL).await;
                continue;
            }
            if !listened {
                // S2: CONNECTED once the device listens, before any controller
                // connects (after a peer closes it stays CLOSED until the next).
                turn.engine.listening();
                listened = true;
            }
            if !connected(served) {
                if connected(standby) {
                    core::mem::swap(&mut served, &mut standby);
                } else {
                    Timer::after(POLL_INTERVAL).await;
                    continue;
                }
            }
            let Some(from) = served.remote_endpoint().and_then(endpoint) else {
                served.abort();
                continue;
            };
            turn.engine.listening();
            framer.reset();
            let mut guard = StallGuard::new(turn.engine.config().timeout_ms, turn.now());
            let write_limit =
                Duration::from_millis(u64::from(turn.engine.config().timeout_ms.max(1)));
            'connection: loop {
                match select(served.read(chunk), Timer::after(POLL_INTERVAL)).await {
                    Either::First(Ok(0)) | Either::First(Err(_)) => break 'connection,
                    Either::First(Ok(n)) => {
                        let received = turn.now();
                        let mut completed = false;
                        // `read` filled the first `n` bytes; a count beyond the
                        // chunk (never returned) breaks the connection like a
                        // read error, instead of reading as no bytes.
                        let Some(mut rest) = chunk.get(..n) else {
                            break 'connection;
                        };
                        while !rest.is_empty() {
                            let Some((unused, message)) = feed(framer, rest) else {
                                turn.engine.framing_error();
                                turn.link.turn_done(false);
                                break 'connection;
                            };
                            rest = unused;
                            let Some(message) = message else { continue };
                            completed = true;
                            let handled = turn.message(from, message, received, reply);
                            if let Outcome::Reply { len, .. } = handled.outcome {
                                if !send_reply(served, turn.engine, reply, len, write_limit).await {
                                    break 'connection;
                                }
                            }
                            turn.done(message, from, &handled);
                        }
                        if !completed {
                            // Part of a message: nothing to answer yet.
                            turn.link.turn_done(false);
                        }
                        guard.received(received, completed, framer.pending());
                    }
                    Either::Second(()) => {
                        if let Some((_, len)) = turn.poll(reply) {
                            if !send_reply(served, turn.engine, reply, len, write_limit).await {
                                break 'connection;
                            }
                        }
                        turn.polled();
                    }
                }
                if guard.check(turn.now(), connected(standby)).is_some() {
                    turn.engine.stalled();
                    break 'connection;
                }
            }
            served.abort();
            let _ = served.flush().await;
            turn.engine.peer_closed();
            // The standby (listening, or already holding the next connection)
            // is served next; this one listens again.
            core::mem::swap(&mut served, &mut standby);
        }
    }
}

mod tcp_io;
mod turn;
pub use tcp_io::TcpBuffers;
use tcp_io::{connected, feed, listen, send_reply};
use turn::Turn;
