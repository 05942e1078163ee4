//! Every counter the diagnostics show, named once for the three forms:
//! the page (its text), `/status.json` (its key inside its group) and
//! `/metrics` (its family's metric name and its label value). A counter
//! added to [`crate::engine::Stats`] is shown by adding one line here.

use crate::engine::Stats;

/// A family of counters: one Prometheus metric with one label, one JSON
/// object, one table on the page.
#[derive(Clone, Copy, Debug)]
pub struct Family {
    /// JSON key of the group, and the page's heading.
    pub key: &'static str,
    /// The page's heading.
    pub title: &'static str,
    /// Prometheus metric name (`rri_…_total`).
    pub metric: &'static str,
    /// Prometheus `# HELP` text.
    pub help: &'static str,
    /// The label that tells its members apart (`None`: one member).
    pub label: Option<&'static str>,
    /// Its members.
    pub members: &'static [Counter],
}

/// One counter.
#[derive(Clone, Copy, Debug)]
pub struct Counter {
    /// JSON key and Prometheus label value.
    pub key: &'static str,
    /// What the page calls it.
    pub text: &'static str,
    /// Its value in the engine's statistics.
    pub get: fn(&Stats) -> u32,
}

const fn c(key: &'static str, text: &'static str, get: fn(&Stats) -> u32) -> Counter {
    Counter { key, text, get }
}

/// Every family of the engine's and the fragment guard's counters, in
/// the page's order (decode errors by kind are their own list:
/// [`crate::codec::DecodeErrorKind::ALL`]).
pub const FAMILIES: [Family; 8] = [
    Family {
        key: "messages",
        title: "Robot messages",
        metric: "rri_messages_total",
        help: "Robot messages handed to the engine, and what became of them.",
        label: Some("outcome"),
        members: &[
            c("received", "received", |s| s.received),
            c("answered", "answered (M8)", |s| s.answered),
            c("periodic_sent", "periodic sends", |s| s.periodic_sent),
        ],
    },
    Family {
        key: "dropped",
        title: "Dropped, by reason",
        metric: "rri_dropped_total",
        help: "Robot messages not answered, by reason (S4, decode errors, encode).",
        label: Some("reason"),
        members: &[
            c("foreign", "not the controller (S4)", |s| s.dropped_foreign),
            c("invalid_source", "invalid source: port 0, not unicast (S4)", |s| {
                s.dropped_invalid_source
            }),
            c("throttled", "other source, throttled to one per cycle (S4)", |s| {
                s.dropped_throttled
            }),
            c("decode", "rejected by the decoder (kinds below)", |s| s.dropped_decode),
            c("encode", "reply did not fit its buffer", |s| s.dropped_encode),
        ],
    },
    Family {
        key: "ids",
        title: "Message Ids (S3)",
        metric: "rri_ids_total",
        help: "Id accounting of the robot messages (S3).",
        label: Some("event"),
        members: &[
            c("lost", "lost (gaps)", |s| s.lost),
            c("duplicates", "duplicates", |s| s.duplicates),
            c("reordered", "reordered", |s| s.reordered),
            c("wraps", "Id wraps", |s| s.id_wraps),
        ],
    },
    Family {
        key: "supervision",
        title: "Supervision (S1, S2, S4)",
        metric: "rri_supervision_total",
        help: "Supervision events: TimeOut, MaxLost, state changes, peer changes (S1, S2, S4).",
        label: Some("event"),
        members: &[
            c("timeouts", "TimeOut exceeded", |s| s.timeouts),
            c("max_lost", "MaxLost exceeded", |s| s.max_lost_exceeded),
            c("state_changes", "state changes", |s| s.state_changes),
            c("peer_locked", "controller locked on", |s| s.peer_locked),
            c("peer_takeovers", "controller address changed", |s| s.peer_takeovers),
            c("port_takeovers", "controller port changed", |s| s.port_takeovers),
        ],
    },
    Family {
        key: "transport",
        title: "Transport",
        metric: "rri_transport_total",
        help: "Send errors and TCP connection events (M10).",
        label: Some("event"),
        members: &[
            c("send_errors", "send errors", |s| s.send_errors),
            c("tcp_stalled", "TCP connections closed as stalled (M10)", |s| {
                s.stalled_closed
            }),
            c("tcp_closed", "TCP connections closed by the peer", |s| s.closed),
            c("framing_errors", "TCP messages too long (M10)", |s| s.framing_errors),
        ],
    },
    Family {
        key: "tolerated",
        title: "Tolerated (M2, M4, M5, M6)",
        metric: "rri_tolerated_total",
        help: "What decoding tolerated and counted (M2, M4, M6), and non-finite reals sent as zero (M5).",
        label: Some("what"),
        members: &[
            c("unknown_elements", "unknown elements", |s| s.unknown_elements),
            c("unknown_attributes", "unknown attributes", |s| s.unknown_attributes),
            c("missing_fields", "missing fields", |s| s.missing_fields),
            c("missing_values", "missing values", |s| s.missing_values),
            c("shape_mismatches", "fields in the wrong shape", |s| s.shape_mismatches),
            c("truncated_strings", "strings cut at 80 bytes", |s| s.truncated_strings),
            c("stray_text", "stray text", |s| s.stray_text),
            c("non_finite", "non-finite reals sent as 0", |s| s.non_finite),
        ],
    },
    Family {
        key: "fragments",
        title: "IPv4 fragments (S5)",
        metric: "rri_fragments_total",
        help: "The fragment guard's counters (S5).",
        label: Some("event"),
        members: &[
            c("fragments", "fragments in", |s| s.fragments.fragments),
            c("reassembled", "datagrams reassembled", |s| s.fragments.reassembled),
            c("oversize", "oversize, dropped", |s| s.fragments.oversize),
            c("unwanted", "not for the channel, dropped", |s| s.fragments.unwanted),
            c("malformed", "malformed, dropped", |s| s.fragments.malformed),
            c("no_buffer", "no buffer, dropped", |s| s.fragments.no_buffer),
            c("timed_out", "sets timed out", |s| s.fragments.timed_out),
            c("evicted", "sets evicted", |s| s.fragments.evicted),
            c("spoiled", "sets spoiled", |s| s.fragments.spoiled),
        ],
    },
    Family {
        key: "controller",
        title: "The controller's datagrams (S5)",
        metric: "rri_controller_datagrams_total",
        help: "The controller's datagrams at the fragment guard: handed on whole, or lost there.",
        label: Some("outcome"),
        members: &[
            c("in", "handed on whole", |s| s.fragments.controller_datagrams),
            c("incomplete", "given up incomplete", |s| s.fragments.controller_incomplete),
            c("dropped", "lost in reassembly", |s| s.fragments.controller_dropped),
        ],
    },
];

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    #[test]
    fn keys_and_metric_names_are_unique_and_well_formed() {
        let mut metrics = HashSet::new();
        let mut keys = HashSet::new();
        for f in FAMILIES {
            assert!(metrics.insert(f.metric), "{}", f.metric);
            assert!(keys.insert(f.key), "{}", f.key);
            assert!(f.metric.starts_with("rri_") && f.metric.ends_with("_total"));
            let mut members = HashSet::new();
            for m in f.members {
                assert!(members.insert(m.key), "{}.{}", f.key, m.key);
                assert!(m.key.bytes().all(|b| b.is_ascii_lowercase() || b == b'_'));
            }
        }
    }

    #[test]
    fn every_counter_reads_its_own_field() {
        let mut s = Stats::ZERO;
        s.dropped_throttled = 7;
        s.fragments.no_buffer = 9;
        let read = |family: &str, key: &str| {
            let f = FAMILIES.iter().find(|f| f.key == family).unwrap();
            (f.members.iter().find(|m| m.key == key).unwrap().get)(&s)
        };
        assert_eq!(read("dropped", "throttled"), 7);
        assert_eq!(read("fragments", "no_buffer"), 9);
        assert_eq!(read("dropped", "foreign"), 0);
    }
}
