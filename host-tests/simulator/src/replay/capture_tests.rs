//! The capture reader's own checks: timestamp resolutions, simple packet
//! blocks.

use super::*;

#[test]
fn timestamp_resolutions_decimal_and_binary() {
    // The default (no option): microseconds.
    assert_eq!(units_per_second(6), Some(1_000_000));
    assert_eq!(units_per_second(9), Some(1_000_000_000));
    // Bit 7: a power of two (2^-30 s units).
    assert_eq!(units_per_second(0x80 | 30), Some(1 << 30));
    assert_eq!(units_per_second(20), None);
    assert_eq!(units_per_second(0x80 | 64), None);
}

/// The blocks of a little-endian pcapng file: (type, body).
fn blocks(b: &[u8]) -> Vec<(u32, Vec<u8>)> {
    let mut out = Vec::new();
    let mut at = 0;
    while at + 12 <= b.len() {
        let kind = u32::from_le_bytes(b[at..at + 4].try_into().unwrap());
        let len = u32::from_le_bytes(b[at + 4..at + 8].try_into().unwrap()) as usize;
        out.push((kind, b[at + 8..at + len - 4].to_vec()));
        at += len;
    }
    out
}

fn block(kind: u32, body: &[u8]) -> Vec<u8> {
    let total = (12 + body.len()) as u32;
    let mut v = kind.to_le_bytes().to_vec();
    v.extend_from_slice(&total.to_le_bytes());
    v.extend_from_slice(body);
    v.extend_from_slice(&total.to_le_bytes());
    v
}

/// Issue 42 #4: a pcapng interface with binary timestamps (2^-30 s,
/// if_tsresol 0x9e) reads at the right times (was: as microseconds,
/// about 1000× too large), and a simple packet block gets the time of
/// the packet before it (was: 0, the epoch) and is counted.
#[test]
fn binary_timestamps_and_simple_packet_blocks_read_at_the_right_time() {
    let dir = std::env::temp_dir().join(format!("rri-tsresol-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let made = dir.join("made.pcapng");
    let (a, b): (std::net::SocketAddr, std::net::SocketAddr) = (
        "10.0.0.1:40000".parse().unwrap(),
        "10.0.0.2:3002".parse().unwrap(),
    );
    let packets: Vec<crate::pcap::Packet> = [0u64, 4_000, 8_000]
        .iter()
        .map(|&at_us| crate::pcap::Packet {
            at_us,
            from: a,
            to: b,
            payload: b"<RobData Id=\"1\"/>".to_vec(),
        })
        .collect();
    let start = 1_700_000_000_000_000u64;
    crate::pcap::write_pcap(&made, &packets, start, false).unwrap();
    let mut out = Vec::new();
    for (k, (kind, mut body)) in blocks(&std::fs::read(&made).unwrap())
        .into_iter()
        .enumerate()
    {
        match kind {
            1 => {
                // if_tsresol (9) = 0x9e, then opt_endofopt.
                body.extend_from_slice(&[9, 0, 1, 0, 0x9e, 0, 0, 0, 0, 0, 0, 0]);
                out.extend(block(1, &body));
            }
            6 if k == 3 => {
                // The second packet as a simple packet block.
                let data = &body[20..];
                let mut spb = (data.len() as u32).to_le_bytes().to_vec();
                spb.extend_from_slice(data);
                spb.resize(4 + data.len().div_ceil(4) * 4, 0);
                out.extend(block(3, &spb));
            }
            6 => {
                let us = (u64::from(u32::from_le_bytes(body[4..8].try_into().unwrap())) << 32)
                    | u64::from(u32::from_le_bytes(body[8..12].try_into().unwrap()));
                let ticks = (u128::from(us) << 30) / 1_000_000;
                body[4..8].copy_from_slice(&((ticks >> 32) as u32).to_le_bytes());
                body[8..12].copy_from_slice(&(ticks as u32).to_le_bytes());
                out.extend(block(6, &body));
            }
            _ => out.extend(block(kind, &body)),
        }
    }
    let file = dir.join("binary.pcapng");
    std::fs::write(&file, out).unwrap();
    let c = read(&file).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    let at: Vec<u64> = c.segments.iter().map(|s| s.at_us - start).collect();
    // Within a microsecond of the truth (2^-30 s ticks round down).
    assert_eq!(at.len(), 3);
    assert!(at[0] <= 1 && at[2].abs_diff(8_000) <= 1, "{at:?}");
    assert_eq!(
        at[1], at[0],
        "the simple packet block takes the time before it"
    );
    assert_eq!(c.untimed, vec![2]);
}
