//! The flood: datagrams the device must reject, sent from a second port at
//! a fixed period while the simulator drives the controller's cycle.

use super::corpus::hostile;

/// The flood datagram: not a robot message. Slirp shows every host
/// sender with the same address, so the flood cannot come from a foreign
/// address (which the peer filter drops before decoding); from a second
/// port it is admitted, decoded and rejected at its first byte.
pub const FLOOD_LEN: usize = 64;

/// What the flood sends, in turn: the garbage datagram, the two costliest
/// rejected inputs of [`hostile`] (a whole `MAX_RECEIVE_LEN` decoded before
/// the rejection), and a 9,000-byte datagram (IP fragments on the wire,
/// which the device's stack drops). Each is rejected, so the controller's
/// Id accounting (S3) is not disturbed; valid messages from the
/// controller's second port would take the peer over (the peer rule's
/// reconnecting controller), as the engine tests show.
pub fn flood_datagrams() -> Vec<(String, Vec<u8>)> {
    let mut all = vec![("garbage".to_string(), flood_datagram())];
    for input in hostile() {
        if input.name == "rejected at the last byte" || input.name == "truncated" {
            all.push((input.name.clone(), input.with_id(7)));
        }
    }
    all.push(("9000-byte (fragmented)".to_string(), vec![b'<'; 9000]));
    all
}

/// What a flooder did: datagrams sent per kind (in [`flood`]'s order), and
/// replies it received (none may come: every flood datagram is rejected or
/// from a source the device never answers).
#[derive(Clone, Debug, Default)]
pub struct Flooded {
    pub sent: Vec<(String, u64)>,
    pub replies: u64,
}

impl Flooded {
    pub fn total(&self) -> u64 {
        self.sent.iter().map(|(_, n)| n).sum()
    }
}

/// The schedule of a flooder thread: one send every `period`, as close to
/// it as Linux allows. A thread that fell behind (the host stalled it)
/// starts again from now rather than sending a burst to catch up: the
/// flood keeps its rate, which is what the device is measured against.
#[derive(Clone, Copy, Debug)]
pub struct Pacer {
    next: std::time::Instant,
    period: std::time::Duration,
}

impl Pacer {
    /// The first send is due now.
    pub fn new(period: std::time::Duration) -> Self {
        Pacer {
            next: std::time::Instant::now(),
            period,
        }
    }

    /// After a send at `now`: how long to wait for the next one (`None`:
    /// behind schedule, due at once, the schedule restarted from `now`).
    pub fn after_send(&mut self, now: std::time::Instant) -> Option<std::time::Duration> {
        self.next += self.period;
        let wait = self.next.checked_duration_since(now);
        if wait.is_none() {
            self.next = now;
        }
        wait
    }

    /// After a send: sleeps until the next one is due.
    pub fn wait(&mut self) {
        if let Some(wait) = self.after_send(std::time::Instant::now()) {
            std::thread::sleep(wait);
        }
    }
}

/// Reads every datagram waiting on the flooder's non-blocking `socket`:
/// how many there were (replies the device should never have sent).
pub fn drain_replies(socket: &std::net::UdpSocket, buf: &mut [u8]) -> u64 {
    let mut replies = 0;
    while socket.recv_from(buf).is_ok() {
        replies += 1;
    }
    replies
}

/// A flooder thread: sends `datagrams` in turn to `to`, one every `period`,
/// from a socket bound to `from`, until `stop`; counts what it sent and
/// any reply (`cargo qemu-bench`'s second port, `cargo flood`'s stranger
/// and second port).
pub fn flood(
    from: std::net::SocketAddr,
    to: std::net::SocketAddr,
    datagrams: Vec<(String, Vec<u8>)>,
    period: std::time::Duration,
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
) -> Result<std::thread::JoinHandle<Flooded>, String> {
    use std::sync::atomic::Ordering;
    use std::time::Duration;
    let socket = std::net::UdpSocket::bind(from).map_err(|e| format!("bind {from}: {e}"))?;
    socket.set_nonblocking(true).map_err(|e| e.to_string())?;
    Ok(std::thread::spawn(move || {
        let mut sent = vec![0u64; datagrams.len()];
        let mut replies = 0u64;
        let mut buf = [0u8; 2048];
        let mut pacer = Pacer::new(period);
        let mut turn = (0..datagrams.len()).cycle();
        while !stop.load(Ordering::Relaxed) {
            let Some(i) = turn.next() else { break };
            if socket.send_to(&datagrams[i].1, to).is_ok() {
                sent[i] += 1;
            }
            replies += drain_replies(&socket, &mut buf);
            pacer.wait();
        }
        // Late replies.
        std::thread::sleep(Duration::from_millis(200));
        replies += drain_replies(&socket, &mut buf);
        let names = datagrams.into_iter().map(|(n, _)| n);
        Flooded {
            sent: names.zip(sent).collect(),
            replies,
        }
    }))
}

pub fn flood_datagram() -> Vec<u8> {
    let mut d = b"FLOOD not a robot message; ".to_vec();
    d.resize(FLOOD_LEN, b'#');
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layouts::anydevice as layout;

    /// On schedule, the pacer waits out the period; behind it, it sends
    /// at once and restarts the schedule (no catch-up burst).
    #[test]
    fn the_pacer_keeps_the_rate_and_never_bursts() {
        use std::time::Duration;
        let ms = Duration::from_millis;
        let mut p = Pacer::new(ms(2));
        let t0 = p.next;
        assert_eq!(p.after_send(t0), Some(ms(2)));
        assert_eq!(p.after_send(t0 + ms(3)), Some(ms(1)));
        // Stalled for 10 ms: due at once, once; then paced from there.
        assert_eq!(p.after_send(t0 + ms(14)), None);
        assert_eq!(p.after_send(t0 + ms(14)), Some(ms(2)));
    }

    #[test]
    fn flood_datagram_is_rejected_at_once() {
        use rri_firmware::codec::decode;
        let mut robot = layout::RobotData::default();
        let e = decode::<layout::RobDataMessage>(&flood_datagram(), &mut robot).unwrap_err();
        assert_eq!(e.offset, 0, "{e:?}");
        assert_eq!(flood_datagram().len(), FLOOD_LEN);
    }

    #[test]
    fn every_flood_datagram_is_rejected() {
        use rri_firmware::codec::decode;
        let flood = flood_datagrams();
        assert_eq!(flood.len(), 4, "garbage, two hostile, oversize");
        for (name, d) in &flood {
            let mut robot = layout::RobotData::default();
            assert!(
                decode::<layout::RobDataMessage>(d, &mut robot).is_err(),
                "{name} would be answered"
            );
        }
    }
}
