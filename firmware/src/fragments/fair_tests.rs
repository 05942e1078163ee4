//! The reassembler's fairness to every sender and its exact matching
//! (issue 36): sets keyed by (source, destination, protocol, ID), exact
//! duplicates dropped alone, options in the header, and buffers given up
//! least recently used first under a sustained attack. The frames are
//! built as in `tests.rs`.

use super::tests::{checksum, cut, feed, frame, udp, CHANNEL, PEER, PORT, R, ROBOT, ROBOT_PORT};
use super::*;

/// An exact copy of a fragment (port mirroring, a layer-2 loop) is
/// dropped alone and counted; the set goes on and completes (issue 36).
#[test]
fn an_exact_duplicate_is_dropped_alone() {
    let mut r = R::new();
    let frags = cut(ROBOT, 9, &udp(ROBOT_PORT, PORT, 3557), 1480);
    for (i, f) in frags.iter().enumerate().take(2) {
        assert_eq!(r.accept(f, 0, CHANNEL, PEER), Verdict::Held);
        assert_eq!(
            r.accept(f, 1, CHANNEL, PEER),
            Verdict::Dropped(FragmentDrop::Duplicate),
            "copy of fragment {i}"
        );
    }
    assert_eq!(feed(&mut r, &frags[2..], 2, PEER).len(), 1);
    let s = r.stats();
    assert_eq!(
        (
            s.duplicate,
            s.spoiled,
            s.controller_dropped,
            s.controller_datagrams
        ),
        (2, 0, 0, 1)
    );
    // The last fragment twice, in front of the others: the same.
    let frags = cut(ROBOT, 10, &udp(ROBOT_PORT, PORT, 3557), 1480);
    assert_eq!(r.accept(&frags[2], 3, CHANNEL, PEER), Verdict::Held);
    assert_eq!(
        r.accept(&frags[2], 3, CHANNEL, PEER),
        Verdict::Dropped(FragmentDrop::Duplicate)
    );
    assert_eq!(feed(&mut r, &frags[..2], 4, PEER).len(), 1);
}

/// A set is one (source, destination, protocol, ID): an ICMP fragment, or
/// one to another address, from the controller's host with a robot
/// message's ID is dropped as unwanted and leaves the set alone (issue 36:
/// it used to spoil it, a loss counted nowhere as the controller's).
#[test]
fn one_id_shared_across_protocols_and_addresses_spoils_nothing() {
    let mut r = R::new();
    let frags = cut(ROBOT, 11, &udp(ROBOT_PORT, PORT, 3000), 1480);
    assert_eq!(r.accept(&frags[0], 0, CHANNEL, PEER), Verdict::Held);
    let icmp = frame(ROBOT, 11, 1, 1480, true, &[0; 16]);
    let mut broadcast = frame(ROBOT, 11, 17, 1480, false, &[0; 16]);
    broadcast[30..34].copy_from_slice(&[10, 49, 65, 255]);
    broadcast[24..26].copy_from_slice(&[0, 0]);
    let sum = checksum(&broadcast[14..34]);
    broadcast[24..26].copy_from_slice(&sum.to_be_bytes());
    for f in [&icmp, &broadcast] {
        assert_eq!(
            r.accept(f, 1, CHANNEL, PEER),
            Verdict::Dropped(FragmentDrop::Unwanted)
        );
        assert_eq!(r.held(), 1, "the robot's set is still held");
    }
    assert_eq!(feed(&mut r, &frags[1..], 2, PEER).len(), 1);
    assert_eq!((r.stats().spoiled, r.stats().unwanted), (0, 2));
}

/// Fragments whose IPv4 header carries options (IHL > 5) are put
/// together like any other: the whole datagram gets a plain header.
#[test]
fn fragments_with_ip_options_are_reassembled() {
    let datagram = udp(ROBOT_PORT, PORT, 3000);
    let with_options = |f: &Vec<u8>| {
        // Four bytes of options (NOP NOP NOP EOL) after the 20 of the
        // header: IHL 6, the total length and the checksum again.
        let mut o = f[..34].to_vec();
        o.extend_from_slice(&[1, 1, 1, 0]);
        o.extend_from_slice(&f[34..]);
        o[14] = 0x46;
        let total = u16::from_be_bytes([o[16], o[17]]) + 4;
        o[16..18].copy_from_slice(&total.to_be_bytes());
        o[24..26].copy_from_slice(&[0, 0]);
        let sum = checksum(&o[14..38]);
        o[24..26].copy_from_slice(&sum.to_be_bytes());
        o
    };
    let frags: Vec<Vec<u8>> = cut(ROBOT, 12, &datagram, 1480)
        .iter()
        .map(with_options)
        .collect();
    let mut r = R::new();
    let got = feed(&mut r, &frags, 0, PEER);
    assert_eq!(got, vec![datagram]);
}

/// The review's attack on buffers (issue 36, item 4), sustained: from
/// the controller's address at another port, a tail fragment with a
/// fresh ID every 7 ms (each ranks "likely", as a reordered robot message
/// does, and would hold a buffer for 8 ms); meanwhile every 4 ms the
/// controller's message arrives last fragment first. Not one of the
/// controller's messages may be lost.
#[test]
fn tail_fragments_every_7_ms_never_keep_the_controllers_reordered_messages_out() {
    let mut r = R::new();
    let mut got = 0;
    let mut attack_ident = 20_000u16;
    let mut next_attack = 0u64;
    let cycles = 2_000u64;
    for cycle in 0..cycles {
        let t = cycle * 4_000;
        // The attacker's tail fragments due before this message.
        while next_attack <= t {
            let tail = frame(ROBOT, attack_ident, 17, 1480, false, &[0xa5; 200]);
            r.accept(&tail, next_attack, CHANNEL, PEER);
            attack_ident = attack_ident.wrapping_add(1);
            next_attack += 7_000;
        }
        let ident = (cycle % 10_000) as u16;
        let frags = cut(ROBOT, ident, &udp(ROBOT_PORT, PORT, 3000), 1480);
        // Last fragment first, the others back to back (µs apart).
        let order = [2, 0, 1];
        for (k, &i) in order.iter().enumerate() {
            if let Verdict::Complete { .. } = r.accept(&frags[i], t + k as u64 * 100, CHANNEL, PEER)
            {
                got += 1;
            }
        }
    }
    let s = r.stats();
    assert_eq!(got, cycles, "{s:?}");
    assert_eq!(
        (s.controller_dropped, s.controller_incomplete),
        (0, 0),
        "{s:?}"
    );
    assert!(
        s.evicted > 0,
        "the attacker's sets gave their buffers up: {s:?}"
    );
}
