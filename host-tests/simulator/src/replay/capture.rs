//! Reading what Wireshark and tcpdump write: pcap (micro- and nanosecond
//! timestamps, either byte order) and pcapng (several sections, several
//! interfaces, mixed link types), through pcap-parser; Ethernet, Linux
//! cooked (SLL and SLL2), raw IPv4 and BSD loopback frames, through
//! etherparse, which also reassembles IPv4 fragments (RFC 791: by source,
//! destination, protocol and identification). What comes out is every
//! UDP datagram and TCP segment over IPv4, numbered like Wireshark numbers
//! packets (from 1), with its time in microseconds.

use etherparse::defrag::IpDefragPool;
use etherparse::{
    EtherType, LaxNetSlice, LaxSlicedPacket, NetSlice, SlicedPacket, TcpSlice, TransportSlice,
    UdpSlice,
};
use pcap_parser::pcapng::Block;
use pcap_parser::{Linktype, PcapBlockOwned, PcapError};
use std::net::SocketAddrV4;
use std::path::Path;

/// The transport of a [`Segment`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Transport {
    /// A whole UDP datagram (reassembled if it came in fragments).
    Udp,
    /// A TCP segment: its sequence number and flags.
    Tcp {
        seq: u32,
        syn: bool,
        fin: bool,
        rst: bool,
    },
}

/// One UDP datagram or TCP segment of the capture.
#[derive(Clone, Debug)]
pub struct Segment {
    /// The packet that completed it (1 for the file's first).
    pub number: usize,
    /// Capture time, µs since the Unix epoch.
    pub at_us: u64,
    pub from: SocketAddrV4,
    pub to: SocketAddrV4,
    pub transport: Transport,
    pub payload: Vec<u8>,
}

/// A packet whose IPv4 packet the file does not hold whole (cut by the
/// capture's snapshot length): its number and, where its headers were
/// whole, its addresses and endpoints. A frame whose original length only
/// counts a frame check sequence that was not captured is not cut.
#[derive(Clone, Debug)]
pub struct Cut {
    pub number: usize,
    pub ends: Option<(SocketAddrV4, SocketAddrV4)>,
    /// Source and destination address, where the IPv4 header was whole.
    pub hosts: Option<(std::net::Ipv4Addr, std::net::Ipv4Addr)>,
}

/// What the file held.
#[derive(Debug, Default)]
pub struct Capture {
    /// Packets in the file.
    pub packets: usize,
    /// Every UDP datagram and TCP segment over IPv4, in file order.
    pub segments: Vec<Segment>,
    /// Packets cut by the snapshot length.
    pub cut: Vec<Cut>,
    /// Packets of a link type this reader does not take, by link type.
    pub other_links: Vec<(i32, usize)>,
    /// Packets with no timestamp of their own (pcapng simple packet
    /// blocks): given the time of the packet before.
    pub untimed: Vec<usize>,
}

/// Timestamp units per second of a pcapng interface's `if_tsresol`: a
/// power of ten, or of two when bit 7 is set (pcapng, 4.2). `None` for one
/// that does not fit (pcap-parser 0.17's own gives `None` for every binary
/// one, which read 2^-30 s units as microseconds).
fn units_per_second(if_tsresol: u8) -> Option<u128> {
    let n = u32::from(if_tsresol & 0x7f);
    if if_tsresol & 0x80 == 0 {
        10u128.checked_pow(n).filter(|_| n <= 19)
    } else {
        (n <= 63).then(|| 1u128 << n)
    }
}

/// What the reader's last step came to.
enum Step {
    Consumed(usize),
    End,
    Refill,
    Truncated,
    Bad(String),
}

/// A packet as the file gives it.
struct Frame<'a> {
    number: usize,
    at_us: u64,
    link: Linktype,
    data: &'a [u8],
    cut: bool,
}

/// One pcapng interface: its link type and clock.
#[derive(Clone, Copy)]
struct Interface {
    link: Linktype,
    /// Timestamp units per second.
    resolution: u128,
    /// Seconds added to every timestamp.
    offset: i64,
}

/// Reads `path`, or says in one line why it cannot be replayed from.
pub fn read(path: &Path) -> Result<Capture, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let name = path.display();
    let mut reader = pcap_parser::create_reader(1 << 20, &bytes[..]).map_err(|e| match e {
        PcapError::Eof => format!("{name}: empty file, not a capture"),
        PcapError::HeaderNotRecognized => {
            format!(
                "{name}: not a capture (neither pcap nor pcapng; Wireshark and tcpdump write both)"
            )
        }
        PcapError::Incomplete(_) | PcapError::UnexpectedEof => {
            format!("{name}: truncated before the first packet")
        }
        other => format!("{name}: not a readable capture ({other:?})"),
    })?;
    let mut out = Capture::default();
    let mut pool = IpDefragPool::<u64, ()>::new();
    let mut legacy: Option<(Linktype, bool)> = None;
    let mut interfaces: Vec<Interface> = Vec::new();
    let mut last_us = 0;
    loop {
        let step = match reader.next() {
            Ok((consumed, block)) => {
                let frame = match block {
                    PcapBlockOwned::LegacyHeader(h) => {
                        legacy = Some((h.network, h.is_nanosecond_precision()));
                        None
                    }
                    PcapBlockOwned::Legacy(b) => {
                        let (link, nanos) = legacy.unwrap_or((Linktype::ETHERNET, false));
                        let frac = u64::from(b.ts_usec) / if nanos { 1000 } else { 1 };
                        out.packets += 1;
                        Some(Frame {
                            number: out.packets,
                            at_us: u64::from(b.ts_sec) * 1_000_000 + frac,
                            link,
                            data: b.data,
                            cut: b.caplen < b.origlen,
                        })
                    }
                    PcapBlockOwned::NG(Block::SectionHeader(_)) => {
                        // A new section describes its interfaces anew.
                        interfaces.clear();
                        None
                    }
                    PcapBlockOwned::NG(Block::InterfaceDescription(i)) => {
                        interfaces.push(Interface {
                            link: i.linktype,
                            resolution: units_per_second(i.if_tsresol).ok_or_else(|| {
                                format!(
                                    "{name}: interface {} has a timestamp resolution (if_tsresol {:#04x}) no clock has",
                                    interfaces.len(),
                                    i.if_tsresol
                                )
                            })?,
                            offset: i.ts_offset(),
                        });
                        None
                    }
                    PcapBlockOwned::NG(Block::EnhancedPacket(p)) => {
                        out.packets += 1;
                        let number = out.packets;
                        let i = interfaces.get(p.if_id as usize).copied().ok_or_else(|| {
                            format!(
                                "{name}: packet {number} names interface {} that the file never described",
                                p.if_id
                            )
                        })?;
                        let ticks = (u128::from(p.ts_high) << 32) | u128::from(p.ts_low);
                        let us = ticks * 1_000_000 / i.resolution;
                        let us = (us as i128 + i128::from(i.offset) * 1_000_000).max(0) as u64;
                        Some(Frame {
                            number,
                            at_us: us,
                            link: i.link,
                            data: p.data,
                            cut: p.caplen < p.origlen,
                        })
                    }
                    PcapBlockOwned::NG(Block::SimplePacket(p)) => {
                        // No timestamp (it is given the packet before's,
                        // and counted: recorded pacing cannot use it), and
                        // the first interface's link type.
                        out.packets += 1;
                        out.untimed.push(out.packets);
                        let i = interfaces.first().copied().ok_or_else(|| {
                            format!(
                                "{name}: packet {} comes before any interface description",
                                out.packets
                            )
                        })?;
                        Some(Frame {
                            number: out.packets,
                            at_us: last_us,
                            link: i.link,
                            data: p.data,
                            cut: (p.data.len() as u64) < u64::from(p.origlen),
                        })
                    }
                    PcapBlockOwned::NG(_) => None,
                };
                if let Some(f) = frame {
                    last_us = f.at_us;
                    take(&f, &mut pool, &mut out);
                }
                Step::Consumed(consumed)
            }
            Err(PcapError::Eof) => Step::End,
            Err(PcapError::Incomplete(_)) => Step::Refill,
            Err(PcapError::UnexpectedEof) => Step::Truncated,
            Err(e) => Step::Bad(format!("{e:?}")),
        };
        match step {
            Step::Consumed(n) => reader.consume(n),
            Step::End => break,
            Step::Refill if !reader.reader_exhausted() => {
                reader.refill().map_err(|e| {
                    format!("{name}: unreadable after packet {}: {e:?}", out.packets)
                })?;
            }
            Step::Refill | Step::Truncated => {
                return Err(format!(
                    "{name}: truncated: the file ends inside the block after packet {}",
                    out.packets
                ))
            }
            Step::Bad(e) => {
                return Err(format!(
                    "{name}: unreadable after packet {}: {e}",
                    out.packets
                ))
            }
        }
    }
    Ok(out)
}

/// Where a frame's packet starts, by the link type: what the strict and
/// the lenient slicing both read it from.
enum Framing<'a> {
    Ethernet(&'a [u8]),
    /// An EtherType and the packet after the link header.
    EtherType(u16, &'a [u8]),
    /// The IP packet itself.
    Ip(&'a [u8]),
}

/// The frame's [`Framing`]; `Ok(None)` when it carries no IPv4 (or is
/// shorter than its link header), `Err` with the link type when this
/// reader does not take it.
fn framing(link: Linktype, data: &[u8]) -> Result<Option<Framing<'_>>, i32> {
    // Linux cooked captures (`-i any`, and loopback on some systems): the
    // protocol is an EtherType whatever the device type (etherparse takes
    // it only for a few; a loopback's, ARPHRD 772, not). SLL: 16 bytes,
    // the protocol last; SLL2: 20 bytes, the protocol first.
    let cooked = |proto: usize, payload: usize| {
        let ty = data
            .get(proto..proto + 2)
            .map_or(0, |b| u16::from_be_bytes([b[0], b[1]]));
        data.get(payload..).map(|rest| Framing::EtherType(ty, rest))
    };
    Ok(match link {
        Linktype::ETHERNET => Some(Framing::Ethernet(data)),
        Linktype::LINUX_SLL => cooked(14, 16),
        Linktype::LINUX_SLL2 => cooked(0, 20),
        Linktype::RAW | Linktype::IPV4 => Some(Framing::Ip(data)),
        // BSD loopback: a 4-byte address family (2: IPv4) in the capturing
        // host's order (NULL) or big-endian (LOOP).
        Linktype::NULL | Linktype::LOOP => match (data.get(..4), data.get(4..)) {
            (Some(family), Some(rest)) if family.contains(&2) => Some(Framing::Ip(rest)),
            _ => None,
        },
        other => return Err(other.0),
    })
}

/// The IPv4 packet a frame carries, sliced strictly; `Err` with the link
/// type when this reader does not take it.
fn slice(link: Linktype, data: &[u8]) -> Result<Option<SlicedPacket<'_>>, i32> {
    Ok(framing(link, data)?.and_then(|f| {
        match f {
            Framing::Ethernet(d) => SlicedPacket::from_ethernet(d),
            Framing::EtherType(ty, d) => SlicedPacket::from_ether_type(EtherType(ty), d),
            Framing::Ip(d) => SlicedPacket::from_ip(d),
        }
        .ok()
    }))
}

/// The frame read leniently (lengths that say more than the file holds are
/// allowed), to tell a packet cut by the snapshot length and its ends.
fn lax(link: Linktype, data: &[u8]) -> Option<LaxSlicedPacket<'_>> {
    match framing(link, data).ok()?? {
        Framing::Ethernet(d) => LaxSlicedPacket::from_ethernet(d).ok(),
        Framing::EtherType(ty, d) => Some(LaxSlicedPacket::from_ether_type(EtherType(ty), d)),
        Framing::Ip(d) => LaxSlicedPacket::from_ip(d).ok(),
    }
}

/// The frame as a [`Cut`] if its IPv4 packet is not whole in the file
/// (its header says more than was captured), or if the frame was cut
/// before its IPv4 header could be read.
fn cut(f: &Frame<'_>) -> Option<Cut> {
    let Some(p) = lax(f.link, f.data) else {
        return f.cut.then_some(Cut {
            number: f.number,
            ends: None,
            hosts: None,
        });
    };
    let Some(LaxNetSlice::Ipv4(ip)) = &p.net else {
        return None;
    };
    if !ip.payload().incomplete {
        return None;
    }
    let h = ip.header();
    let (src, dst) = (h.source_addr(), h.destination_addr());
    Some(Cut {
        number: f.number,
        ends: p
            .transport
            .as_ref()
            .and_then(ports)
            .map(|(a, b)| (SocketAddrV4::new(src, a), SocketAddrV4::new(dst, b))),
        hosts: Some((src, dst)),
    })
}

/// Takes one frame: its UDP datagram or TCP segment, once whole.
fn take(f: &Frame<'_>, pool: &mut IpDefragPool<u64, ()>, out: &mut Capture) {
    if let Some(c) = cut(f) {
        out.cut.push(c);
        return;
    }
    let sliced = match slice(f.link, f.data) {
        Ok(s) => s,
        Err(link) => {
            match out.other_links.iter_mut().find(|(l, _)| *l == link) {
                Some((_, n)) => *n += 1,
                None => out.other_links.push((link, 1)),
            }
            return;
        }
    };
    let Some(sliced) = sliced else {
        return;
    };
    let Some(NetSlice::Ipv4(ip)) = &sliced.net else {
        return;
    };
    let header = ip.header();
    let (src, dst) = (header.source_addr(), header.destination_addr());
    if header.is_fragmenting_payload() {
        // Fragments older than a second are let go, as a host would.
        let now = f.at_us;
        pool.retain(|t| now.saturating_sub(*t) < 1_000_000);
        let Ok(Some(whole)) = pool.process_sliced_packet(&sliced, f.at_us, ()) else {
            return;
        };
        let transport = match whole.ip_number {
            etherparse::IpNumber::UDP => UdpSlice::from_slice(&whole.payload)
                .ok()
                .map(TransportSlice::Udp),
            etherparse::IpNumber::TCP => TcpSlice::from_slice(&whole.payload)
                .ok()
                .map(TransportSlice::Tcp),
            _ => None,
        };
        if let Some(t) = transport {
            push(f, src, dst, &t, out);
        }
        return;
    }
    if let Some(t @ (TransportSlice::Udp(_) | TransportSlice::Tcp(_))) = &sliced.transport {
        push(f, src, dst, t, out);
    }
}

fn ports(t: &TransportSlice<'_>) -> Option<(u16, u16)> {
    match t {
        TransportSlice::Udp(u) => Some((u.source_port(), u.destination_port())),
        TransportSlice::Tcp(t) => Some((t.source_port(), t.destination_port())),
        _ => None,
    }
}

fn push(
    f: &Frame<'_>,
    src: std::net::Ipv4Addr,
    dst: std::net::Ipv4Addr,
    t: &TransportSlice<'_>,
    out: &mut Capture,
) {
    let (transport, from, to, payload) = match t {
        TransportSlice::Udp(u) => (
            Transport::Udp,
            u.source_port(),
            u.destination_port(),
            u.payload(),
        ),
        TransportSlice::Tcp(t) => (
            Transport::Tcp {
                seq: t.sequence_number(),
                syn: t.syn(),
                fin: t.fin(),
                rst: t.rst(),
            },
            t.source_port(),
            t.destination_port(),
            t.payload(),
        ),
        _ => return,
    };
    out.segments.push(Segment {
        number: f.number,
        at_us: f.at_us,
        from: SocketAddrV4::new(src, from),
        to: SocketAddrV4::new(dst, to),
        transport,
        payload: payload.to_vec(),
    });
}

#[cfg(test)]
#[path = "capture_tests.rs"]
mod tests;
