//! `/metrics`: Prometheus text exposition format 0.0.4, so a plant's
//! monitoring scrapes the device as it scrapes anything else. Every
//! counter of the engine and the fragment guard (one family per group of
//! [`FAMILIES`], told apart by a label), the state as a gauge per S2
//! state, the reply latency as a histogram (`_bucket`, `_sum`, `_count`,
//! in seconds), the stack, the network chip, and an `rri_info` gauge
//! whose labels say who the device is. Seconds are written as decimals
//! of integer microseconds: no float formatting.

use super::counters::{Family, FAMILIES};
use super::out::Out;
use super::status::{Identity, Status};
use rri_firmware::codec::DecodeErrorKind;
use rri_firmware::engine::{Histogram, SensorState};

/// `# HELP` and `# TYPE` of one family.
#[inline(never)]
fn family(o: &mut dyn Out, name: &str, kind: &str, help: &str) {
    o.str("# HELP ");
    o.str(name);
    o.str(" ");
    o.str(help);
    o.str("\n# TYPE ");
    o.str(name);
    o.str(" ");
    o.str(kind);
    o.str("\n");
}

/// `# HELP` and `# TYPE` of a counter family, the help going on with
/// what each member counts, as the page shows it: `# HELP
/// rri_messages_total Robot messages and answers. outcome="received":
/// datagrams …. outcome="answered": ….` (the text format ends HELP at the
/// line's end; the meanings hold no `\` or newline, a test in
/// `counters.rs` checks).
#[inline(never)]
fn counter_family(o: &mut dyn Out, f: &Family) {
    o.str("# HELP ");
    o.str(f.metric);
    o.str(" ");
    o.str(f.help);
    for c in f.members {
        o.str(" ");
        if let Some(label) = f.label {
            o.str(label);
            o.str("=\"");
            o.str(c.key);
            o.str("\": ");
        }
        o.str(c.means);
        o.str(".");
    }
    o.str("\n# TYPE ");
    o.str(f.metric);
    o.str(" counter\n");
}

/// A sample's value: a number, or microseconds written as seconds.
#[derive(Clone, Copy)]
enum V {
    N(u64),
    Seconds(u64),
}

/// `name{label="value"} v` (no label when `label` is `None`).
#[inline(never)]
fn sample(o: &mut dyn Out, name: &str, label: Option<(&str, &str)>, value: V) {
    o.str(name);
    if let Some((k, v)) = label {
        o.str("{");
        o.str(k);
        o.str("=\"");
        o.label(v);
        o.str("\"}");
    }
    o.str(" ");
    match value {
        V::N(n) => o.u64(n),
        V::Seconds(us) => o.seconds(us),
    }
    o.str("\n");
}

/// A family of one unlabelled sample.
#[inline(never)]
fn single(o: &mut dyn Out, name: &str, kind: &str, help: &str, value: V) {
    family(o, name, kind, help);
    sample(o, name, None, value);
}

/// Writes `/metrics`.
pub fn write(o: &mut dyn Out, id: &Identity, s: &Status) {
    info(o, id, s);
    state(o, s);
    counters(o, id, s);
    latency(o, &s.latency.histogram);
    board(o, s);
}

/// Who the device is, since when, why it started.
#[inline(never)]
fn info(o: &mut dyn Out, id: &Identity, s: &Status) {
    family(o, "rri_info", "gauge", "Device, firmware, board, sensor.");
    o.str("rri_info{device=\"");
    o.label(id.device);
    o.str("\",version=\"");
    o.label(id.version);
    o.str("\",commit=\"");
    o.label(id.commit);
    o.str("\",board=\"");
    o.label(id.board);
    o.str("\",sensor=\"");
    o.label(id.sensor);
    o.str("\",protocol=\"");
    o.str(super::view::protocol(id.protocol));
    o.str("\"} 1\n");
    single(
        o,
        "rri_uptime_seconds",
        "gauge",
        "Since start.",
        V::Seconds(s.now.as_micros()),
    );
    // The host sensor has no resets: neither family.
    if let Some(reset) = s.reset {
        single(
            o,
            "rri_boots",
            "gauge",
            "Starts since power-on.",
            V::N(reset.boots.into()),
        );
        family(o, "rri_last_reset", "gauge", "Cause of the last start.");
        sample(
            o,
            "rri_last_reset",
            Some(("cause", reset.cause.name())),
            V::N(1),
        );
    }
}

/// The S2 state, the error code, the last message's age, the link.
#[inline(never)]
fn state(o: &mut dyn Out, s: &Status) {
    let snap = &s.snapshot;
    family(o, "rri_state", "gauge", "S2 state (1: current).");
    for state in [
        SensorState::Undefined,
        SensorState::Connected,
        SensorState::Operating,
        SensorState::Error,
        SensorState::Closed,
    ] {
        let on = u64::from(snap.state == state);
        sample(o, "rri_state", Some(("state", state.name())), V::N(on));
    }
    single(
        o,
        "rri_error_code",
        "gauge",
        "S2 error code, else 0.",
        V::N(snap.error.map_or(0, |e| e.code().into())),
    );
    if let Some(at) = snap.last_message {
        single(
            o,
            "rri_last_message_age_seconds",
            "gauge",
            "Since the last good robot message.",
            V::Seconds(s.now.micros_since(at)),
        );
    }
    single(
        o,
        "rri_link_up",
        "gauge",
        "Link up.",
        V::N(s.link.up.into()),
    );
}

/// Every counter family, the decode errors by kind, the robot
/// properties, the events.
#[inline(never)]
fn counters(o: &mut dyn Out, id: &Identity, s: &Status) {
    let snap = &s.snapshot;
    let st = &snap.stats;
    // `black_box`: a loop over constant tables the optimizer would
    // otherwise unroll into one copy of the writers per counter.
    for f in core::hint::black_box(&FAMILIES).iter() {
        counter_family(o, f);
        for c in f.members {
            let v = (c.get)(st);
            sample(o, f.metric, f.label.map(|l| (l, c.key)), V::N(v));
        }
    }
    family(
        o,
        "rri_decode_errors_total",
        "counter",
        "Decode errors by kind.",
    );
    for kind in core::hint::black_box(DecodeErrorKind::ALL) {
        let v = st.decode_errors_of(kind);
        sample(
            o,
            "rri_decode_errors_total",
            Some(("kind", kind.name())),
            V::N(v),
        );
    }
    family(
        o,
        "rri_robot_property_messages_total",
        "counter",
        "Robot messages by property (M11).",
    );
    for (p, seen) in id.received.iter().zip(snap.robot_seen.iter()) {
        sample(
            o,
            "rri_robot_property_messages_total",
            Some(("property", p.name)),
            V::N(seen.messages.into()),
        );
    }
    family(
        o,
        "rri_robot_property_interval_seconds",
        "gauge",
        "Interval of each robot property.",
    );
    for (p, seen) in id.received.iter().zip(snap.robot_seen.iter()) {
        sample(
            o,
            "rri_robot_property_interval_seconds",
            Some(("property", p.name)),
            V::Seconds(seen.interval_us.into()),
        );
    }
    single(
        o,
        "rri_events_total",
        "counter",
        "Events logged.",
        V::N(s.events.total().into()),
    );
}

/// The stack and the network chip, where the board reads them.
#[inline(never)]
fn board(o: &mut dyn Out, s: &Status) {
    if let Some(stack) = s.stack {
        family(
            o,
            "rri_stack_bytes",
            "gauge",
            "Stack high-water marks and budget.",
        );
        for (kind, v) in [
            ("boot", stack.boot),
            ("running", stack.running),
            ("size", stack.size),
        ] {
            sample(o, "rri_stack_bytes", Some(("mark", kind)), V::N(v.into()));
        }
    }
    if let Some(n) = s.nic {
        single(
            o,
            "rri_nic_rx_dropped_total",
            "counter",
            "Frames the network chip dropped.",
            V::N(n.rx_dropped.into()),
        );
        single(
            o,
            "rri_nic_rx_dropped_at_least",
            "gauge",
            "1 when a chip counter overflowed between reads: rri_nic_rx_dropped_total is then a lower bound.",
            V::N(u64::from(n.rx_dropped_at_least)),
        );
        if n.fifo {
            single(
                o,
                "rri_nic_rx_frames_total",
                "counter",
                "Frames taken from the network chip.",
                V::N(n.rx_frames.into()),
            );
            single(
                o,
                "rri_nic_status_full_total",
                "counter",
                "Receive status FIFO full.",
                V::N(n.status_full.into()),
            );
            single(
                o,
                "rri_nic_fifo_max_bytes",
                "gauge",
                "Most bytes in the receive FIFO.",
                V::N(n.fifo_max.into()),
            );
        }
    }
}

/// The reply latency as a Prometheus histogram in seconds. The device's
/// buckets count whole microseconds below 2^i, so bucket `i`'s upper
/// bound (Prometheus counts `<= le`) is exactly 2^i − 1 µs.
#[inline(never)]
fn latency(o: &mut dyn Out, h: &Histogram) {
    const NAME: &str = "rri_reply_latency_seconds";
    family(o, NAME, "histogram", "Robot message in to reply out.");
    let mut cumulative: u64 = 0;
    for (i, n) in h.buckets.iter().enumerate() {
        cumulative += *n;
        o.str(NAME);
        o.str("_bucket{le=\"");
        match Histogram::bucket_limit_us(i) {
            Some(limit) => o.seconds(u64::from(limit) - 1),
            None => o.str("+Inf"),
        }
        o.str("\"} ");
        o.u64(cumulative);
        o.str("\n");
    }
    o.str(NAME);
    o.str("_sum ");
    o.seconds(h.total_us);
    o.str("\n");
    o.str(NAME);
    o.str("_count ");
    o.u64(h.count);
    o.str("\n");
    single(
        o,
        "rri_reply_latency_max_microseconds",
        "gauge",
        "Longest reply latency.",
        V::N(h.max_us.into()),
    );
}
