//! The host sensor over UDP: one socket, every datagram through the
//! engine, every reply sent back to where the engine says.

use super::{endpoint, Node, SensorOptions};
use rri_firmware::engine::{Application, Clock, Endpoint};
use rri_firmware::properties::{DeviceSet, RobotSet};
use std::io::{self, ErrorKind};
use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Sender;
use std::time::Duration;

pub(super) fn serve<R: RobotSet, D: DeviceSet, A: Application<R, D>>(
    sensor: &mut Node<'_, R, D, A>,
    opts: &SensorOptions,
    stop: &AtomicBool,
    ready: Option<Sender<SocketAddr>>,
) -> io::Result<()> {
    let socket = UdpSocket::bind(opts.listen)?;
    socket.set_read_timeout(Some(Duration::from_micros(500)))?;
    let local = socket.local_addr()?;
    let _ = writeln!(
        sensor.log,
        "listening on udp {local} (device {})",
        opts.device_name
    );
    sensor.engine.listening();
    sensor.note_state();
    if let Some(tx) = ready {
        let _ = tx.send(local);
    }
    // One byte more than the layout allows, so a longer datagram is seen
    // as too long rather than silently cut.
    let mut buf = vec![0u8; R::MAX_RECEIVE_LEN + 1];
    while !stop.load(Ordering::Relaxed) {
        match socket.recv_from(&mut buf) {
            Ok((n, from)) => {
                let received = sensor.clock.now();
                let Some(from) = endpoint(from) else { continue };
                if let Some((to, len)) = sensor.message(from, buf.get(..n).unwrap_or(&[]), received)
                {
                    send(sensor, &socket, to, len);
                }
            }
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted
                ) => {}
            // ICMP port unreachable from a robot that went away.
            Err(e) if e.kind() == ErrorKind::ConnectionReset => {}
            Err(e) => return Err(e),
        }
        if let Some((to, len)) = sensor.poll() {
            send(sensor, &socket, to, len);
        }
    }
    Ok(())
}

/// Sends the reply in `sensor.out`; a failure is counted and logged, never
/// fatal (a controller that went away, a full socket buffer).
pub(super) fn send<R: RobotSet, D: DeviceSet, A: Application<R, D>>(
    sensor: &mut Node<'_, R, D, A>,
    socket: &UdpSocket,
    to: Endpoint,
    len: usize,
) {
    let to_addr = SocketAddr::from((to.ip, to.port));
    if let Err(e) = socket.send_to(&sensor.out[..len], to_addr) {
        sensor.engine.send_failed();
        if sensor.engine.stats().send_errors == 1 {
            let _ = writeln!(
                sensor.log,
                "reply to {to_addr} not sent ({e}); counted as send-errors, the sensor goes on"
            );
        }
    }
}
