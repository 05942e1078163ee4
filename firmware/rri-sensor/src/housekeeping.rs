//! Housekeeping, 10 Hz on the background executor: the watchdog (fed only
//! while the cycle turns), the LEDs (the S2 state), state changes and,
//! once a second, the counter line in the log. It reads the snapshot the
//! cycle publishes; it never holds the engine.

#[cfg(rri_http)]
use super::diagnostics;
use super::{PUBLISHED, TCP, WATCHDOG_MS};
use embassy_time::{Duration, Ticker};
use hal_board::board;
use rri_firmware::codec::DecodeErrorKind;
use rri_firmware::engine::SensorState;
use rri_firmware::snapshot::Snapshot;

/// 10 Hz: the watchdog (fed only while the cycle turns), the LEDs (S2 state
/// on LED 0; LED 1 toggles with answered cycles, on for CLOSED) and the log.
#[embassy_executor::task]
pub(crate) async fn housekeeping(mut leds: board::Leds, mut watchdog: board::Watchdog) -> ! {
    watchdog.start(WATCHDOG_MS);
    // After an update: on trial until OPERATING, and the restart into the
    // swap of a marked image once the controller is not OPERATING.
    #[cfg(rri_update)]
    let mut course = super::update::Course::take();
    let mut ticker = Ticker::every(Duration::from_millis(100));
    // From UNDEFINED, so the first state the cycle reaches is logged too.
    let mut last = Snapshot::default();
    let mut tick: u32 = 0;
    let mut stack_used = 0;
    #[cfg(rri_http)]
    let mut link = hal_board::LinkInfo::default();
    loop {
        ticker.next().await;
        tick = tick.wrapping_add(1);
        // The network chip's clear-on-read missed-frame counters, summed
        // by the board ten times a second (their overflow flags say when
        // even that was not often enough: issue 42 #12).
        let _ = board::nic_counters();
        let now = PUBLISHED.latest();
        #[cfg(rri_http)]
        diagnostics::note(&last, &now, &mut link);
        // A TCP cycle waits in accept without turning; it has nothing to
        // hang on there.
        let waiting = TCP && now.state != SensorState::Operating;
        #[cfg(rri_update)]
        let keep = course.tick(&now);
        #[cfg(not(rri_update))]
        let keep = true;
        if keep && (now.heartbeat != last.heartbeat || waiting) {
            watchdog.feed();
        }
        leds.set(0, state_led(now.state, tick));
        // LED 1: toggles with every answered cycle (a steady glow while the
        // robot streams), on for CLOSED.
        leds.set(
            1,
            now.state == SensorState::Closed || now.stats.answered % 2 == 1,
        );
        if now.state != last.state || now.error != last.error {
            match now.error {
                Some(e) => defmt::warn!("state {=str} {=u32}", now.state.name(), e.code()),
                None => defmt::info!("state {=str}", now.state.name()),
            }
        }
        for kind in DecodeErrorKind::ALL {
            let (was, is) = (
                last.stats.decode_errors_of(kind),
                now.stats.decode_errors_of(kind),
            );
            if is > was {
                defmt::warn!("decode error {}: {} more ({} in all)", kind, is - was, is);
            }
        }
        if tick.is_multiple_of(10) {
            // The deepest the one stack (thread mode and every interrupt
            // on top) has been; logged when it grows (qemu-bench gates on
            // the margin).
            let stack = hal_board::stack::high_water();
            if stack.running > stack_used {
                stack_used = stack.running;
                defmt::info!(
                    "stack: boot {=usize} running {=usize} of {=usize} bytes, {=usize}% margin",
                    stack.boot,
                    stack.running,
                    stack.size,
                    stack.margin_percent()
                );
            }
            // After the stack line: a reader that sees this line has seen
            // the latest stack figure.
            log_counters(&now);
        }
        last = now;
    }
}

/// S2 on one LED: off UNDEFINED, slow blink CONNECTED, on OPERATING, fast
/// blink ERROR, on CLOSED.
fn state_led(state: SensorState, tick: u32) -> bool {
    match state {
        SensorState::Undefined => false,
        SensorState::Connected => (tick / 5).is_multiple_of(2),
        SensorState::Operating | SensorState::Closed => true,
        SensorState::Error => tick.is_multiple_of(2),
    }
}

/// The counter line, once a second (host tools parse it:
/// `host-tests/src/counters.rs`): the engine's counters, the fragment
/// guard's (S5) and the network chip's own receive counters where the
/// board reads them (`nic n/a` where it does not). Each group is
/// `family: key value …` with the family and key the page, `/status.json`
/// and `/metrics` use (`rri-diag`'s `counters.rs`, which says what each
/// counts; a host test holds this line to that table).
fn log_counters(s: &Snapshot) {
    let st = &s.stats;
    let fr = &st.fragments;
    let (read, nic) = match board::nic_counters() {
        Some(n) => ("read", n),
        None => ("n/a", hal_board::NicCounters::default()),
    };
    defmt::info!(
        "counters: messages: received {} answered {} | dropped: foreign {} invalid_source {} throttled {} decode {} | transport: send_errors {} tcp_stalled {} | ids: lost {} duplicates {} reordered {} | supervision: timeouts {} | engine latency (message in to reply ready; the page and /metrics show the driver's, frame to frame) us: max {} mean {} | fragments: fragments {} reassembled {} oversize {} unwanted {} malformed {} no_buffer {} duplicate {} timed_out {} evicted {} spoiled {} | controller: in {} incomplete {} dropped {} | nic {=str}: rx_frames {} rx_dropped {} status_full {} fifo_max {}",
        st.received,
        st.answered,
        st.dropped_foreign,
        st.dropped_invalid_source,
        st.dropped_throttled,
        st.dropped_decode,
        st.send_errors,
        st.stalled_closed,
        st.lost,
        st.duplicates,
        st.reordered,
        st.timeouts,
        if st.latency.count > 0 { st.latency.max_us } else { 0 },
        st.latency.total_us.checked_div(st.latency.count).unwrap_or(0),
        fr.fragments,
        fr.reassembled,
        fr.oversize,
        fr.unwanted,
        fr.malformed,
        fr.no_buffer,
        fr.duplicate,
        fr.timed_out,
        fr.evicted,
        fr.spoiled,
        fr.controller_datagrams,
        fr.controller_incomplete,
        fr.controller_dropped,
        read,
        nic.rx_frames,
        nic.rx_dropped,
        nic.status_full,
        nic.fifo_max,
    );
}
