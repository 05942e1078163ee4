//! The bridge's forwarded TCP connections against a device that resets
//! under them: a smoltcp stack on the far side of the wire stands for the
//! device (the chip's own stack is smoltcp too), and a reset is that stack
//! thrown away and made again, as a chip reset throws away its sockets.

use super::*;
use std::time::Duration as WallDuration;

const DEVICE: [u8; 4] = [192, 168, 0, 10];
const DEVICE_MAC: [u8; 6] = [0x02, 0, 0, 0, 0, 0x10];
const PORT: u16 = 80;

/// The device's stack: an interface and one socket listening on [`PORT`].
struct Device {
    iface: Interface,
    sockets: SocketSet<'static>,
    listener: SocketHandle,
    queues: Queues,
}

impl Device {
    /// A device fresh from reset: nothing learned, one listener.
    fn boot() -> Device {
        let mut queues = Queues {
            rx: VecDeque::new(),
            tx: VecDeque::new(),
        };
        let config = Config::new(HardwareAddress::Ethernet(EthernetAddress(DEVICE_MAC)));
        let mut iface = Interface::new(config, &mut queues, Instant::ZERO);
        let [a, b, c, d] = DEVICE;
        iface.update_ip_addrs(|addrs| {
            let _ = addrs.push(IpCidr::new(IpAddress::v4(a, b, c, d), 24));
        });
        let mut s = tcp::Socket::new(
            tcp::SocketBuffer::new(vec![0; 4096]),
            tcp::SocketBuffer::new(vec![0; 4096]),
        );
        s.listen(PORT).expect("listen");
        let mut sockets = SocketSet::new(vec![]);
        let listener = sockets.add(s);
        Device {
            iface,
            sockets,
            listener,
            queues,
        }
    }

    /// One round on the wire: the bridge's frames in, the device's out.
    fn poll(&mut self, link: &mut Link, now_us: u64) {
        self.queues.rx.extend(link.to_device.drain(..));
        let now = Instant::from_micros(now_us as i64);
        self.iface.poll(now, &mut self.queues, &mut self.sockets);
        link.from_device.extend(self.queues.tx.drain(..));
    }

    /// What the device's socket has received so far.
    fn received(&mut self) -> Vec<u8> {
        let s = self.sockets.get_mut::<tcp::Socket>(self.listener);
        let mut buf = [0u8; 256];
        let mut got = Vec::new();
        while let Ok(n) = s.recv_slice(&mut buf) {
            if n == 0 {
                break;
            }
            got.extend_from_slice(&buf[..n]);
        }
        got
    }
}

/// A bridge forwarding a 127.0.0.1 port to the device's [`PORT`], and a
/// host client connected to it (its reads wait a millisecond).
fn forwarded() -> (Bridge, TcpStream) {
    let mut bridge = Bridge::new(DEVICE);
    let listen = bridge
        .forward_tcp("127.0.0.1:0".parse().unwrap(), PORT)
        .expect("forward");
    let host = TcpStream::connect(listen).expect("connect");
    host.set_read_timeout(Some(WallDuration::from_millis(1)))
        .expect("timeout");
    (bridge, host)
}

/// A host client sends a request that the device takes (its stack
/// acknowledges it), and the device resets before it answers. The
/// bridge's connection then has nothing in flight: only its keep-alive
/// reaches the new stack, whose reset closes the host's side too.
#[test]
fn a_connection_whose_device_reset_under_it_is_closed_on_both_sides() {
    let (mut bridge, mut host) = forwarded();
    host.write_all(b"GET /status.json HTTP/1.1\r\n\r\n")
        .expect("write");

    let mut link = Link::nucleo();
    let mut device = Device::boot();
    let mut now_us = 0u64;
    let step = 1_000;
    // Until the device holds the request (and its stack acknowledged it).
    let mut taken = Vec::new();
    while taken.is_empty() {
        now_us += step;
        assert!(now_us < 5_000_000, "the request never reached the device");
        bridge.poll(&mut link, now_us);
        device.poll(&mut link, now_us);
        taken = device.received();
    }
    for _ in 0..100 {
        now_us += step;
        bridge.poll(&mut link, now_us);
        device.poll(&mut link, now_us);
    }
    assert_eq!(bridge.tcp[0].conns.len(), 1, "open while the device lives");

    // The chip resets: its stack and every socket in it are gone.
    device = Device::boot();
    let reset_at = now_us;
    let mut closed_at = None;
    let mut buf = [0u8; 64];
    while now_us < reset_at + 60_000_000 {
        now_us += step;
        bridge.poll(&mut link, now_us);
        device.poll(&mut link, now_us);
        if bridge.tcp[0].conns.is_empty() {
            closed_at = Some(now_us);
            break;
        }
    }
    let closed_at = closed_at.expect("the bridge kept the connection 60 s after the reset");
    let after = closed_at - reset_at;
    assert!(
        after <= 2 * HOST_KEEP_ALIVE.total_micros(),
        "closed {after} µs after the reset: later than two keep-alive intervals"
    );
    match host.read(&mut buf) {
        Ok(0) => {}
        other => panic!("the host's side was not closed: {other:?}"),
    }
}

/// A connection made while the device answers nothing at all (in its
/// bootloader, say) is aborted after [`HOST_TIMEOUT`], not kept for good.
#[test]
fn a_connection_to_a_silent_device_is_aborted_after_the_timeout() {
    let (mut bridge, mut host) = forwarded();
    let mut link = Link::nucleo();
    let mut now_us = 0u64;
    let step = 10_000;
    let mut closed_at = None;
    while now_us < 120_000_000 {
        now_us += step;
        bridge.poll(&mut link, now_us);
        link.from_device.clear();
        link.to_device.clear();
        if bridge.tcp.first().is_some_and(|f| f.conns.is_empty()) && now_us > step {
            closed_at = Some(now_us);
            break;
        }
    }
    let closed_at = closed_at.expect("the bridge kept the connection 120 s");
    assert!(
        closed_at >= HOST_TIMEOUT.total_micros()
            && closed_at <= HOST_TIMEOUT.total_micros() + 5_000_000,
        "aborted at {closed_at} µs, not at the {HOST_TIMEOUT} timeout"
    );
    let mut buf = [0u8; 8];
    match host.read(&mut buf) {
        Ok(0) => {}
        other => panic!("the host's side was not closed: {other:?}"),
    }
}
