//! The capture (`--pcap FILE`): every message of the run as IPv4/UDP or
//! IPv4/TCP packets (with the handshake and close around TCP), every
//! checksum computed with smoltcp's wire layer, so Wireshark shows them as
//! it would a real capture.

use smoltcp::phy::ChecksumCapabilities;
use smoltcp::wire::{
    IpAddress, IpProtocol, Ipv4Address, Ipv4Packet, Ipv4Repr, TcpControl, TcpPacket, TcpRepr,
    TcpSeqNumber, UdpPacket, UdpRepr, UDP_HEADER_LEN,
};
use std::collections::HashMap;
use std::io::{self, Write};
use std::net::SocketAddr;
use std::path::Path;

/// A captured datagram (or TCP segment payload).
#[derive(Clone, Debug)]
pub struct Packet {
    pub at_us: u64,
    pub from: SocketAddr,
    pub to: SocketAddr,
    pub payload: Vec<u8>,
}

fn v4(a: SocketAddr) -> Ipv4Address {
    match a {
        SocketAddr::V4(a) => *a.ip(),
        SocketAddr::V6(_) => Ipv4Address::UNSPECIFIED,
    }
}

/// One IPv4 packet with its transport header and payload, every checksum
/// computed (smoltcp's wire layer).
fn ipv4_packet(from: SocketAddr, to: SocketAddr, l4: &L4<'_>, payload: &[u8]) -> Vec<u8> {
    let caps = ChecksumCapabilities::default();
    let (src, dst) = (v4(from), v4(to));
    let (protocol, l4_len) = match l4 {
        L4::Udp => (IpProtocol::Udp, UDP_HEADER_LEN + payload.len()),
        L4::Tcp(repr) => (IpProtocol::Tcp, repr.buffer_len()),
    };
    let ip = Ipv4Repr {
        src_addr: src,
        dst_addr: dst,
        next_header: protocol,
        payload_len: l4_len,
        hop_limit: 64,
    };
    let mut buf = vec![0u8; ip.buffer_len() + l4_len];
    ip.emit(&mut Ipv4Packet::new_unchecked(&mut buf[..]), &caps);
    let body = &mut buf[ip.buffer_len()..];
    let (src, dst) = (IpAddress::Ipv4(src), IpAddress::Ipv4(dst));
    match l4 {
        L4::Udp => UdpRepr {
            src_port: from.port(),
            dst_port: to.port(),
        }
        .emit(
            &mut UdpPacket::new_unchecked(body),
            &src,
            &dst,
            payload.len(),
            |b| b.copy_from_slice(payload),
            &caps,
        ),
        L4::Tcp(repr) => repr.emit(&mut TcpPacket::new_unchecked(body), &src, &dst, &caps),
    }
    buf
}

enum L4<'a> {
    Udp,
    Tcp(TcpRepr<'a>),
}

/// The TCP segment `from` → `to` with `control` and `payload`, sequence
/// and acknowledgement numbers from `next` (each side's next sequence
/// number), which it advances.
fn segment<'a>(
    next: &mut HashMap<SocketAddr, u32>,
    from: SocketAddr,
    to: SocketAddr,
    control: TcpControl,
    payload: &'a [u8],
) -> TcpRepr<'a> {
    let seq = *next.get(&from).unwrap_or(&0);
    let ack = next.get(&to).copied();
    let len =
        payload.len() as u32 + u32::from(matches!(control, TcpControl::Syn | TcpControl::Fin));
    next.insert(from, seq.wrapping_add(len));
    TcpRepr {
        src_port: from.port(),
        dst_port: to.port(),
        control,
        seq_number: TcpSeqNumber(seq as i32),
        ack_number: ack.map(|a| TcpSeqNumber(a as i32)),
        window_len: 65_535,
        window_scale: None,
        max_seg_size: None,
        sack_permitted: false,
        sack_ranges: [None; 3],
        timestamp: None,
        payload,
    }
}

/// Writes the exchanged messages as a pcap file Wireshark and tshark read
/// cleanly: raw IPv4 packets (link type 101) with real IPv4, UDP and TCP
/// checksums. A TCP capture opens with the three-way handshake and closes
/// with the FIN exchange around the messages, with running sequence and
/// acknowledgement numbers, so the stream can be followed.
pub fn write_pcap(
    path: &Path,
    packets: &[Packet],
    start_unix_us: u64,
    tcp: bool,
) -> io::Result<()> {
    let mut frames: Vec<(u64, Vec<u8>)> = Vec::new();
    if tcp {
        if let (Some(first), Some(last)) = (packets.first(), packets.last()) {
            let (robot, sensor) = (first.from, first.to);
            let mut next: HashMap<SocketAddr, u32> = HashMap::new();
            next.insert(robot, 1_000);
            next.insert(sensor, 5_000);
            let open = first.at_us.saturating_sub(3);
            let mut push = |next: &mut HashMap<SocketAddr, u32>, at, from, to, control, payload| {
                let repr = segment(next, from, to, control, payload);
                frames.push((at, ipv4_packet(from, to, &L4::Tcp(repr), payload)));
            };
            // SYN carries no Ack; the robot's Ack starts with the SYN-ACK.
            let syn_ack_from = next.remove(&sensor).unwrap_or(5_000);
            push(&mut next, open, robot, sensor, TcpControl::Syn, &[]);
            next.insert(sensor, syn_ack_from);
            push(&mut next, open + 1, sensor, robot, TcpControl::Syn, &[]);
            push(&mut next, open + 2, robot, sensor, TcpControl::None, &[]);
            for p in packets {
                push(
                    &mut next,
                    p.at_us,
                    p.from,
                    p.to,
                    TcpControl::Psh,
                    &p.payload,
                );
            }
            let close = last.at_us + 1;
            push(&mut next, close, robot, sensor, TcpControl::Fin, &[]);
            push(&mut next, close + 1, sensor, robot, TcpControl::Fin, &[]);
            push(&mut next, close + 2, robot, sensor, TcpControl::None, &[]);
        }
    } else {
        for p in packets {
            frames.push((p.at_us, ipv4_packet(p.from, p.to, &L4::Udp, &p.payload)));
        }
    }
    if path.extension().is_some_and(|e| e == "pcapng") {
        return write_pcapng(path, &frames, start_unix_us);
    }
    let mut f = io::BufWriter::new(std::fs::File::create(path)?);
    // Global header: magic, v2.4, tz 0, sigfigs 0, snaplen, LINKTYPE_RAW.
    f.write_all(&0xa1b2_c3d4u32.to_le_bytes())?;
    f.write_all(&2u16.to_le_bytes())?;
    f.write_all(&4u16.to_le_bytes())?;
    f.write_all(&0i32.to_le_bytes())?;
    f.write_all(&0u32.to_le_bytes())?;
    f.write_all(&65_535u32.to_le_bytes())?;
    f.write_all(&101u32.to_le_bytes())?;
    for (at_us, pkt) in frames {
        let t = start_unix_us + at_us;
        f.write_all(&((t / 1_000_000) as u32).to_le_bytes())?;
        f.write_all(&((t % 1_000_000) as u32).to_le_bytes())?;
        f.write_all(&(pkt.len() as u32).to_le_bytes())?;
        f.write_all(&(pkt.len() as u32).to_le_bytes())?;
        f.write_all(&pkt)?;
    }
    f.flush()
}

/// The same frames as pcapng (a `.pcapng` file name): one section, one
/// raw-IPv4 interface with microsecond timestamps, an enhanced packet
/// block per frame. What Wireshark writes by default, so a capture made
/// here and one made there take the same path through `--replay`.
fn write_pcapng(path: &Path, frames: &[(u64, Vec<u8>)], start_unix_us: u64) -> io::Result<()> {
    let mut f = io::BufWriter::new(std::fs::File::create(path)?);
    let block = |f: &mut io::BufWriter<std::fs::File>, kind: u32, body: &[u8]| {
        // Type, total length, body padded to 32 bits, total length again.
        let padded = body.len().div_ceil(4) * 4;
        let total = (12 + padded) as u32;
        f.write_all(&kind.to_le_bytes())?;
        f.write_all(&total.to_le_bytes())?;
        f.write_all(body)?;
        f.write_all(&vec![0u8; padded - body.len()])?;
        f.write_all(&total.to_le_bytes())
    };
    // Section header: byte-order magic, v1.0, section length unknown.
    let mut shb = Vec::new();
    shb.extend_from_slice(&0x1a2b_3c4du32.to_le_bytes());
    shb.extend_from_slice(&1u16.to_le_bytes());
    shb.extend_from_slice(&0u16.to_le_bytes());
    shb.extend_from_slice(&(-1i64).to_le_bytes());
    block(&mut f, 0x0a0d_0d0a, &shb)?;
    // Interface: LINKTYPE_RAW, snaplen 65,535 (default resolution: µs).
    let mut idb = Vec::new();
    idb.extend_from_slice(&101u16.to_le_bytes());
    idb.extend_from_slice(&0u16.to_le_bytes());
    idb.extend_from_slice(&65_535u32.to_le_bytes());
    block(&mut f, 1, &idb)?;
    for (at_us, pkt) in frames {
        let t = start_unix_us + at_us;
        let mut epb = Vec::with_capacity(20 + pkt.len());
        epb.extend_from_slice(&0u32.to_le_bytes());
        epb.extend_from_slice(&((t >> 32) as u32).to_le_bytes());
        epb.extend_from_slice(&(t as u32).to_le_bytes());
        epb.extend_from_slice(&(pkt.len() as u32).to_le_bytes());
        epb.extend_from_slice(&(pkt.len() as u32).to_le_bytes());
        epb.extend_from_slice(pkt);
        block(&mut f, 6, &epb)?;
    }
    f.flush()
}
