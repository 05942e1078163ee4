//! A controller datagram counts only once it is valid, and a datagram
//! that came in fragments has its UDP checksum checked by the guard
//! itself, whatever the driver declares: no NIC can check the checksum of
//! a payload that arrived in pieces (issue 36, finding 6).

use super::tests::{
    checksum, cut, feed, frame, udp, CHANNEL, DEVICE, PEER, PORT, R, ROBOT, ROBOT_PORT,
};
use super::*;

/// `datagram` (UDP header and payload) from `src` to the device with its
/// UDP checksum filled in.
fn with_checksum(src: [u8; 4], mut datagram: Vec<u8>) -> Vec<u8> {
    datagram[6..8].copy_from_slice(&[0, 0]);
    let mut pseudo = Vec::new();
    pseudo.extend_from_slice(&src);
    pseudo.extend_from_slice(&DEVICE);
    pseudo.extend_from_slice(&[0, 17]);
    pseudo.extend_from_slice(&(datagram.len() as u16).to_be_bytes());
    pseudo.extend_from_slice(&datagram);
    let sum = match checksum(&pseudo) {
        // 0 means "none": a computed 0 goes out as all ones (RFC 768).
        0 => 0xffff,
        s => s,
    };
    datagram[6..8].copy_from_slice(&sum.to_be_bytes());
    datagram
}

#[test]
fn a_reassembled_datagram_with_a_right_checksum_passes_checked_once() {
    let datagram = with_checksum(ROBOT, udp(ROBOT_PORT, PORT, 3000));
    let mut r = R::new();
    let out = feed(&mut r, &cut(ROBOT, 1, &datagram, 1480), 0, PEER);
    assert_eq!(out.len(), 1);
    // Checked here, so zeroed: the stack takes 0 as "no checksum" and
    // does not check it a second time.
    assert_eq!(&out[0][6..8], &[0, 0]);
    assert_eq!(&out[0][8..], &datagram[8..]);
    let s = r.stats();
    assert_eq!(
        (s.reassembled, s.controller_datagrams, s.spoiled),
        (1, 1, 0)
    );
    // No checksum at all (0) passes as it is.
    let out = feed(
        &mut r,
        &cut(ROBOT, 2, &udp(ROBOT_PORT, PORT, 2000), 1480),
        0,
        PEER,
    );
    assert_eq!(out.len(), 1);
}

#[test]
fn a_reassembled_datagram_with_a_wrong_checksum_is_dropped_and_counted_as_the_controllers() {
    let datagram = with_checksum(ROBOT, udp(ROBOT_PORT, PORT, 3000));
    let mut bad = datagram.clone();
    bad[1000] ^= 0x10;
    let mut r = R::new();
    assert!(feed(&mut r, &cut(ROBOT, 7, &bad, 1480), 0, PEER).is_empty());
    let s = r.stats();
    assert_eq!(
        (
            s.reassembled,
            s.controller_datagrams,
            s.spoiled,
            s.controller_dropped,
            s.malformed
        ),
        (0, 0, 1, 1, 1),
        "{s:?}"
    );
    // A UDP length past the datagram's end: the same.
    let mut long = datagram.clone();
    long[4..6].copy_from_slice(&(datagram.len() as u16 + 8).to_be_bytes());
    assert!(feed(&mut r, &cut(ROBOT, 8, &long, 1480), 0, PEER).is_empty());
    assert_eq!(r.stats().controller_dropped, 2);
    // The right one after them still comes through.
    assert_eq!(
        feed(&mut r, &cut(ROBOT, 9, &datagram, 1480), 0, PEER).len(),
        1
    );
    assert_eq!(r.stats().controller_datagrams, 1);
}

#[test]
fn a_whole_controller_datagram_is_counted_only_with_a_valid_header() {
    let mut r = R::new();
    let good = frame(ROBOT, 1, 17, 0, false, &udp(ROBOT_PORT, PORT, 700));
    let mut broken = good.clone();
    broken[14 + 10] ^= 0xff; // the header checksum
    let mut short = good.clone();
    short.truncate(good.len() - 1); // the IPv4 length past the frame
    for f in [&broken, &short] {
        assert_eq!(
            r.accept(f, 0, CHANNEL, PEER),
            Verdict::Pass,
            "the stack's to drop"
        );
        assert!(!r.to_channel(), "not a robot message: no hold for it");
    }
    assert_eq!(r.stats().controller_datagrams, 0);
    r.accept(&good, 0, CHANNEL, PEER);
    assert!(r.to_channel());
    assert_eq!(r.stats().controller_datagrams, 1);
}
