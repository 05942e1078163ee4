//! One direction of a captured TCP connection rebuilt in sequence order:
//! retransmissions and overlaps give their new bytes only, segments that
//! came early wait for the ones before them, and a hole the capture never
//! filled is named by the packet after it. The bytes are then cut into
//! RRI messages by the M10 framing (the firmware's own framer).

use super::capture::{Segment, Transport};
use std::collections::BTreeMap;

/// A whole message: the packet that completed it, its time, its bytes.
pub type Framed = (usize, u64, Vec<u8>);

/// The messages of one direction, `segments` in capture order.
pub fn messages(segments: &[&Segment]) -> Result<Vec<Framed>, String> {
    let mut out = Vec::new();
    for connection in connections(segments) {
        // Each connection frames from its own first byte.
        let mut framer = Box::new(rri_framing::Framer::<65_536>::new());
        for (number, at_us, bytes) in in_order(&connection)? {
            framer
                .push(&bytes, |m| out.push((number, at_us, m.to_vec())))
                .map_err(|_| format!("packet {number}: not RRI's TCP framing (M10): a message longer than 64 KiB or not XML"))?;
        }
    }
    Ok(out)
}

/// The stream's bytes in order, each run with the packet that made it
/// available and that packet's time. `segments` is one connection's one
/// direction (a new SYN starts another: [`connections`]).
///
/// Sequence numbers are unwrapped against the last one seen (each is less
/// than 2^31 from it), so a stream longer than 4 GiB keeps its order, and
/// bytes from before where the stream starts (a capture that began
/// mid-connection, then a retransmission of earlier bytes) are old, not a
/// gap.
pub fn in_order(segments: &[&Segment]) -> Result<Vec<Framed>, String> {
    // Where the stream starts: after the SYN, or (a capture that began
    // mid-connection) at the first segment seen.
    let Some(first) = segments.first() else {
        return Ok(Vec::new());
    };
    let base = segments
        .iter()
        .find_map(|s| match s.transport {
            Transport::Tcp { seq, syn: true, .. } => Some(seq.wrapping_add(1)),
            _ => None,
        })
        .unwrap_or(match first.transport {
            Transport::Tcp { seq, .. } => seq,
            Transport::Udp => 0,
        });
    let mut unwrap = Unwrap {
        last: base,
        offset: 0,
    };
    let mut delivered: u64 = 0;
    let mut early: BTreeMap<u64, (usize, u64, Vec<u8>)> = BTreeMap::new();
    let mut out: Vec<Framed> = Vec::new();
    for s in segments {
        let Transport::Tcp { seq, syn, .. } = s.transport else {
            continue;
        };
        // Data on a SYN starts one after its sequence number.
        let seq = seq.wrapping_add(u32::from(syn));
        let offset = unwrap.offset_of(seq);
        if s.payload.is_empty() {
            continue;
        }
        // Bytes before the stream's start were delivered before the
        // capture began: only what follows them is new.
        let skip = usize::try_from(-offset).unwrap_or(0);
        let Some(bytes) = s.payload.get(skip..).filter(|b| !b.is_empty()) else {
            continue;
        };
        let start = offset.max(0) as u64;
        // A retransmission from the same place keeps the longer of the two.
        let piece = (s.number, s.at_us, bytes.to_vec());
        early
            .entry(start)
            .and_modify(|kept| {
                if piece.2.len() > kept.2.len() {
                    *kept = piece.clone();
                }
            })
            .or_insert_with(|| piece.clone());
        // Deliver whatever now joins what was delivered.
        while let Some((&at, _)) = early.first_key_value() {
            if at > delivered {
                break;
            }
            let Some((at, (_, _, bytes))) = early.pop_first() else {
                break;
            };
            let end = at + bytes.len() as u64;
            if end > delivered {
                // Available in order now: with this packet, whichever
                // packet carried the bytes.
                let new = &bytes[(delivered - at) as usize..];
                out.push((s.number, s.at_us, new.to_vec()));
                delivered = end;
            }
        }
    }
    if let Some((&at, (number, ..))) = early.first_key_value() {
        return Err(format!(
            "a gap in the stream: bytes {delivered} to {at} were never captured (the data of packet {number} comes after them); a capture that lost packets cannot be replayed over TCP"
        ));
    }
    Ok(out)
}

/// Sequence numbers as offsets from the stream's start, unwrapped against
/// the last one seen (TCP keeps every segment within 2^31 of it).
struct Unwrap {
    last: u32,
    offset: i64,
}

impl Unwrap {
    fn offset_of(&mut self, seq: u32) -> i64 {
        self.offset += i64::from(seq.wrapping_sub(self.last) as i32);
        self.last = seq;
        self.offset
    }
}

/// One direction's segments (capture order) split into connections: a
/// SYN starts a new one (a controller that reconnects from the same port
/// starts a new stream, not the old one's continuation).
pub fn connections<'a>(segments: &[&'a Segment]) -> Vec<Vec<&'a Segment>> {
    let mut out: Vec<Vec<&'a Segment>> = Vec::new();
    for s in segments {
        let syn = matches!(s.transport, Transport::Tcp { syn: true, .. });
        match out.last_mut() {
            Some(c) if !syn || c.is_empty() => c.push(s),
            _ => out.push(vec![*s]),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::SocketAddrV4;

    fn seg(number: usize, seq: u32, syn: bool, payload: &[u8]) -> Segment {
        Segment {
            number,
            at_us: number as u64 * 10,
            from: SocketAddrV4::new([10, 0, 0, 1].into(), 5000),
            to: SocketAddrV4::new([10, 0, 0, 2].into(), 3002),
            transport: Transport::Tcp {
                seq,
                syn,
                fin: false,
                rst: false,
            },
            payload: payload.to_vec(),
        }
    }

    fn bytes(out: &[Framed]) -> Vec<u8> {
        out.iter().flat_map(|(_, _, b)| b.clone()).collect()
    }

    #[test]
    fn reordered_retransmitted_and_overlapping_segments_give_the_stream_once() {
        let s = [
            seg(1, 99, true, b""),
            seg(2, 100, false, b"abc"),
            seg(4, 106, false, b"ghi"),  // early
            seg(5, 100, false, b"abc"),  // retransmission
            seg(6, 102, false, b"cdef"), // overlaps, fills the hole
        ];
        let refs: Vec<&Segment> = s.iter().collect();
        let out = in_order(&refs).unwrap();
        assert_eq!(bytes(&out), b"abcdefghi");
        // "ghi" became available with packet 6, which filled the hole.
        assert_eq!(out.last().map(|o| o.0), Some(6));
    }

    #[test]
    fn a_hole_is_named_by_the_packet_after_it() {
        let s = [
            seg(1, 99, true, b""),
            seg(2, 100, false, b"abc"),
            seg(3, 110, false, b"xyz"),
        ];
        let refs: Vec<&Segment> = s.iter().collect();
        let e = in_order(&refs).unwrap_err();
        assert!(e.contains("bytes 3 to 10") && e.contains("packet 3"), "{e}");
    }

    #[test]
    fn a_capture_that_starts_mid_stream_starts_at_its_first_segment() {
        let s = [
            seg(7, 5000, false, b"hello "),
            seg(8, 5006, false, b"world"),
        ];
        let refs: Vec<&Segment> = s.iter().collect();
        assert_eq!(bytes(&in_order(&refs).unwrap()), b"hello world");
    }

    /// Issue 42 #3: a capture that starts mid-stream and then sees a
    /// retransmission of bytes from before its first segment (was: a false
    /// gap of nearly 4 GiB).
    #[test]
    fn a_retransmission_from_before_a_mid_stream_capture_is_old() {
        let s = [
            seg(7, 5000, false, b"hello "),
            seg(8, 4990, false, b"0123456789hel"), // old, then "hel" again
            seg(9, 5006, false, b"world"),
        ];
        let refs: Vec<&Segment> = s.iter().collect();
        assert_eq!(bytes(&in_order(&refs).unwrap()), b"hello world");
    }

    /// Issue 42 #3: past 4 GiB of stream the offsets keep growing (were
    /// taken modulo 2^32, so every later segment was dropped as old).
    #[test]
    fn offsets_past_4_gib_keep_growing() {
        let mut u = Unwrap {
            last: 1000,
            offset: 0,
        };
        let step = 1u32 << 30;
        let mut seq = 1000u32;
        for k in 1..=6i64 {
            seq = seq.wrapping_add(step);
            assert_eq!(u.offset_of(seq), k << 30);
        }
        // A retransmission from before is behind, not 4 GiB ahead.
        assert_eq!(u.offset_of(seq.wrapping_sub(10)), (6i64 << 30) - 10);
    }

    /// Issue 42 #3: a reconnection from the same port starts a new stream
    /// at its SYN (was: joined to the first connection's).
    #[test]
    fn a_reconnection_from_the_same_port_is_a_new_stream() {
        let s = [
            seg(1, 99, true, b""),
            seg(2, 100, false, b"abc"),
            seg(3, 7_000, true, b""),
            seg(4, 7_001, false, b"xyz"),
        ];
        let refs: Vec<&Segment> = s.iter().collect();
        let c = connections(&refs);
        assert_eq!(c.len(), 2);
        assert_eq!(bytes(&in_order(&c[0]).unwrap()), b"abc");
        assert_eq!(bytes(&in_order(&c[1]).unwrap()), b"xyz");
    }

    #[test]
    fn sequence_numbers_wrap() {
        let s = [
            seg(1, u32::MAX, true, b""),
            seg(2, 0, false, b"ab"),
            seg(3, 2, false, b"cd"),
        ];
        let refs: Vec<&Segment> = s.iter().collect();
        assert_eq!(bytes(&in_order(&refs).unwrap()), b"abcd");
    }
}
