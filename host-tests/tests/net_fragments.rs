//! S5 on the boards' own network path, in one process: the UDP cycle task
//! on embassy-net behind the fragment guard every board runs, over the
//! in-memory Ethernet, with real Ethernet/IPv4/UDP frames. Robot messages
//! longer than a frame are answered whatever other senders did before or
//! meanwhile: oversize fragment sets, incomplete ones, strangers' sets
//! interleaved with the controller's. Time is embassy-time's mock clock
//! (deterministic); every figure printed is mock time.

mod memnet;

use host_tests::layouts::anydevice::{self as layout, SensDataMessage};
use memnet::udp::{
    await_reply, padded_robdata, robot_fragments, udp_fragments, with_udp_device, ROBOT_PORT,
};
use memnet::{Frames, ROBOT_IP};
use rri_firmware::codec::decode;
use rri_firmware::engine::Engine;
use rri_firmware::fragments::{FragmentStats, TIMEOUT_US};

type DeviceEngine = Engine<layout::RobotProperties, layout::DeviceProperties>;

const STRANGER: [u8; 4] = [10, 49, 65, 200];
/// A second port of the controller's address: the attacker.
const SECOND_PORT: ([u8; 4], u16) = (ROBOT_IP, 40000);

/// Answers with the layout's reply, nothing else.
struct Echo;

impl rri_firmware::engine::Application<layout::RobotProperties, layout::DeviceProperties> for Echo {
    fn cycle(
        &mut self,
        _: &layout::RobotProperties,
        _: &mut layout::DeviceProperties,
        _: &rri_firmware::engine::CycleInfo<'_>,
    ) {
    }
}

fn engine() -> DeviceEngine {
    Engine::new(layout::ENGINE_CONFIG)
}

fn push(to_device: &Frames, frames: impl IntoIterator<Item = Vec<u8>>) {
    to_device.borrow_mut().extend(frames);
}

/// A robot message of `MAX_RECEIVE_LEN` bytes (three fragments) with Id
/// `id`, its fragments in `order`; the µs of mock time to its reply, or
/// `None` when none came within 4 ms.
fn robot_round(
    step: &mut dyn FnMut(usize),
    to_device: &Frames,
    from_device: &Frames,
    id: u32,
    order: [usize; 3],
) -> Option<u64> {
    let request = padded_robdata(id, layout::MAX_RECEIVE_LEN);
    let frags = robot_fragments(&request, 1480, id as u16);
    push(to_device, order.iter().map(|&i| frags[i].clone()));
    let (payload, _, steps) = await_reply(step, to_device, from_device, 400)?;
    let mut data = layout::SensorData::default();
    let d = decode::<SensDataMessage>(&payload, &mut data).expect("the reply decodes");
    assert_eq!(d.id, id, "M8: the reply is to this message");
    Some(steps as u64 * 10)
}

/// Lets mock time run to the next 4 ms robot cycle.
fn rest_of_cycle(step: &mut dyn FnMut(usize), spent_us: u64) {
    step((4_000u64.saturating_sub(spent_us) / 10) as usize);
}

/// A 9,000-byte datagram to the channel port (seven fragments): larger
/// than any robot message of the layout.
fn oversize(from: ([u8; 4], u16), ident: u16) -> Vec<Vec<u8>> {
    udp_fragments(from, &[b'<'; 9000], 1480, ident)
}

#[test]
fn two_oversize_datagrams_lock_nobody_out() {
    let mut app = Echo;
    let mut e = engine();
    with_udp_device(&mut e, &mut app, |step, to, from, link| {
        let before = robot_round(step, to, from, 1, [0, 1, 2]).expect("answered before");
        rest_of_cycle(step, before);
        // The attack: two 9,000-byte datagrams from another port of
        // the controller's address. smoltcp alone kept both sets for 60 s
        // in its two buffers and dropped every fragmented robot message.
        push(to, oversize(SECOND_PORT, 0x9000));
        push(to, oversize(SECOND_PORT, 0x9001));
        step(20);
        let s = link.stats();
        assert_eq!(
            (s.fragments, s.oversize, s.spoiled),
            (3 + 14, 10, 2),
            "{s:?}"
        );
        let mut after = Vec::new();
        for id in 2..=9 {
            let us = robot_round(step, to, from, id, [0, 1, 2])
                .unwrap_or_else(|| panic!("message {id} after the attack not answered"));
            after.push(us);
            rest_of_cycle(step, us);
        }
        println!(
            "S5: fragmented message answered in {before} µs before two 9,000-byte datagrams, {} µs right after (mock time)",
            after[0]
        );
        assert!(after[0] <= before + 20, "{after:?} vs {before}");
    });
    let s = e.stats();
    assert_eq!((s.received, s.answered), (9, 9));
    assert_eq!(s.fragments.controller_datagrams, 9);
    assert_eq!(s.fragments.reassembled, 9);
}

#[test]
fn the_controllers_own_lost_fragment_costs_one_message_and_is_given_up() {
    let mut app = Echo;
    let mut e = engine();
    with_udp_device(&mut e, &mut app, |step, to, from, link| {
        let us = robot_round(step, to, from, 1, [0, 1, 2]).expect("answered");
        rest_of_cycle(step, us);
        // Message 2 loses its last fragment on the way.
        let frags = robot_fragments(&padded_robdata(2, layout::MAX_RECEIVE_LEN), 1480, 2);
        push(to, frags[..2].to_vec());
        assert!(await_reply(step, to, from, 400).is_none());
        // Message 3 is answered at once: the incomplete set does not stand
        // in its way (the controller's newer set would take its buffer).
        let us = robot_round(step, to, from, 3, [0, 1, 2]).expect("message 3 answered");
        assert!(us <= 1_000, "{us} µs");
        // Message 2's set is given up two cycles after it began.
        step((TIMEOUT_US / 10) as usize);
        let s = link.stats();
        assert_eq!(
            (s.timed_out, s.controller_incomplete, s.controller_dropped),
            (1, 1, 0)
        );
    });
    assert_eq!(e.stats().lost, 1, "S3: the engine saw Id 2 missing");
}

#[test]
fn incomplete_sets_from_the_controllers_address_never_keep_its_messages_out() {
    let mut app = Echo;
    let mut e = engine();
    with_udp_device(&mut e, &mut app, |step, to, from, link| {
        let us = robot_round(step, to, from, 1, [0, 1, 2]).expect("answered");
        rest_of_cycle(step, us);
        // A second port of the controller's address sends the last
        // fragments of two sets and nothing else: both buffers held by sets
        // that may be the controller's (their first fragment, with the
        // ports, never comes).
        push(to, [oversize_tail(0xa000), oversize_tail(0xa001)]);
        step(5);
        assert_eq!(link.stats().fragments, 3 + 2);
        // The robot's messages come last fragment first (as a switch may
        // reorder them), ranking "likely" like those sets until their first
        // fragment comes: the least recently used set gives its buffer up
        // (issue 36; before, they waited for the sets' timeout), so every
        // one is answered, the first at once.
        for id in 2..=8 {
            let us = robot_round(step, to, from, id, [2, 1, 0])
                .unwrap_or_else(|| panic!("message {id} not answered: {:?}", link.stats()));
            rest_of_cycle(step, us);
        }
        let s = link.stats();
        println!("S5: every out-of-order fragmented message answered beside two incomplete sets from the controller's address: {s:?}");
        assert!(s.timed_out + s.evicted >= 2, "both sets given up: {s:?}");
        assert_eq!(
            (s.controller_dropped, s.controller_incomplete),
            (0, 0),
            "{s:?}"
        );
    });
}

/// The last fragment (offset 2,960, 48 bytes) of a 3,000-byte datagram
/// from a second port of the controller's address.
fn oversize_tail(ident: u16) -> Vec<u8> {
    udp_fragments(SECOND_PORT, &[b'<'; 3000], 1480, ident)
        .pop()
        .unwrap()
}

#[test]
fn strangers_sets_interleaved_with_the_controllers_cost_it_nothing() {
    let mut app = Echo;
    let mut e = engine();
    let mut x: u64 = 0x5eed_2700;
    let mut next = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    };
    let rounds = 200u32;
    let mut ident = 0x8000u16;
    with_udp_device(&mut e, &mut app, |step, to, from, link| {
        // The controller speaks first: before that anyone may be it.
        let us = robot_round(step, to, from, 1, [0, 1, 2]).expect("answered");
        rest_of_cycle(step, us);
        for id in 2..=rounds {
            let request = padded_robdata(id, layout::MAX_RECEIVE_LEN);
            let robot = robot_fragments(&request, 1480, id as u16);
            // Before, between and after the robot's fragments: single
            // fragments of strangers' sets (incomplete ones, and pieces of
            // oversize ones), from a foreign address and from a second port
            // of the controller's address.
            let mut frames = Vec::new();
            for r in robot {
                for k in 0..(next() % 3) {
                    let who = if next().is_multiple_of(2) {
                        (STRANGER, 40000)
                    } else {
                        SECOND_PORT
                    };
                    ident = ident.wrapping_add(1) | 0x8000;
                    let set = oversize(who, ident);
                    let _ = k;
                    frames.push(set[(next() % set.len() as u64) as usize].clone());
                }
                frames.push(r);
            }
            push(to, frames);
            let (payload, _, steps) = await_reply(step, to, from, 400)
                .unwrap_or_else(|| panic!("message {id} not answered"));
            let mut data = layout::SensorData::default();
            assert_eq!(
                decode::<SensDataMessage>(&payload, &mut data).unwrap().id,
                id
            );
            rest_of_cycle(step, steps as u64 * 10);
        }
        let s: FragmentStats = link.stats();
        println!("S5: {rounds} fragmented robot messages among strangers' fragments: {s:?}");
        assert_eq!(s.controller_datagrams, u64::from(rounds));
        assert_eq!((s.controller_dropped, s.controller_incomplete), (0, 0));
        assert!(s.evicted + s.no_buffer > 0 && s.oversize > 0, "{s:?}");
    });
    let s = e.stats();
    assert_eq!(
        (s.received, s.answered),
        (u64::from(rounds), u64::from(rounds))
    );
    assert_eq!(
        s.fragments.controller_datagrams,
        u64::from(rounds),
        "the engine has the guard's counters"
    );
}

#[test]
fn before_any_peer_strangers_sets_do_not_keep_the_first_message_out() {
    let mut app = Echo;
    let mut e = engine();
    with_udp_device(&mut e, &mut app, |step, to, from, link| {
        // Strangers hold both buffers with incomplete sets to the channel
        // port before the controller ever spoke (anyone may be the
        // controller then).
        for ident in [1, 2] {
            push(to, [oversize((STRANGER, 40000), ident)[0].clone()]);
        }
        step(5);
        let us = robot_round(step, to, from, 1, [0, 1, 2]).expect("the first message answered");
        assert!(us <= 1_000, "{us} µs");
        assert_eq!(link.stats().evicted, 1);
    });
    assert_eq!(
        e.peer().map(|p| (p.ip, p.port)),
        Some((ROBOT_IP, ROBOT_PORT))
    );
}

#[test]
fn a_burst_of_flood_datagrams_never_crowds_the_robots_message_out_of_the_socket() {
    let mut app = Echo;
    let mut e = engine();
    with_udp_device(&mut e, &mut app, |step, to, from, _| {
        let us = robot_round(step, to, from, 1, [0, 1, 2]).expect("answered");
        rest_of_cycle(step, us);
        // Forty 1,400-byte datagrams from a second port of the controller's
        // address reach the driver at once, then the robot's message. Taken
        // in one poll they would fill the socket's queue (4 × 3,557 bytes)
        // before the cycle could empty it, and the robot's message would be
        // dropped there; the guard ends a poll after each datagram for the
        // channel port, so the cycle empties the queue in between.
        let junk = vec![b'#'; 1400];
        push(
            to,
            (0..40).map(|_| memnet::udp::udp_frame(SECOND_PORT, &junk)),
        );
        let us = robot_round(step, to, from, 2, [0, 1, 2]).expect("answered after the burst");
        println!("S5: fragmented message answered {us} µs after a burst of 40 flood datagrams (mock time)");
    });
    let s = e.stats();
    assert_eq!(s.answered, 2);
    assert_eq!(
        s.received,
        2 + 40,
        "every flood datagram reached the engine too"
    );
}

/// `host-tests/gsi/fragmented` (the QEMU board's S5 run in CI): every
/// robot message the simulator sends is longer than one frame, so it
/// always arrives in fragments, and decodes with the layout.
#[test]
fn the_fragmented_configuration_never_fits_one_frame() {
    use host_tests::layouts::fragmented as frag;
    use rri_robot::motion::Motion;
    let gsi = host_tests::workspace().join("host-tests/gsi/fragmented/GSI");
    let device = gsi_config::load(&gsi, None).expect("loads").device;
    let prop = device.received().next().expect("a robot property");
    let motion = Motion::new(&device);
    let (mut shortest, mut longest) = (usize::MAX, 0);
    for cycle in 0..20_000u64 {
        let t = cycle as f64 * 0.004;
        let msg =
            rri_robot::wire::robot_message(&device, prop, cycle as u32 + 1, Motion::now(t), |f| {
                motion.value(f, cycle, t)
            });
        shortest = shortest.min(msg.len());
        longest = longest.max(msg.len());
        if cycle % 997 == 0 {
            let mut data = frag::RobotData::default();
            let d = decode::<frag::RobDataMessage>(msg.as_bytes(), &mut data)
                .unwrap_or_else(|e| panic!("cycle {cycle}: {e:?}"));
            assert_eq!(d.id, cycle as u32 + 1);
        }
    }
    println!(
        "fragmented configuration: robot messages {shortest}..{longest} bytes, MAX_RECEIVE_LEN {}",
        frag::MAX_RECEIVE_LEN
    );
    assert!(shortest > 1472, "{shortest} bytes fit one frame");
    assert!(longest <= frag::MAX_RECEIVE_LEN);
    assert!(
        rri_firmware::fragments::buffer_len(frag::MAX_RECEIVE_LEN)
            - rri_firmware::fragments::HEADERS
            <= rri_firmware::fragments::MAX_PAYLOAD
    );
}

/// The cycle's payload buffers start where a frame puts a UDP payload (two
/// bytes past a 4-byte boundary, 42 bytes into a frame on one), wherever
/// they live: static, on the stack, in a box. smoltcp and the cycle copy
/// every datagram between them and frames; with the ends aligned alike,
/// `memcpy` takes a third of the instructions (`cargo qemu-bench` prints
/// both figures).
#[test]
fn payload_buffers_sit_as_a_payload_sits_in_a_frame() {
    use rri_firmware::net::AsInFrame;
    static IN_BSS: AsInFrame<[u8; 3557]> = AsInFrame::new([0; 3557]);
    let on_stack = AsInFrame::new([[0u8; 7]; 3]);
    let boxed = Box::new(AsInFrame::new([0u8; 1]));
    for at in [
        IN_BSS.bytes.as_ptr() as usize,
        on_stack.bytes.as_ptr() as usize,
        boxed.bytes.as_ptr() as usize,
    ] {
        assert_eq!(at % 4, 2);
    }
}

/// The network runner as the boards run it (`guard::run_gated`): passed
/// over while the cycle works on a robot message, since such a pass can
/// neither take a frame in nor send one and only costs the message's full
/// path (about 1,400 instructions a pass on the QEMU board, measured with
/// qemu-bench's `held_in`); run again when the cycle's turn ends, or when
/// the hold's bound passes for a cycle that never ends its turn.
#[test]
fn the_runner_is_passed_over_while_the_cycle_works_on_a_message() {
    use embassy_time::{Duration, MockDriver};
    use rri_firmware::fragments::guard::run_gated;
    use rri_firmware::fragments::{Link, HOLD_MAX_US};
    use std::cell::Cell;
    use std::future::Future;
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;
    use std::task::{Context, Poll, Wake, Waker};

    struct Count(AtomicUsize);
    impl Wake for Count {
        fn wake(self: Arc<Self>) {
            self.0.fetch_add(1, Ordering::Relaxed);
        }
    }
    let _clock = memnet::mock_clock();
    MockDriver::get().reset();
    let now = || embassy_time::Instant::now().as_micros();
    let wakes = Arc::new(Count(AtomicUsize::new(0)));
    let waker = Waker::from(wakes.clone());
    let link = Link::new();
    let passes = Cell::new(0);
    let runner = core::future::poll_fn(|_| {
        passes.set(passes.get() + 1);
        Poll::<()>::Pending
    });
    let mut gated = std::pin::pin!(run_gated(&link, runner));
    let mut poll = || {
        assert!(gated
            .as_mut()
            .poll(&mut Context::from_waker(&waker))
            .is_pending())
    };
    poll();
    assert_eq!(passes.get(), 1, "nothing held: the runner runs");
    link.message_in(now());
    poll();
    poll();
    assert_eq!(passes.get(), 1, "passed over while the cycle works");
    let before = wakes.0.load(Ordering::Relaxed);
    link.turn_done(true);
    assert!(
        wakes.0.load(Ordering::Relaxed) > before,
        "the end of the turn wakes the runner"
    );
    poll();
    assert_eq!(passes.get(), 2, "the reply's pass runs");
    // A message the cycle never ends its turn for: the hold's bound lets
    // the runner go.
    link.reply_out(now());
    link.message_in(now());
    poll();
    assert_eq!(passes.get(), 2);
    MockDriver::get().advance(Duration::from_micros(HOLD_MAX_US));
    poll();
    assert_eq!(passes.get(), 3, "past the hold's bound the runner runs");
}
