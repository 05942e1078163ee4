//! Unit tests of [`super`]: the controller's supervision against a
//! device's replies.

use super::*;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::sync::{mpsc, Arc};

/// S1 after a stall of the simulator's own thread (a loaded host): a
/// reply the receiver thread stamped 1 ms after its message counts as
/// an answer in time even when the thread comes back after the next
/// send was due. Before, `pump` returned at the due schedule without
/// reading it, and 31 such catch-up cycles tripped `MaxLost` with
/// "no reply at all" though every reply had come in time.
#[test]
fn replies_received_during_a_stall_are_answers_in_time_s1() {
    let gsi = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../firmware/gsi/GSI");
    let device = gsi_config::load(&gsi, None).expect("GSI loads").device;
    let reply_prop = device.sent().next().expect("a reply");
    let opts = RobotOptions::new(gsi, SocketAddr::from(([127, 0, 0, 1], 6510)));
    let (tx, events) = mpsc::channel();
    let link = Link {
        udp: None,
        tcp: None,
        events,
        stop: Arc::new(AtomicBool::new(false)),
        threads: Vec::new(),
        closed: false,
    };
    let mut log = Vec::new();
    let mut sim = Sim::new(&opts, &device, reply_prop, link, 4, &mut log);
    let mut previous = Vec::new();
    for (index, id) in (7u32..10).enumerate() {
        let sent = Instant::now();
        sim.cycles.push(Cycle {
            cycle: index as u64,
            id,
            sent_us: sim.us(sent),
            reply_us: None,
            dropped_by_fault: false,
            property: 0,
            shown: None,
        });
        sim.waiting.insert(
            id,
            Waiting {
                index,
                sent,
                expected: 1,
                answered: false,
            },
        );
        previous.push(id);
        let app: String = (1..=18).map(|i| format!(" X{i}=\"0\"")).collect();
        let reply =
            format!("<SensData Id=\"{id}\" Ts=\"0\"><EStr>x</EStr><AppData{app}/></SensData>");
        let local = SocketAddr::from(([127, 0, 0, 1], 6511));
        let at = sent + Duration::from_millis(1);
        tx.send(Event::Data(reply.into_bytes(), local, at))
            .expect("channel");
        // The thread "stalled": the next send was due a while ago.
        std::thread::sleep(Duration::from_millis(10));
        sim.pump(sent + Duration::from_millis(4), None);
        sim.judge_previous(&mut previous);
    }
    assert_eq!((sim.s.answered, sim.s.late, sim.s.malformed), (3, 0, 0));
    assert_eq!(sim.sup.in_row, 0);
    assert!(sim.sup.tripped.is_none());
}
