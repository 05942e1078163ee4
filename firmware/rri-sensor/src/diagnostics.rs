//! The device's own story, on the board: what the diagnostics service
//! (`rri_diag`) shows and the tasks that serve it.
//!
//! - The cycle keeps the last bad robot message ([`LAST_BAD`], after the
//!   message was dropped) and the fragment guard times the replies at
//!   the driver (`LINK`); housekeeping logs events ([`EVENTS`]) by
//!   comparing the snapshots the cycle publishes.
//! - With cfg `rri_http` (`RRI_HTTP_PORT`, default 80; 0 compiles it
//!   out) the service's tasks (`rri_diag::tasks`): per connection slot one
//!   on the urgent executor that only moves bytes, one on the background
//!   executor that parses and renders, their buffers in `.diag_ram` (the
//!   NUCLEO boards' DMA SRAM, beside the Ethernet rings: nothing from the
//!   DTCM). This file gives them the board's status ([`status`]) and who
//!   the device is ([`identity`]).

use crate::{board, LINK, PUBLISHED};
use rri_diag::events::{EventKind, Events};
use rri_diag::status::{Identity, LatencySource, ResetInfo, StackFigures, Status};
use rri_diag::LastBad;
use rri_firmware::engine::Instant;
use rri_firmware::snapshot::Snapshot;

/// The last robot message the decoder rejected (the cycle writes it).
pub static LAST_BAD: LastBad = LastBad::new();
/// What happened (housekeeping writes it).
pub static EVENTS: Events = Events::new();

/// Why the board started, set once at start-up (before any reader).
static RESET: critical_section::Mutex<core::cell::Cell<ResetInfo>> =
    critical_section::Mutex::new(core::cell::Cell::new(ResetInfo::UNKNOWN));

/// Device time now.
pub fn now() -> Instant {
    Instant(embassy_time::Instant::now().as_micros())
}

/// At start-up: keeps why the board started, as the first event.
pub fn started(report: hal_board::reset::Report) {
    let info = report;
    critical_section::with(|cs| RESET.borrow(cs).set(info));
    EVENTS.push(now(), EventKind::Started(info.cause));
}

/// Housekeeping, after each look at the cycle: the events between the
/// last snapshot and this one, and the link's changes.
pub fn note(last: &Snapshot, now_snap: &Snapshot, link: &mut hal_board::LinkInfo) {
    let at = now();
    EVENTS.between(at, last, now_snap);
    EVENTS.link(at, board::link(), link);
}

/// Everything that moves, as of now (the service copies it once per
/// response).
pub fn status(out: &mut Option<Status>) {
    let stack = hal_board::stack::high_water();
    let snapshot = PUBLISHED.latest();
    *out = Some(Status {
        snapshot,
        now: now(),
        link: board::link(),
        nic: board::nic_counters(),
        stack: Some(StackFigures {
            boot: stack.boot as u32,
            running: stack.running as u32,
            size: stack.size as u32,
        }),
        latency: rri_diag::status::Latency {
            source: LatencySource::Driver,
            histogram: LINK.latency(),
        },
        bad: LAST_BAD.get(),
        events: EVENTS.copy(),
        reset: Some(critical_section::with(|cs| RESET.borrow(cs).get())),
        // The service fills it in from its update desk.
        update: None,
    });
}

/// Who the device is, for the service.
pub fn identity(mac: Option<[u8; 6]>) -> Identity {
    use rri_firmware::layout;
    Identity {
        device: layout::DEVICE_NAME,
        device_type: layout::DEVICE_TYPE,
        device_class: layout::DEVICE_CLASS,
        version: crate::version::VERSION,
        commit: rri_firmware::network::COMMIT,
        board: board::NAME,
        sensor: rri_active_sensor::active_name(),
        sensor_file: rri_active_sensor::ACTIVE_FILE,
        mac,
        ip: crate::ADDRESS,
        prefix: rri_firmware::network::PREFIX_LEN,
        gateway: rri_firmware::network::GATEWAY,
        protocol: layout::CHANNEL_PROTOCOL,
        port: layout::CHANNEL_PORT,
        http_port: rri_firmware::network::HTTP_PORT,
        config: layout::ENGINE_CONFIG,
        received: &layout::RECEIVED_INFO,
        sent: &layout::SENT_INFO,
    }
}
