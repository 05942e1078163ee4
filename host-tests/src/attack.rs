//! Fragment attacks (S5) for the QEMU board over a tap device (`cargo
//! flood -- --fragments`): oversize fragment sets, sent as UDP datagrams
//! longer than the layout accepts that the host's kernel cuts into
//! fragments (the two 9,000-byte ones first, [`opening`]), and
//! incomplete ones, single IPv4 fragments crafted whole and sent through a
//! raw socket (root): the first fragment of a set alone, a middle one
//! alone, one alone far past anything a layout accepts.

use crate::qemu_bench::{drain_replies, Flooded, Pacer};
use std::net::{Ipv4Addr, SocketAddrV4, UdpSocket};
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

/// Bytes of IP payload in each crafted fragment (one full Ethernet frame).
const FRAGMENT: usize = 1480;

/// A raw IPv4 socket: every packet is sent as written, header included
/// (`IPPROTO_RAW` implies `IP_HDRINCL`; the kernel fills in nothing we
/// set and does not fragment).
pub struct RawIpv4(OwnedFd);

impl RawIpv4 {
    /// Needs root (`CAP_NET_RAW`).
    pub fn new() -> Result<RawIpv4, String> {
        // SAFETY: plain socket(2); the descriptor is owned from here on.
        let fd = unsafe { libc::socket(libc::AF_INET, libc::SOCK_RAW, libc::IPPROTO_RAW) };
        if fd < 0 {
            return Err(format!(
                "cannot open a raw IPv4 socket (root needed): {}",
                std::io::Error::last_os_error()
            ));
        }
        // SAFETY: `fd` is a fresh descriptor nobody else owns.
        Ok(RawIpv4(unsafe { OwnedFd::from_raw_fd(fd) }))
    }

    /// Sends one IPv4 packet (`packet` starts with its header) to `to`.
    pub fn send(&self, packet: &[u8], to: Ipv4Addr) -> std::io::Result<()> {
        let addr = libc::sockaddr_in {
            sin_family: libc::AF_INET as libc::sa_family_t,
            sin_port: 0,
            sin_addr: libc::in_addr {
                s_addr: u32::from_ne_bytes(to.octets()),
            },
            sin_zero: [0; 8],
        };
        // SAFETY: `packet` and `addr` outlive the call; the length is theirs.
        let sent = unsafe {
            libc::sendto(
                self.0.as_raw_fd(),
                packet.as_ptr().cast(),
                packet.len(),
                0,
                (&addr as *const libc::sockaddr_in).cast(),
                std::mem::size_of::<libc::sockaddr_in>() as libc::socklen_t,
            )
        };
        if sent < 0 {
            Err(std::io::Error::last_os_error())
        } else {
            Ok(())
        }
    }
}

/// One IPv4 fragment of a UDP datagram: `payload` at byte `offset`, "more
/// fragments" set, a right header checksum. `ident` 0: the kernel picks
/// one from the counter it numbers every datagram from `from` to `to`
/// with (raw(7): "filled in when zero"), so a crafted fragment from the
/// controller's address never joins one of the robot's own sets by chance
/// (it did once with idents of our own: the set was spoiled).
pub fn fragment(
    from: Ipv4Addr,
    to: Ipv4Addr,
    ident: u16,
    offset: usize,
    payload: &[u8],
) -> Vec<u8> {
    fragment_at(from, to, ident, offset, true, payload)
}

/// [`fragment`] with "more fragments" as `more` says (clear: the last of
/// its set).
fn fragment_at(
    from: Ipv4Addr,
    to: Ipv4Addr,
    ident: u16,
    offset: usize,
    more: bool,
    payload: &[u8],
) -> Vec<u8> {
    let total = 20 + payload.len();
    let flags = if more { 0x2000 } else { 0 } | (offset / 8) as u16;
    let mut p = vec![0x45, 0];
    p.extend_from_slice(&(total as u16).to_be_bytes());
    p.extend_from_slice(&ident.to_be_bytes());
    p.extend_from_slice(&flags.to_be_bytes());
    p.extend_from_slice(&[64, 17, 0, 0]);
    p.extend_from_slice(&from.octets());
    p.extend_from_slice(&to.octets());
    // The header checksum (RFC 1071): smoltcp's.
    smoltcp::wire::Ipv4Packet::new_unchecked(&mut p[..]).fill_checksum();
    p.extend_from_slice(payload);
    p
}

/// The first fragment of a UDP datagram of `len` bytes from `sport` to
/// `dport`, whose other fragments never come.
pub fn first_alone(from: SocketAddrV4, to: SocketAddrV4, ident: u16, len: usize) -> Vec<u8> {
    let mut udp = Vec::with_capacity(FRAGMENT);
    udp.extend_from_slice(&from.port().to_be_bytes());
    udp.extend_from_slice(&to.port().to_be_bytes());
    udp.extend_from_slice(&((8 + len) as u16).to_be_bytes());
    udp.extend_from_slice(&[0, 0]);
    udp.resize(FRAGMENT, b' ');
    fragment(*from.ip(), *to.ip(), ident, 0, &udp)
}

/// What a fragment flooder sends, in turn. None is longer than three
/// frames: a burst of the emulated LAN9118's whole RX FIFO (10,560 bytes,
/// seven full frames) would drop the robot's own frames in the emulator
/// whatever the firmware does; the 9,000-byte datagrams of the issue are
/// sent by [`opening`].
pub const KINDS: [&str; 4] = [
    "first fragment alone (incomplete set)",
    "datagram one byte past the layout (oversize set)",
    "middle fragment alone (incomplete set)",
    "fragment alone at 60,000 bytes (oversize)",
];

/// The attack, once: two 9,000-byte datagrams from `from` (a
/// second port of the controller's address), each seven fragments. With
/// smoltcp's own reassembly they held both buffers for 60 s.
pub fn opening(from: Ipv4Addr, to: SocketAddrV4) -> Result<(), String> {
    let udp = UdpSocket::bind((from, 0)).map_err(|e| format!("bind {from}: {e}"))?;
    for _ in 0..2 {
        udp.send_to(&[b'<'; 9000], to)
            .map_err(|e| format!("send to {to}: {e}"))?;
    }
    Ok(())
}

/// A flooder thread: from `from` (its address; UDP from an ephemeral
/// port), one of [`KINDS`] in turn, starting at `first`, every `period`
/// to `to`, until `stop`; counts what it sent and any reply (none may
/// come). `max_receive_len`: the layout's (`layout::MAX_RECEIVE_LEN`).
pub fn fragment_flood(
    from: Ipv4Addr,
    to: SocketAddrV4,
    max_receive_len: usize,
    first: usize,
    period: Duration,
    stop: Arc<AtomicBool>,
) -> Result<JoinHandle<Flooded>, String> {
    let udp = UdpSocket::bind((from, 0)).map_err(|e| format!("bind {from}: {e}"))?;
    udp.set_nonblocking(true).map_err(|e| e.to_string())?;
    let sport = udp.local_addr().map_err(|e| e.to_string())?.port();
    let me = SocketAddrV4::new(from, sport);
    let raw = RawIpv4::new()?;
    Ok(std::thread::spawn(move || {
        let mut sent = [0u64; KINDS.len()];
        let mut replies = 0u64;
        let mut buf = [0u8; 2048];
        let past = vec![b'<'; max_receive_len + 1];
        let middle = vec![b' '; FRAGMENT];
        let mut pacer = Pacer::new(period);
        // The kernel numbers every crafted fragment (see `fragment`): each
        // is a set of its own.
        let ident = 0;
        for turn in (0..KINDS.len()).cycle().skip(first) {
            if stop.load(Ordering::Relaxed) {
                break;
            }
            let ok = match turn {
                0 => raw
                    .send(&first_alone(me, to, ident, max_receive_len), *to.ip())
                    .is_ok(),
                1 => udp.send_to(&past, to).is_ok(),
                2 => raw
                    .send(
                        &fragment(from, *to.ip(), ident, FRAGMENT, &middle),
                        *to.ip(),
                    )
                    .is_ok(),
                _ => raw
                    .send(
                        &fragment(from, *to.ip(), ident, 60_000, &middle[..8]),
                        *to.ip(),
                    )
                    .is_ok(),
            };
            sent[turn] += u64::from(ok);
            replies += drain_replies(&udp, &mut buf);
            pacer.wait();
        }
        std::thread::sleep(Duration::from_millis(200));
        replies += drain_replies(&udp, &mut buf);
        Flooded {
            sent: KINDS.iter().map(|k| k.to_string()).zip(sent).collect(),
            replies,
        }
    }))
}

/// The first IP ident of the robot's crafted datagrams ([`last_first`]);
/// the tail flood ([`tail_flood`]) numbers from [`TAIL_IDENTS`]. Two
/// halves, so that no tail ever joins one of the robot's sets by its ident
/// (the set would be spoiled for a reason the test does not stand for).
const ROBOT_IDENTS: u16 = 0x0001;
const TAIL_IDENTS: u16 = 0x8000;

/// A UDP datagram from `from` to `to` (checksum filled) as IPv4
/// fragments of 1,480 bytes (`FRAGMENT`), **the last one first**, then the
/// others from the first on: how a controller's message looks after a
/// path that reorders (issue 36, finding 4). One packet when it fits one.
pub fn last_first(
    from: SocketAddrV4,
    to: SocketAddrV4,
    ident: u16,
    payload: &[u8],
) -> Vec<Vec<u8>> {
    let mut udp = Vec::with_capacity(8 + payload.len());
    udp.extend_from_slice(&from.port().to_be_bytes());
    udp.extend_from_slice(&to.port().to_be_bytes());
    udp.extend_from_slice(&((8 + payload.len()) as u16).to_be_bytes());
    udp.extend_from_slice(&[0, 0]);
    udp.extend_from_slice(payload);
    smoltcp::wire::UdpPacket::new_unchecked(&mut udp[..]).fill_checksum(
        &smoltcp::wire::IpAddress::Ipv4(*from.ip()),
        &smoltcp::wire::IpAddress::Ipv4(*to.ip()),
    );
    let mut pieces: Vec<Vec<u8>> = udp
        .chunks(FRAGMENT)
        .enumerate()
        .map(|(i, piece)| {
            let offset = i * FRAGMENT;
            let more = offset + piece.len() < udp.len();
            fragment_at(*from.ip(), *to.ip(), ident, offset, more, piece)
        })
        .collect();
    if let Some(last) = pieces.pop() {
        pieces.insert(0, last);
    }
    pieces
}

/// A send for the robot simulator (`RobotOptions::udp_send`): each robot
/// message from `controller` (at the simulator's own port, so its replies
/// still reach the simulator's socket) crafted as [`last_first`]
/// fragments through a raw socket, each message a fresh ident.
pub fn last_first_sender(controller: Ipv4Addr) -> Result<rri_robot::UdpSend, String> {
    let raw = RawIpv4::new()?;
    let next = std::sync::atomic::AtomicU16::new(ROBOT_IDENTS);
    Ok(rri_robot::UdpSend(Arc::new(move |from, to, bytes| {
        let std::net::SocketAddr::V4(to) = to else {
            return Err(std::io::Error::other("IPv4 only"));
        };
        let ident = next.fetch_add(1, Ordering::Relaxed) % TAIL_IDENTS;
        let from = SocketAddrV4::new(controller, from.port());
        for piece in last_first(from, to, ident.max(ROBOT_IDENTS), bytes) {
            raw.send(&piece, *to.ip())?;
        }
        Ok(())
    })))
}

/// The sustained form of issue 36's finding 4: from `from` (the
/// controller's address), a tail fragment (the last of a set, at byte
/// `FRAGMENT`) with a fresh ident every `period` (7 ms in CI), until
/// `stop`. Before the guard evicted least-recently-used within a rank,
/// these kept a robot message that arrived last-fragment-first out:
/// no buffer for its tail.
pub fn tail_flood(
    from: Ipv4Addr,
    to: SocketAddrV4,
    period: Duration,
    stop: Arc<AtomicBool>,
) -> Result<JoinHandle<Flooded>, String> {
    let raw = RawIpv4::new()?;
    Ok(std::thread::spawn(move || {
        let mut sent = 0u64;
        let tail = vec![b' '; 200];
        let mut pacer = Pacer::new(period);
        for n in 0u16.. {
            if stop.load(Ordering::Relaxed) {
                break;
            }
            let ident = TAIL_IDENTS | (n & 0x7fff);
            let piece = fragment_at(from, *to.ip(), ident, FRAGMENT, false, &tail);
            sent += u64::from(raw.send(&piece, *to.ip()).is_ok());
            pacer.wait();
        }
        Flooded {
            sent: vec![("tail fragment, a fresh ident".to_string(), sent)],
            replies: 0,
        }
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crafted_fragments_have_a_right_header() {
        let from = SocketAddrV4::new(Ipv4Addr::new(10, 49, 65, 1), 40000);
        let to = SocketAddrV4::new(Ipv4Addr::new(10, 49, 65, 74), 3002);
        let p = first_alone(from, to, 0x8001, 2000);
        assert_eq!(p.len(), 20 + FRAGMENT);
        let right = |h: &[u8]| smoltcp::wire::Ipv4Packet::new_unchecked(h).verify_checksum();
        assert!(right(&p[..20]));
        assert_eq!(u16::from_be_bytes([p[6], p[7]]), 0x2000, "MF, offset 0");
        assert_eq!(&p[20..24], &[0x9c, 0x40, 0x0b, 0xba], "ports 40000 → 3002");
        let m = fragment(*from.ip(), *to.ip(), 1, 60_000, &[0; 8]);
        assert_eq!(u16::from_be_bytes([m[6], m[7]]), 0x2000 | 7500);
        assert!(right(&m[..20]));
    }

    /// The robot's crafted datagram: the last fragment first, every
    /// header right, and the pieces put back in offset order are the UDP
    /// datagram with a right checksum.
    #[test]
    fn last_first_puts_the_last_fragment_first_and_holds_the_datagram() {
        let from = SocketAddrV4::new(Ipv4Addr::new(10, 49, 65, 1), 40000);
        let to = SocketAddrV4::new(Ipv4Addr::new(10, 49, 65, 74), 3002);
        let payload: Vec<u8> = (0..3500u32).map(|i| b'a' + (i % 26) as u8).collect();
        let pieces = last_first(from, to, 7, &payload);
        assert_eq!(pieces.len(), 3);
        let flags = |p: &[u8]| u16::from_be_bytes([p[6], p[7]]);
        assert_eq!(
            flags(&pieces[0]),
            (2 * FRAGMENT / 8) as u16,
            "last: offset, no MF"
        );
        assert_eq!(flags(&pieces[1]), 0x2000, "first: MF, offset 0");
        assert_eq!(flags(&pieces[2]), 0x2000 | (FRAGMENT / 8) as u16);
        let right = |h: &[u8]| smoltcp::wire::Ipv4Packet::new_unchecked(h).verify_checksum();
        assert!(pieces.iter().all(|p| right(&p[..20]) && p[4..6] == [0, 7]));
        let mut udp: Vec<u8> = Vec::new();
        for p in [&pieces[1], &pieces[2], &pieces[0]] {
            udp.extend_from_slice(&p[20..]);
        }
        let packet = smoltcp::wire::UdpPacket::new_checked(&udp[..]).unwrap();
        assert!(packet.verify_checksum(
            &smoltcp::wire::IpAddress::Ipv4(*from.ip()),
            &smoltcp::wire::IpAddress::Ipv4(*to.ip())
        ));
        assert_eq!(packet.payload(), &payload[..]);
    }
}
