//! The diagnostics on a board (feature `net`): each connection slot is
//! two halves joined by two byte pipes.
//!
//! - [`connection`] runs on the urgent executor beside the cycle, because
//!   embassy-net's stack may only be used where it runs (it is not
//!   `Send`). It accepts a connection on the port and moves bytes, at
//!   most [`PIECE`] per turn: request bytes into the slot's inbound pipe,
//!   response bytes from its outbound pipe into the socket. Nothing else:
//!   a turn of it costs the cycle a copy of a few hundred bytes.
//! - [`service`] runs on the background executor, below the cycle: it
//!   parses the request ([`super::http::Parser`]), copies the status once
//!   and renders the response window by window ([`super::Window`]) into
//!   the outbound pipe.
//!
//! Memory: everything here is plain data the board may put wherever it
//! likes ([`Slot`], [`SocketHalf`], [`ServiceHalf`], [`Renderer`] and the
//! socket buffers are each built once and handed out as `&'static`); the
//! boards keep them out of the DTCM (`.diag_ram`), so that the service
//! costs the stack and the cycle's statics only the tasks' small futures
//! and the network stack's socket state.
//!
//! Bounds, so that no client can hold a slot or the renderer for long:
//! the request must arrive within [`REQUEST_TIMEOUT`] of the connection
//! (408 otherwise), the response must be taken within
//! [`RESPONSE_TIMEOUT`] and without a pause of [`STALL_TIMEOUT`] (the
//! connection is aborted otherwise: a response holds the one renderer
//! while its client reads), one
//! request per connection, and the closing handshake gets
//! [`CLOSE_TIMEOUT`]. With every slot busy, smoltcp (which has no listen
//! backlog) answers a new connection with a reset: the client is refused
//! at once, not queued.

use super::http::Parser;
use super::Status;
use embassy_futures::select::{select, select3, Either, Either3};
use embassy_net::tcp::{State as TcpState, TcpSocket};
use embassy_net::Stack;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::pipe::Pipe;
use embassy_sync::signal::Signal;
use embassy_time::{with_timeout, Duration, Instant, Timer};
use rri_firmware::fragments::Link;

/// Connections served at once.
pub const SLOTS: usize = 2;
/// Each slot's socket receive buffer (a request's head is read through it
/// in pieces).
pub const SOCKET_RX: usize = 256;
/// Each slot's socket send buffer.
pub const SOCKET_TX: usize = 1024;
/// The outbound pipe's size: response bytes on their way to the socket.
pub const CHUNK: usize = 256;
/// Bytes copied through a pipe at a time: a pipe copies under a critical
/// section, which holds off every interrupt, the cycle's included.
pub const PIECE: usize = 64;
/// The rendering window: bytes of a response rendered per pass.
pub const WINDOW: usize = 1024;
/// The whole request head must arrive within this (408 otherwise).
pub const REQUEST_TIMEOUT: Duration = Duration::from_secs(2);
/// The whole response must be taken within this (abort otherwise).
pub const RESPONSE_TIMEOUT: Duration = Duration::from_secs(5);
/// The closing handshake may take this long (abort otherwise).
pub const CLOSE_TIMEOUT: Duration = Duration::from_secs(1);
/// A response holds the one renderer while its bytes wait for the client;
/// a client that takes none for this long loses its connection, so that
/// it cannot keep the other slots' responses waiting.
pub const STALL_TIMEOUT: Duration = Duration::from_secs(1);
/// A whole upload (`PUT /firmware`), from the connection to the response,
/// must take no longer (the connection is aborted otherwise, and the
/// upload abandoned): a 1 MiB image at 16 KiB/s.
pub const UPLOAD_TIMEOUT: Duration = Duration::from_secs(64);
/// An upload whose client sends no byte for this long is abandoned.
pub const BODY_STALL: Duration = Duration::from_secs(5);

type Cs = CriticalSectionRawMutex;

/// One connection slot: what the two halves share.
pub struct Slot {
    inbound: Pipe<Cs, CHUNK>,
    outbound: Pipe<Cs, CHUNK>,
    /// A connection was accepted (network half → service).
    opened: Signal<Cs, ()>,
    /// The service has written the whole response (or gave up).
    finished: Signal<Cs, ()>,
    /// The client went away or did not read (network half → service).
    gone: Signal<Cs, ()>,
    /// The client closed its side and every byte it sent is in the
    /// inbound pipe (network half → service): a body still short will
    /// never be whole.
    ended: Signal<Cs, ()>,
    /// The service has its verdict: request bytes are no longer needed.
    heard: core::sync::atomic::AtomicBool,
    /// The service gave the response up (the client stalled): the network
    /// half aborts the connection instead of closing it.
    abandoned: core::sync::atomic::AtomicBool,
    /// An upload is arriving: the connection may last [`UPLOAD_TIMEOUT`].
    long: core::sync::atomic::AtomicBool,
}

impl Default for Slot {
    fn default() -> Self {
        Self::new()
    }
}

impl Slot {
    /// An idle slot (`const`, for a `static`).
    pub const fn new() -> Self {
        Slot {
            inbound: Pipe::new(),
            outbound: Pipe::new(),
            opened: Signal::new(),
            finished: Signal::new(),
            gone: Signal::new(),
            ended: Signal::new(),
            heard: core::sync::atomic::AtomicBool::new(false),
            abandoned: core::sync::atomic::AtomicBool::new(false),
            long: core::sync::atomic::AtomicBool::new(false),
        }
    }
}

/// The network half's own buffers: a chunk on its way to the socket, and
/// request bytes on their way to the inbound pipe.
pub struct SocketHalf {
    chunk: [u8; PIECE],
    inbound: Inbound,
}

impl Default for SocketHalf {
    fn default() -> Self {
        Self::new()
    }
}

impl SocketHalf {
    /// Empty.
    pub const fn new() -> Self {
        SocketHalf {
            chunk: [0; PIECE],
            inbound: Inbound {
                bytes: [0; 64],
                len: 0,
                eof: false,
            },
        }
    }
}

/// The service half's own state: the request parser and a read buffer.
pub struct ServiceHalf {
    parser: Parser,
    buf: [u8; 64],
}

impl Default for ServiceHalf {
    fn default() -> Self {
        Self::new()
    }
}

impl ServiceHalf {
    /// Empty.
    pub const fn new() -> Self {
        ServiceHalf {
            parser: Parser::new(),
            buf: [0; 64],
        }
    }
}

/// What the service renders with: one status copy and one window, shared
/// by every slot (a response is rendered whole before the next starts).
pub struct Renderer {
    status: Option<Status>,
    window: &'static mut [u8; WINDOW],
}

impl Renderer {
    /// Renders through `window` (the board keeps it out of the DTCM).
    pub fn new(window: &'static mut [u8; WINDOW]) -> Self {
        Renderer {
            status: None,
            window,
        }
    }
}

/// Counters of the service, for the tests and the log.
#[derive(Default)]
pub struct ServiceStats {
    /// Connections accepted.
    pub accepted: core::sync::atomic::AtomicU32,
    /// Responses sent whole (any status).
    pub responses: core::sync::atomic::AtomicU32,
    /// Connections aborted: the client did not read, or vanished.
    pub aborted: core::sync::atomic::AtomicU32,
}

impl ServiceStats {
    /// All zero (`const`, for a `static`).
    pub const fn new() -> Self {
        ServiceStats {
            accepted: core::sync::atomic::AtomicU32::new(0),
            responses: core::sync::atomic::AtomicU32::new(0),
            aborted: core::sync::atomic::AtomicU32::new(0),
        }
    }
}

/// What a connection's network half answers to besides its slot: the
/// service's counters, and the cycle's link (its hold says when bytes
/// moved now would be on a reply's path).
#[derive(Clone, Copy)]
pub struct Guest<'a> {
    /// The service's counters.
    pub stats: &'a ServiceStats,
    /// The fragment guard's link to the cycle.
    pub cycle: &'a Link,
}

/// Waits while the cycle works on a robot message or its reply waits to
/// leave (the fragment guard's hold, [`Link::when_free`]): this task runs
/// on the cycle's executor, and a copy into the socket then could run
/// between the message and its reply, whenever the executor picked it
/// before the network runner. Woken when the hold ends (no timer: a
/// guest that polled would itself run in that window); outside a hold it
/// costs one look.
async fn after_the_reply(cycle: &Link) {
    core::future::poll_fn(|cx| {
        if cycle.when_free(cx.waker()) {
            core::task::Poll::Ready(())
        } else {
            core::task::Poll::Pending
        }
    })
    .await
}

fn bump(c: &core::sync::atomic::AtomicU32) {
    c.fetch_add(1, core::sync::atomic::Ordering::Relaxed);
}

/// The network half of a slot, forever: accept on `port`, move bytes
/// between the socket and the slot's pipes, close. Runs on the executor
/// the network stack runs on.
pub async fn connection(
    stack: Stack<'_>,
    port: u16,
    slot: &Slot,
    half: &mut SocketHalf,
    guest: Guest<'_>,
    rx: &mut [u8],
    tx: &mut [u8],
) -> ! {
    let Guest { stats, cycle } = guest;
    let mut socket = TcpSocket::new(stack, rx, tx);
    loop {
        if socket.accept(port).await.is_err() {
            socket.abort();
            Timer::after(Duration::from_millis(100)).await;
            continue;
        }
        bump(&stats.accepted);
        slot.inbound.clear();
        slot.outbound.clear();
        slot.finished.reset();
        slot.gone.reset();
        slot.ended.reset();
        slot.heard
            .store(false, core::sync::atomic::Ordering::Relaxed);
        slot.abandoned
            .store(false, core::sync::atomic::Ordering::Relaxed);
        slot.long
            .store(false, core::sync::atomic::Ordering::Relaxed);
        slot.opened.signal(());
        half.inbound.len = 0;
        half.inbound.eof = false;
        let ended = serve_connection(&mut socket, slot, half, cycle).await;
        if ended.served {
            bump(&stats.responses);
            // Our FIN after the response; the client's in return. What the
            // socket still holds (the response's tail and our FIN) is
            // acknowledged before the socket is let go (issue 42 #10): a
            // client that half-closed after its request has sent its FIN
            // already, so the wait for it ended at once, and the abort
            // below dropped the unsent tail (a body shorter than its
            // Content-Length, then a reset).
            socket.close();
            let _ = with_timeout(CLOSE_TIMEOUT, async {
                let _ = socket.flush().await;
                closed(&mut socket).await
            })
            .await;
        } else {
            bump(&stats.aborted);
            slot.gone.signal(());
            if !ended.service_done {
                // The service stops at its next step; wait for it so the
                // pipes are quiet before the next connection.
                slot.finished.wait().await;
            }
        }
        socket.abort();
        let _ = socket.flush().await;
    }
}

/// Waits until the socket is closed (or in TIME-WAIT).
async fn closed(socket: &mut TcpSocket<'_>) {
    let mut bin = [0u8; 32];
    while !matches!(socket.state(), TcpState::Closed | TcpState::TimeWait) {
        // Reading what the client still sends (it must not be left
        // unread) also wakes us when its FIN comes.
        match select(
            socket.read(&mut bin),
            Timer::after(Duration::from_millis(50)),
        )
        .await
        {
            Either::First(Ok(0)) | Either::First(Err(_)) => return,
            _ => {}
        }
    }
}

/// How a connection ended.
struct Ended {
    /// The whole response went out.
    served: bool,
    /// The service said it was done (so it will not touch the pipes
    /// again until the next connection).
    service_done: bool,
}

/// Moves bytes until the service has written everything and it has left
/// the pipes, or the client went away, stopped reading or ran out of
/// time.
async fn serve_connection(
    socket: &mut TcpSocket<'_>,
    slot: &Slot,
    half: &mut SocketHalf,
    cycle: &Link,
) -> Ended {
    let opened = Instant::now();
    let SocketHalf { chunk, inbound } = half;
    let mut service_done = false;
    loop {
        if service_done && slot.outbound.is_empty() {
            return Ended {
                served: !slot.abandoned.load(core::sync::atomic::Ordering::Relaxed),
                service_done,
            };
        }
        after_the_reply(cycle).await;
        let deadline = opened
            + if slot.long.load(core::sync::atomic::Ordering::Relaxed) {
                UPLOAD_TIMEOUT
            } else {
                REQUEST_TIMEOUT + RESPONSE_TIMEOUT
            };
        // One of: request bytes moved, response bytes ready, the service
        // done; or the connection's time is up.
        let step = select3(
            read_or_forward(socket, slot, inbound),
            slot.outbound.read(chunk.as_mut_slice()),
            async {
                if service_done {
                    core::future::pending::<()>().await
                } else {
                    slot.finished.wait().await
                }
            },
        );
        let alive = match select(step, Timer::at(deadline)).await {
            Either::Second(()) => false,
            Either::First(Either3::First(alive)) => alive,
            Either::First(Either3::Second(n)) => {
                // Bounded like every other step: a client that takes no
                // bytes for STALL_TIMEOUT loses the connection.
                let bytes = chunk.get(..n).unwrap_or(&[]);
                after_the_reply(cycle).await;
                let limit = deadline.min(Instant::now() + STALL_TIMEOUT);
                matches!(
                    select(write_all(socket, bytes), Timer::at(limit)).await,
                    Either::First(true)
                )
            }
            Either::First(Either3::Third(())) => {
                service_done = true;
                true
            }
        };
        if !alive {
            return Ended {
                served: false,
                service_done,
            };
        }
    }
}

/// Request bytes between the socket and the inbound pipe.
struct Inbound {
    bytes: [u8; 64],
    len: usize,
    /// The client closed its side (after its request, a client may).
    eof: bool,
}

/// One step of the request direction: forwards pending bytes into the
/// inbound pipe, or reads more from the socket (discarded once the
/// service has its verdict). `false` when the connection was reset.
async fn read_or_forward(socket: &mut TcpSocket<'_>, slot: &Slot, inbound: &mut Inbound) -> bool {
    let heard = slot.heard.load(core::sync::atomic::Ordering::Relaxed);
    if heard {
        inbound.len = 0;
    }
    if inbound.len > 0 {
        let n = slot
            .inbound
            .write(inbound.bytes.get(..inbound.len).unwrap_or(&[]))
            .await
            .min(inbound.len);
        inbound.bytes.copy_within(n..inbound.len, 0);
        inbound.len -= n;
        return true;
    }
    if inbound.eof {
        // Nothing more will come, and all of it is in the pipe; the other
        // directions decide.
        slot.ended.signal(());
        core::future::pending::<()>().await;
    }
    match socket.read(inbound.bytes.as_mut_slice()).await {
        Ok(0) => {
            inbound.eof = true;
            true
        }
        Ok(n) => {
            inbound.len = n.min(inbound.bytes.len());
            true
        }
        Err(_) => false,
    }
}

/// Writes all of `bytes`; `false` when the connection broke.
async fn write_all(socket: &mut TcpSocket<'_>, mut bytes: &[u8]) -> bool {
    while !bytes.is_empty() {
        match socket.write(bytes).await {
            Ok(n) if n > 0 => match bytes.get(n..) {
                Some(rest) => bytes = rest,
                None => return false,
            },
            _ => return false,
        }
    }
    true
}

mod desk;
mod service;
#[cfg(rri_update)]
mod upload;
pub use desk::Desk;
pub use service::service;
