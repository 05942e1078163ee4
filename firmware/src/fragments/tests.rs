//! The reassembler against hand-built frames (S5): what is put together,
//! what is dropped and why, who wins a buffer, when a set is given up.

use super::*;

pub(super) const DEVICE: [u8; 4] = [10, 49, 65, 74];
pub(super) const ROBOT: [u8; 4] = [10, 49, 65, 1];
pub(super) const STRANGER: [u8; 4] = [10, 49, 65, 200];
pub(super) const PORT: u16 = 3002;
pub(super) const ROBOT_PORT: u16 = 6510;
pub(super) const CHANNEL: Channel = Channel {
    device: DEVICE,
    port: PORT,
};
pub(super) const PEER: Controller = Controller {
    ip: Some(ROBOT),
    port: Some(ROBOT_PORT),
};
/// The manual's layout: `MAX_RECEIVE_LEN` 3,557.
pub(super) const BUF: usize = buffer_len(3557);
pub(super) type R = Reassembler<BUF>;

pub(super) fn checksum(b: &[u8]) -> u16 {
    let mut sum: u32 = b
        .chunks(2)
        .map(|c| u32::from(u16::from_be_bytes([c[0], *c.get(1).unwrap_or(&0)])))
        .sum();
    while sum > 0xffff {
        sum = (sum & 0xffff) + (sum >> 16);
    }
    !(sum as u16)
}

/// A UDP datagram's IP payload (header with a zero checksum, then `len`
/// bytes counting up).
pub(super) fn udp(sport: u16, dport: u16, len: usize) -> Vec<u8> {
    let mut d = Vec::new();
    d.extend_from_slice(&sport.to_be_bytes());
    d.extend_from_slice(&dport.to_be_bytes());
    d.extend_from_slice(&((8 + len) as u16).to_be_bytes());
    d.extend_from_slice(&[0, 0]);
    d.extend((0..len).map(|i| (i * 7 + 3) as u8));
    d
}

/// One IPv4 frame: `payload` at byte `offset` of its datagram, "more
/// fragments" as given, a correct header checksum.
pub(super) fn frame(
    src: [u8; 4],
    ident: u16,
    proto: u8,
    offset: usize,
    more: bool,
    payload: &[u8],
) -> Vec<u8> {
    let mut f = vec![2, 0, 0, 0, 0, 1, 2, 0, 0, 0, 0, 2, 0x08, 0x00];
    let total = 20 + payload.len();
    let flags = (if more { 0x2000 } else { 0 }) | (offset / 8) as u16;
    let mut h = vec![0x45, 0];
    h.extend_from_slice(&(total as u16).to_be_bytes());
    h.extend_from_slice(&ident.to_be_bytes());
    h.extend_from_slice(&flags.to_be_bytes());
    h.extend_from_slice(&[64, proto, 0, 0]);
    h.extend_from_slice(&src);
    h.extend_from_slice(&DEVICE);
    let sum = checksum(&h);
    h[10..12].copy_from_slice(&sum.to_be_bytes());
    f.extend_from_slice(&h);
    f.extend_from_slice(payload);
    f
}

/// `datagram` cut into fragments of at most `size` bytes (a multiple of 8).
pub(super) fn cut(src: [u8; 4], ident: u16, datagram: &[u8], size: usize) -> Vec<Vec<u8>> {
    let n = datagram.len().div_ceil(size);
    (0..n)
        .map(|i| {
            let part = &datagram[i * size..((i + 1) * size).min(datagram.len())];
            frame(src, ident, 17, i * size, i + 1 < n, part)
        })
        .collect()
}

/// Feeds `frames` at `now` and returns what completed, as IP payloads.
pub(super) fn feed(r: &mut R, frames: &[Vec<u8>], now: u64, ctl: Controller) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    for f in frames {
        if let Verdict::Complete { slot, len } = r.accept(f, now, CHANNEL, ctl) {
            let d = r.datagram(slot, len).unwrap();
            // A whole datagram: no options, not a fragment, its length, a
            // right checksum, the addresses of its fragments.
            assert_eq!(d[14], 0x45);
            assert_eq!(u16::from_be_bytes([d[16], d[17]]) as usize, len - 14);
            assert_eq!(&d[20..22], &[0, 0]);
            assert_eq!(checksum(&d[14..34]), 0);
            assert_eq!(&d[30..34], &DEVICE);
            // The frame on a 4-byte boundary as a driver's is: the UDP
            // payload two bytes past one, as in the socket buffers smoltcp
            // copies it into (the fast copy: both ends aligned alike).
            assert_eq!(
                (d.as_ptr() as usize % 4, d[42..].as_ptr() as usize % 4),
                (0, 2)
            );
            out.push(d[34..].to_vec());
        }
    }
    out
}

#[test]
fn frames_that_are_not_fragments_pass_and_the_controllers_are_counted() {
    let mut r = R::new();
    let robot = frame(ROBOT, 1, 17, 0, false, &udp(ROBOT_PORT, PORT, 700));
    let second_port = frame(ROBOT, 2, 17, 0, false, &udp(ROBOT_PORT + 1, PORT, 64));
    let other_port = frame(ROBOT, 3, 17, 0, false, &udp(ROBOT_PORT, PORT + 1, 64));
    let arp = vec![0xff; 6]
        .into_iter()
        .chain([0; 6])
        .chain([0x08, 0x06, 0, 1])
        .collect::<Vec<u8>>();
    for f in [&robot, &second_port, &other_port, &arp] {
        assert_eq!(r.accept(f, 0, CHANNEL, PEER), Verdict::Pass);
    }
    let s = r.stats();
    assert_eq!((s.fragments, s.controller_datagrams), (0, 1));
    // Before any peer, every sender to the channel port may be the controller.
    r.accept(&second_port, 0, CHANNEL, Controller::ANYONE);
    assert_eq!(r.stats().controller_datagrams, 2);
}

#[test]
fn fragments_in_any_order_make_the_datagram() {
    let datagram = udp(ROBOT_PORT, PORT, 3557);
    let frags = cut(ROBOT, 0x4200, &datagram, 1480);
    assert_eq!(frags.len(), 3);
    for order in [[0, 1, 2], [2, 0, 1], [1, 2, 0], [2, 1, 0]] {
        let mut r = R::new();
        let shuffled: Vec<Vec<u8>> = order.iter().map(|&i| frags[i].clone()).collect();
        let got = feed(&mut r, &shuffled, 0, PEER);
        assert_eq!(got, vec![datagram.clone()], "order {order:?}");
        let s = r.stats();
        assert_eq!(
            (s.fragments, s.reassembled, s.controller_datagrams),
            (3, 1, 1)
        );
        assert_eq!((s.dropped(), s.sets_lost(), r.held()), (0, 0, 0));
    }
}

#[test]
fn pass_hands_the_stack_the_frame_the_datagram_or_nothing() {
    let mut r = R::new();
    let mut whole = frame(ROBOT, 1, 17, 0, false, &udp(ROBOT_PORT, PORT, 100));
    let n = whole.len();
    assert_eq!(r.pass(&mut whole, 0, CHANNEL, PEER, |f| f.len()), n);
    let datagram = udp(ROBOT_PORT, PORT, 2000);
    let frags = cut(ROBOT, 9, &datagram, 1480);
    let mut first = frags[0].clone();
    assert_eq!(r.pass(&mut first, 0, CHANNEL, PEER, |f| f.len()), 0);
    let mut last = frags[1].clone();
    let got = r.pass(&mut last, 0, CHANNEL, PEER, |f| f[34..].to_vec());
    assert_eq!(got, datagram);
}

#[test]
fn an_oversize_set_is_dropped_at_its_first_fragment_past_the_limit() {
    let mut r = R::new();
    // Before any peer anyone may be the controller, and an oversize set
    // of theirs is no robot message: given up, not the controller's loss.
    let mut r0 = R::new();
    let frags = cut(ROBOT, 9, &udp(ROBOT_PORT, PORT, 9000), 1480);
    feed(&mut r0, &frags, 0, Controller::ANYONE);
    assert_eq!((r0.stats().spoiled, r0.stats().controller_dropped), (1, 0));
    // Two 9,000-byte datagrams (the attack), in order: the first
    // two fragments of each fit and are held, the third goes past the
    // layout's 3,565 bytes and frees the buffer, the rest never take one.
    for ident in [1, 2] {
        let frags = cut(STRANGER, ident, &udp(40000, PORT, 9000), 1480);
        assert_eq!(frags.len(), 7);
        for (i, f) in frags.iter().enumerate() {
            let v = r.accept(f, 0, CHANNEL, PEER);
            if i < 2 {
                assert_eq!(v, Verdict::Held);
            } else {
                assert_eq!(v, Verdict::Dropped(FragmentDrop::Oversize));
                assert_eq!(r.held(), 0, "no buffer held past fragment {i}");
            }
        }
    }
    // Last fragment first (out of order): dropped at once, never held.
    let frags = cut(STRANGER, 3, &udp(40000, PORT, 9000), 1480);
    assert_eq!(
        r.accept(&frags[6], 0, CHANNEL, PEER),
        Verdict::Dropped(FragmentDrop::Oversize)
    );
    assert_eq!(r.held(), 0);
    let s = r.stats();
    assert_eq!(
        (s.fragments, s.oversize, s.spoiled, s.reassembled),
        (15, 11, 2, 0)
    );
    // The controller's next message is put together at once.
    let datagram = udp(ROBOT_PORT, PORT, 3557);
    assert_eq!(
        feed(&mut r, &cut(ROBOT, 7, &datagram, 1480), 0, PEER),
        vec![datagram]
    );
}

#[test]
fn fragments_not_udp_to_the_channel_port_are_unwanted() {
    let mut r = R::new();
    let tcp = frame(ROBOT, 1, 6, 0, true, &[0; 1480]);
    let mut elsewhere = frame(ROBOT, 2, 17, 1480, false, &[0; 100]);
    elsewhere[30..34].copy_from_slice(&[10, 49, 65, 255]);
    let sum_fix = |f: &mut Vec<u8>| {
        f[24..26].copy_from_slice(&[0, 0]);
        let s = checksum(&f[14..34]);
        f[24..26].copy_from_slice(&s.to_be_bytes());
    };
    sum_fix(&mut elsewhere);
    for f in [&tcp, &elsewhere] {
        assert_eq!(
            r.accept(f, 0, CHANNEL, PEER),
            Verdict::Dropped(FragmentDrop::Unwanted)
        );
    }
    // A set held from its last fragment, spoiled when its first shows
    // another port.
    let frags = cut(ROBOT, 3, &udp(ROBOT_PORT, 5000, 2000), 1480);
    assert_eq!(r.accept(&frags[1], 0, CHANNEL, PEER), Verdict::Held);
    assert_eq!(
        r.accept(&frags[0], 0, CHANNEL, PEER),
        Verdict::Dropped(FragmentDrop::Unwanted)
    );
    let s = r.stats();
    assert_eq!((s.unwanted, s.spoiled, r.held()), (3, 1, 0));
}

#[test]
fn malformed_fragments_are_dropped_and_spoil_their_set() {
    let datagram = udp(ROBOT_PORT, PORT, 3000);
    let frags = cut(ROBOT, 5, &datagram, 1480);
    let mut bad_sum = frags[0].clone();
    bad_sum[24] ^= 1;
    let odd = frame(ROBOT, 6, 17, 0, true, &[0; 1001]);
    let empty = frame(ROBOT, 7, 17, 8, true, &[]);
    let mut short = frags[1].clone();
    short.truncate(short.len() - 1);
    let mut options = frags[1].clone();
    options[14] = 0x44; // IHL 4: shorter than a header
    for f in [&bad_sum, &odd, &empty, &short, &options] {
        let mut r = R::new();
        assert_eq!(
            r.accept(f, 0, CHANNEL, PEER),
            Verdict::Dropped(FragmentDrop::Malformed)
        );
        assert_eq!(r.held(), 0);
    }
    // Overlap: other bytes where bytes are held spoil the set (as Linux
    // does since FragmentSmack), so does a second, different end.
    let mut r = R::new();
    assert_eq!(r.accept(&frags[0], 0, CHANNEL, PEER), Verdict::Held);
    let mut other_bytes = frags[0].clone();
    let last = other_bytes.len() - 1;
    other_bytes[last] ^= 1;
    assert_eq!(
        r.accept(&other_bytes, 0, CHANNEL, PEER),
        Verdict::Dropped(FragmentDrop::Malformed)
    );
    assert_eq!(
        (r.held(), r.stats().spoiled, r.stats().controller_dropped),
        (0, 1, 1)
    );
    let early_end = frame(ROBOT, 5, 17, 1480, false, &[0; 16]);
    assert_eq!(r.accept(&frags[2], 0, CHANNEL, PEER), Verdict::Held);
    assert_eq!(
        r.accept(&early_end, 0, CHANNEL, PEER),
        Verdict::Dropped(FragmentDrop::Malformed)
    );
    assert_eq!(r.held(), 0);
}

#[test]
fn an_incomplete_set_is_given_up_after_the_timeout() {
    let mut r = R::new();
    let frags = cut(ROBOT, 8, &udp(ROBOT_PORT, PORT, 3557), 1480);
    // The last fragment is lost.
    feed(&mut r, &frags[..2], 1_000, PEER);
    r.expire(1_000 + TIMEOUT_US - 1);
    assert_eq!(r.held(), 1);
    r.expire(1_000 + TIMEOUT_US);
    assert_eq!(r.held(), 0);
    let s = r.stats();
    assert_eq!(
        (s.timed_out, s.controller_incomplete, s.controller_dropped),
        (1, 1, 0)
    );
    // Its straggler comes later: a new set, held until its own timeout.
    assert_eq!(r.accept(&frags[2], 20_000, CHANNEL, PEER), Verdict::Held);
    r.expire(20_000 + TIMEOUT_US);
    assert_eq!(r.stats().timed_out, 2);
    // A stranger's set is not the controller's.
    r.accept(
        &cut(STRANGER, 1, &udp(1, PORT, 2000), 1480)[0],
        30_000,
        CHANNEL,
        PEER,
    );
    r.expire(40_000);
    assert_eq!(
        (r.stats().timed_out, r.stats().controller_incomplete),
        (3, 1)
    );
}

#[test]
fn the_controller_wins_a_buffer_over_strangers_and_over_its_own_older_set() {
    let mut r = R::new();
    let stranger = |ident| cut(STRANGER, ident, &udp(40000, PORT, 3000), 1480);
    let other_port = |ident| cut(ROBOT, ident, &udp(ROBOT_PORT + 1, PORT, 3000), 1480);
    // Strangers hold both buffers; another stranger takes the buffer of
    // the one least recently heard from.
    assert_eq!(r.accept(&stranger(1)[0], 0, CHANNEL, PEER), Verdict::Held);
    assert_eq!(r.accept(&stranger(2)[0], 10, CHANNEL, PEER), Verdict::Held);
    assert_eq!(r.accept(&stranger(3)[0], 20, CHANNEL, PEER), Verdict::Held);
    assert_eq!(r.stats().evicted, 1);
    // The controller's address (another port, or fragments before the
    // first) ranks above a stranger: it takes the oldest stranger's buffer.
    assert_eq!(
        r.accept(&other_port(4)[0], 30, CHANNEL, PEER),
        Verdict::Held
    );
    assert_eq!(r.stats().evicted, 2);
    // The controller itself takes the other stranger's.
    let robot = |ident| cut(ROBOT, ident, &udp(ROBOT_PORT, PORT, 2000), 1480);
    assert_eq!(r.accept(&robot(5)[0], 40, CHANNEL, PEER), Verdict::Held);
    // Then the other port's, not its own.
    assert_eq!(r.accept(&robot(6)[0], 50, CHANNEL, PEER), Verdict::Held);
    assert_eq!((r.stats().evicted, r.stats().controller_dropped), (4, 0));
    // Both buffers are the controller's: its newest message supersedes
    // its oldest incomplete one; nobody else gets in.
    assert_eq!(
        r.accept(&other_port(7)[0], 60, CHANNEL, PEER),
        Verdict::Dropped(FragmentDrop::NoBuffer)
    );
    assert_eq!(r.accept(&robot(8)[0], 70, CHANNEL, PEER), Verdict::Held);
    let s = r.stats();
    assert_eq!(
        (s.evicted, s.controller_incomplete, s.controller_dropped),
        (5, 1, 0)
    );
    // And both of its newest sets still complete.
    let got = feed(
        &mut r,
        &[robot(6)[1].clone(), robot(8)[1].clone()],
        80,
        PEER,
    );
    assert_eq!(got.len(), 2);
    assert_eq!(r.stats().controller_datagrams, 2);
}

#[test]
fn a_set_is_ranked_again_when_its_first_fragment_shows_the_ports() {
    let mut r = R::new();
    // Last fragments first: both sets from the controller's address rank
    // "likely"; the first fragments show one is the controller's.
    let robot = cut(ROBOT, 1, &udp(ROBOT_PORT, PORT, 2000), 1480);
    let other = cut(ROBOT, 2, &udp(ROBOT_PORT + 1, PORT, 2000), 1480);
    r.accept(&robot[1], 0, CHANNEL, PEER);
    r.accept(&other[1], 1, CHANNEL, PEER);
    r.accept(&other[0], 2, CHANNEL, PEER); // completes: handed on, not the controller's
    r.accept(&robot[0], 3, CHANNEL, PEER);
    let s = r.stats();
    assert_eq!((s.reassembled, s.controller_datagrams), (2, 1));
}

/// A tiny xorshift for the shuffles below.
fn rng(mut x: u64) -> impl FnMut() -> u64 {
    move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    }
}

#[test]
fn strangers_interleaved_with_the_controller_never_cost_it_a_message() {
    let mut next = rng(0x5eed);
    let mut r = R::new();
    let mut now = 0;
    for n in 0..500u16 {
        // A robot message in 2 or 3 fragments, in order (as a controller
        // and Linux send them), mixed at random positions with the
        // fragments of strangers' sets that never complete (a first or a
        // middle fragment) and oversize ones, from a stranger and from a
        // second port of the controller's address.
        let len = 1500 + (next() % 2000) as usize;
        let datagram = udp(ROBOT_PORT, PORT, len);
        let mut robot = cut(ROBOT, n, &datagram, 1480).into_iter();
        let mut attack: Vec<Vec<u8>> = Vec::new();
        for k in 0..(next() % 6) {
            let who = if next().is_multiple_of(2) {
                STRANGER
            } else {
                ROBOT
            };
            let sport = if who == ROBOT { ROBOT_PORT + 1 } else { 40000 };
            let ident = 10_000 + n * 8 + k as u16;
            let frags = cut(who, ident, &udp(sport, PORT, 9000), 1480);
            attack.push(frags[(next() % 7) as usize].clone());
        }
        let mut frames = Vec::new();
        let mut attack = attack.into_iter();
        loop {
            let pick_robot = next().is_multiple_of(2);
            match (pick_robot, robot.len(), attack.len()) {
                (_, 0, 0) => break,
                (true, 1.., _) | (_, 1.., 0) => frames.push(robot.next().unwrap()),
                _ => frames.push(attack.next().unwrap()),
            }
        }
        assert_eq!(
            feed(&mut r, &frames, now, PEER),
            vec![datagram],
            "message {n}"
        );
        now += 4_000;
    }
    let s = r.stats();
    assert_eq!(
        (
            s.controller_datagrams,
            s.controller_dropped,
            s.controller_incomplete
        ),
        (500, 0, 0)
    );
    assert!(s.evicted + s.no_buffer + s.oversize > 0, "{s:?}");
}

#[test]
fn counters_saturate_and_stats_add_up() {
    let mut s = FragmentStats::ZERO;
    // Past 2^32 (issue 42 #11: a u32 stopped there), on to u64's end.
    s.no_buffer = u64::from(u32::MAX);
    s.count_drop(FragmentDrop::NoBuffer);
    assert_eq!(s.no_buffer, 1 << 32);
    s.no_buffer = u64::MAX;
    s.count_drop(FragmentDrop::NoBuffer);
    assert_eq!(s.no_buffer, u64::MAX);
    s.count_loss(SetLoss::Superseded, Rank::Controller);
    assert_eq!(
        (s.evicted, s.controller_incomplete, s.sets_lost()),
        (1, 1, 1)
    );
    s.count_loss(SetLoss::Spoiled, Rank::Controller);
    assert_eq!((s.spoiled, s.controller_dropped, s.sets_lost()), (1, 1, 2));
    assert_eq!(
        FragmentDrop::Oversize.to_string(),
        "fragment past what the layout accepts (S5)"
    );
}

#[test]
fn the_controller_is_the_peer_else_the_pinned_address_else_anyone() {
    let peer = Endpoint::new(ROBOT, ROBOT_PORT);
    let pinned = Pinned {
        ip: STRANGER,
        port: None,
    };
    assert_eq!(Controller::of(Some(peer), Some(pinned)), PEER);
    let c = Controller::of(None, Some(pinned));
    assert!(c.sent(STRANGER, 1) && !c.from_address(ROBOT));
    assert!(Controller::of(None, None).sent(ROBOT, 9));
    assert!(PEER.from_address(ROBOT) && !PEER.sent(ROBOT, ROBOT_PORT + 1));
}
