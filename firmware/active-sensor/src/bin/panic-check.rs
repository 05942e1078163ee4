//! The cycle path as one MCU image, for the panic-freedom check
//! (`cargo panic-check`, run by CI; host-tests/src/bin/panic-paths.rs).
//!
//! This image runs what every board runs per robot message and per poll —
//! the engine's `on_message` (peer check, decode, Id accounting,
//! supervision, the sensor's cycle half (`rri_active_sensor::Active`, the file
//! `RRI_SENSOR` names), encode), its `poll`, the TCP framer
//! and the stall guard — on inputs the optimizer cannot see (a datagram of
//! any length and content from any source, any time), built with the
//! firmware profile (fat LTO): the code the boards run.
//! Every panic path the optimizer could not remove is still in it as a
//! call to a `core` panic entry; the check disassembles the image, finds
//! each such call and the source line it comes from, and fails if any is
//! in the firmware crate.
//!
//! It is never run: its `main` only has to exist.
#![no_std]
#![no_main]

use core::hint::black_box;
use cortex_m_rt::entry;
use rri_active_sensor::Active;
use rri_firmware::engine::{Clock, Endpoint, Engine, Instant, Outcome};
use rri_firmware::layout::{self, DeviceEngine};
use rri_firmware::sample::SampleCell;
use rri_firmware::sensor::{Ring, Sampler, Sensor, SensorApp, Simulated};
use rri_firmware::tcp::{Framer, StallGuard};

/// Never reached when the check passes for the firmware's own code; the
/// check (`cargo panic-check`) lists every call that could get here.
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {
        core::hint::spin_loop();
    }
}

/// A clock the optimizer cannot predict.
struct Opaque;

impl Clock for Opaque {
    fn now(&self) -> Instant {
        Instant(black_box(0))
    }
}

type Samples = <Active as Sensor>::History;

static SAMPLES: SampleCell<Samples> = SampleCell::new(<Samples as Ring<_>>::EMPTY);

/// A deliberate panic path (feature `panic-check-selftest`): CI builds it
/// too and expects the check to find it, so the check is known to bite.
#[cfg(feature = "panic-check-selftest")]
fn selftest(bytes: &[u8]) -> u8 {
    bytes[black_box(usize::MAX)]
}

#[cfg(not(feature = "panic-check-selftest"))]
fn selftest(_: &[u8]) -> u8 {
    0
}

#[entry]
fn main() -> ! {
    let mut engine: DeviceEngine = Engine::new(layout::ENGINE_CONFIG);
    let Some((writer, reader)) = SAMPLES.split() else {
        loop {
            core::hint::spin_loop();
        }
    };
    let mut app = SensorApp::<Active>::new(reader);
    let mut sampler = Sampler::<Active>::new(writer);
    let clock = Opaque;
    let mut datagram = [0u8; layout::MAX_RECEIVE_LEN + 1];
    let mut out = [0u8; layout::MAX_SEND_LEN];
    let mut framer = Framer::<{ layout::MAX_RECEIVE_LEN }>::new();
    let mut guard = StallGuard::new(engine.config().timeout_ms, clock.now());
    loop {
        // Length and content opaque: the slice itself goes through
        // `black_box`.
        let bytes: &[u8] = black_box(datagram.as_mut_slice());
        let from = black_box(Endpoint::new([10, 0, 0, 1], 3002));
        // A sample at an opaque time, so the cycle half meets a history
        // the optimizer cannot predict (its sampling half runs elsewhere
        // on a board, never on this path).
        if black_box(true) {
            sampler.step(&mut Simulated, clock.now());
        }
        let outcome = engine.on_message(&mut app, &clock, from, bytes, clock.now(), &mut out);
        if let Outcome::Reply { len, .. } = outcome {
            black_box(out.get(..len));
        }
        black_box(engine.poll(&mut app, &clock, &mut out));
        // TCP: the framer over any chunk, each message through the engine.
        let mut rest = bytes;
        let mut completed = false;
        while !rest.is_empty() {
            // As `net::Cycle::tcp` does: a count beyond the bytes given
            // (never returned) is a framing error, not an empty remainder.
            let Some((unused, message)) = framer
                .feed(rest)
                .ok()
                .and_then(|(used, m)| rest.get(used..).map(|unused| (unused, m)))
            else {
                engine.framing_error();
                break;
            };
            rest = unused;
            if let Some(message) = message {
                completed = true;
                let received = clock.now();
                black_box(engine.on_message(&mut app, &clock, from, message, received, &mut out));
            }
        }
        guard.received(clock.now(), completed, framer.pending());
        if guard.check(clock.now(), black_box(false)).is_some() {
            engine.stalled();
            engine.peer_closed();
        }
        black_box(engine.stats());
        black_box(selftest(bytes));
    }
}
