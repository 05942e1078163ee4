//! The host sensor over TCP (M10): a listener, the served connection and
//! a standby one, each message framed by the firmware's own framer.

use super::{endpoint, Node, SensorOptions};
use rri_firmware::engine::{Application, Clock};
use rri_firmware::properties::{DeviceSet, RobotSet};
use rri_firmware::tcp::{Framer, Stall, StallGuard};
use std::io::{self, ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Sender;
use std::time::Duration;

pub(super) fn serve<R: RobotSet, D: DeviceSet, A: Application<R, D>, const RX: usize>(
    sensor: &mut Node<'_, R, D, A>,
    opts: &SensorOptions,
    stop: &AtomicBool,
    ready: Option<Sender<SocketAddr>>,
) -> io::Result<()> {
    let listener = TcpListener::bind(opts.listen)?;
    listener.set_nonblocking(true)?;
    let local = listener.local_addr()?;
    let _ = writeln!(
        sensor.log,
        "listening on tcp {local} (device {})",
        opts.device_name
    );
    // S2: CONNECTED once it listens, as over UDP (and on the boards).
    sensor.engine.listening();
    sensor.note_state();
    if let Some(tx) = ready {
        let _ = tx.send(local);
    }
    // A connection that arrived while another was served (M10: it may
    // close a stalled one).
    let mut waiting: Option<(TcpStream, SocketAddr)> = None;
    while !stop.load(Ordering::Relaxed) {
        let next = match waiting.take() {
            Some(c) => Some(c),
            None => match listener.accept() {
                Ok(c) => Some(c),
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::Interrupted) => {
                    None
                }
                // The peer gave up between SYN and accept.
                Err(e) if e.kind() == ErrorKind::ConnectionAborted => None,
                Err(e) => return Err(e),
            },
        };
        match next {
            Some((stream, peer)) => {
                let _ = writeln!(sensor.log, "connection from {peer}");
                sensor.engine.listening();
                sensor.note_state();
                connection::<R, D, A, RX>(sensor, &listener, &mut waiting, stream, peer, stop);
                sensor.engine.peer_closed();
                sensor.note_state();
            }
            None => {
                let _ = sensor.poll();
                std::thread::sleep(Duration::from_micros(500));
            }
        }
    }
    Ok(())
}

/// Why a connection ended, for the log.
pub(super) enum End {
    Stop,
    PeerClosed,
    Framing,
    SendFailed(io::Error),
    ReadFailed(io::Error),
    Stalled(Stall),
}

/// One TCP connection: framed messages in (M10), replies out, until the
/// peer closes, a framing error, a failed send, a stall (M10), or stop.
/// Whatever happens on the connection ends at most the connection.
pub(super) fn connection<R: RobotSet, D: DeviceSet, A: Application<R, D>, const RX: usize>(
    sensor: &mut Node<'_, R, D, A>,
    listener: &TcpListener,
    waiting: &mut Option<(TcpStream, SocketAddr)>,
    stream: TcpStream,
    peer: SocketAddr,
    stop: &AtomicBool,
) {
    let end = serve_connection::<R, D, A, RX>(sensor, listener, waiting, stream, peer, stop);
    let why = match end {
        End::Stop | End::PeerClosed => return,
        End::Framing => format!("framing error: message longer than {RX} bytes"),
        End::SendFailed(e) => format!("reply not sent ({e})"),
        End::ReadFailed(e) => format!("read failed ({e})"),
        End::Stalled(Stall::Incomplete) => format!(
            "an incomplete message held longer than TimeOut ({} ms)",
            sensor.engine.config().timeout_ms
        ),
        End::Stalled(Stall::SilentWhileWaiting) => format!(
            "silent for TimeOut ({} ms) while another connection waits",
            sensor.engine.config().timeout_ms
        ),
    };
    let _ = writeln!(sensor.log, "closing the connection from {peer}: {why}");
}

pub(super) fn serve_connection<R: RobotSet, D: DeviceSet, A: Application<R, D>, const RX: usize>(
    sensor: &mut Node<'_, R, D, A>,
    listener: &TcpListener,
    waiting: &mut Option<(TcpStream, SocketAddr)>,
    mut stream: TcpStream,
    peer: SocketAddr,
    stop: &AtomicBool,
) -> End {
    let timeout = Duration::from_millis(u64::from(sensor.engine.config().timeout_ms.max(1)));
    let setup = stream
        .set_nonblocking(false)
        .and_then(|()| stream.set_read_timeout(Some(Duration::from_micros(500))))
        // A peer that stops reading its replies must not block the sensor.
        .and_then(|()| stream.set_write_timeout(Some(timeout)))
        .and_then(|()| stream.set_nodelay(true));
    if let Err(e) = setup {
        return End::ReadFailed(e);
    }
    let Some(from) = endpoint(peer) else {
        return End::PeerClosed;
    };
    let mut framer = Framer::<RX>::new();
    let mut guard = StallGuard::new(sensor.engine.config().timeout_ms, sensor.clock.now());
    let mut chunk = [0u8; 4096];
    let mut replies: Vec<Vec<u8>> = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        match stream.read(&mut chunk) {
            Ok(0) => return End::PeerClosed,
            Ok(n) => {
                let received = sensor.clock.now();
                let mut completed = false;
                let framed = framer.push(&chunk[..n], |m| {
                    completed = true;
                    if let Some((_, len)) = sensor.message(from, m, received) {
                        replies.push(sensor.out[..len].to_vec());
                    }
                });
                for r in replies.drain(..) {
                    if let Err(e) = stream.write_all(&r) {
                        sensor.engine.send_failed();
                        return End::SendFailed(e);
                    }
                }
                if framed.is_err() {
                    sensor.engine.framing_error();
                    return End::Framing;
                }
                guard.received(received, completed, framer.pending());
            }
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted
                ) => {}
            Err(e) if matches!(e.kind(), ErrorKind::ConnectionReset | ErrorKind::BrokenPipe) => {
                return End::PeerClosed
            }
            Err(e) => return End::ReadFailed(e),
        }
        if waiting.is_none() {
            if let Ok(c) = listener.accept() {
                let _ = writeln!(sensor.log, "connection from {} waits", c.1);
                *waiting = Some(c);
            }
        }
        if let Some(stall) = guard.check(sensor.clock.now(), waiting.is_some()) {
            sensor.engine.stalled();
            return End::Stalled(stall);
        }
        if let Some((_, len)) = sensor.poll() {
            if let Err(e) = stream.write_all(&sensor.out[..len]) {
                sensor.engine.send_failed();
                return End::SendFailed(e);
            }
        }
    }
    End::Stop
}
