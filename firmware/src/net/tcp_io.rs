//! The TCP cycle task's buffers and socket steps (M10): writing a reply
//! whole within its time limit, feeding the framer, listening and telling
//! a connection that carries data; `super` runs the served and standby
//! connections with them.

use crate::engine::Engine;
use crate::properties::{DeviceSet, RobotSet};
use crate::tcp::Framer;
use embassy_net::tcp::{State as TcpState, TcpSocket};
use embassy_time::Duration;

/// Buffers of the TCP cycle task: two sockets (the served connection and
/// a standby that listens, so a controller that reconnects is seen; M10)
/// with `SOCK` bytes each way, the framer's `RX` =
/// `layout::MAX_RECEIVE_LEN`, the reply's `TX` = `layout::MAX_SEND_LEN`.
pub struct TcpBuffers<const SOCK: usize, const RX: usize, const TX: usize> {
    pub(super) rx: [[u8; SOCK]; 2],
    pub(super) tx: [[u8; SOCK]; 2],
    pub(super) chunk: [u8; 512],
    pub(super) framer: Framer<RX>,
    pub(super) reply: [u8; TX],
}

impl<const SOCK: usize, const RX: usize, const TX: usize> Default for TcpBuffers<SOCK, RX, TX> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const SOCK: usize, const RX: usize, const TX: usize> TcpBuffers<SOCK, RX, TX> {
    /// All buffers zeroed and the framer empty; `const`, so it can
    /// initialise a `static`. Does not compile when a socket's `SOCK`
    /// bytes cannot hold a whole reply (`TX`).
    pub const fn new() -> Self {
        const {
            assert!(
                SOCK >= TX,
                "a TCP socket's send buffer must hold a whole reply (MAX_SEND_LEN)"
            );
        }
        TcpBuffers {
            rx: [[0; SOCK]; 2],
            tx: [[0; SOCK]; 2],
            chunk: [0; 512],
            framer: Framer::new(),
            reply: [0; TX],
        }
    }
}

/// Writes all of `bytes`; `false` when the connection broke. A write of
/// nothing is taken for a broken connection, and so would a count beyond
/// the bytes given (never returned), rather than an empty remainder.
async fn write_all(socket: &mut TcpSocket<'_>, mut bytes: &[u8]) -> bool {
    while !bytes.is_empty() {
        let written = socket.write(bytes).await.ok().filter(|&n| n > 0);
        match written.and_then(|n| bytes.get(n..)) {
            Some(rest) => bytes = rest,
            None => return false,
        }
    }
    true
}

/// Writes the reply the engine wrote to the first `len` bytes of `reply`
/// within `limit`. `false`, counted as a send error
/// ([`Engine::send_failed`]), when the connection broke or the peer
/// stopped reading for that long (its window and our send buffer full);
/// the caller then closes the connection, so a controller that stops
/// reading cannot block the device. A `len` beyond the buffer (the engine
/// never returns one) is counted the same way, never written cut.
pub(super) async fn send_reply<R: RobotSet, D: DeviceSet>(
    socket: &mut TcpSocket<'_>,
    engine: &mut Engine<R, D>,
    reply: &[u8],
    len: usize,
    limit: Duration,
) -> bool {
    let sent = match reply.get(..len) {
        Some(bytes) => matches!(
            embassy_time::with_timeout(limit, write_all(socket, bytes)).await,
            Ok(true)
        ),
        None => false,
    };
    if !sent {
        engine.send_failed();
    }
    sent
}

/// Feeds `rest` to the framer (M10): the bytes it did not use and the
/// message it completed, if any; `None` on a framing error. (`feed` never
/// uses more bytes than it was given; a count beyond them would be a
/// framing error too, never an empty remainder.)
pub(super) fn feed<'f, 'r, const N: usize>(
    framer: &'f mut Framer<N>,
    rest: &'r [u8],
) -> Option<(&'r [u8], Option<&'f [u8]>)> {
    let (used, message) = framer.feed(rest).ok()?;
    Some((rest.get(used..)?, message))
}

/// Puts a closed socket in listening mode without waiting for a
/// connection (the first poll of `accept` listens); `false` when the port
/// cannot be listened on.
pub(super) fn listen(socket: &mut TcpSocket<'_>, port: u16) -> bool {
    if socket.state() != TcpState::Closed {
        return true;
    }
    !matches!(
        embassy_futures::poll_once(socket.accept(port)),
        core::task::Poll::Ready(Err(_))
    )
}

/// A connection is established (or its peer has half-closed it).
pub(super) fn connected(socket: &TcpSocket<'_>) -> bool {
    !matches!(
        socket.state(),
        TcpState::Closed | TcpState::Listen | TcpState::SynSent | TcpState::SynReceived
    )
}
