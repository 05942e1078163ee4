//! Every counter the diagnostics show, named once for the three forms:
//! the page (its text), `/status.json` (its key inside its group) and
//! `/metrics` (its family's metric name and its label value). A counter
//! added to [`rri_firmware::engine::Stats`] is shown by adding one line here.

use rri_firmware::engine::Stats;

/// A family of counters: one Prometheus metric with one label, one JSON
/// object, one table on the page.
#[derive(Clone, Copy, Debug)]
pub struct Family {
    /// JSON key of the group (the page's heading).
    pub key: &'static str,
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
    /// Its value in the engine's statistics.
    pub get: fn(&Stats) -> u64,
}

const fn c(key: &'static str, get: fn(&Stats) -> u64) -> Counter {
    Counter { key, get }
}

/// Every family of the engine's and the fragment guard's counters, in
/// the page's order (decode errors by kind are their own list:
/// [`rri_firmware::codec::DecodeErrorKind::ALL`]).
pub const FAMILIES: [Family; 8] = [
    Family {
        key: "messages",
        metric: "rri_messages_total",
        help: "Robot messages and answers.",
        label: Some("outcome"),
        members: &[
            c("received", |s| s.received),
            c("answered", |s| s.answered),
            c("periodic_sent", |s| s.periodic_sent),
        ],
    },
    Family {
        key: "dropped",
        metric: "rri_dropped_total",
        help: "Unanswered, by reason.",
        label: Some("reason"),
        members: &[
            c("foreign", |s| s.dropped_foreign),
            c("invalid_source", |s| s.dropped_invalid_source),
            c("throttled", |s| s.dropped_throttled),
            c("decode", |s| s.dropped_decode),
            c("encode", |s| s.dropped_encode),
        ],
    },
    Family {
        key: "ids",
        metric: "rri_ids_total",
        help: "Id accounting (S3).",
        label: Some("event"),
        members: &[
            c("lost", |s| s.lost),
            c("duplicates", |s| s.duplicates),
            c("reordered", |s| s.reordered),
            c("wraps", |s| s.id_wraps),
        ],
    },
    Family {
        key: "supervision",
        metric: "rri_supervision_total",
        help: "Supervision events (S1, S2, S4).",
        label: Some("event"),
        members: &[
            c("timeouts", |s| s.timeouts),
            c("max_lost", |s| s.max_lost_exceeded),
            c("state_changes", |s| s.state_changes),
            c("peer_locked", |s| s.peer_locked),
            c("peer_takeovers", |s| s.peer_takeovers),
            c("port_takeovers", |s| s.port_takeovers),
        ],
    },
    Family {
        key: "transport",
        metric: "rri_transport_total",
        help: "Send errors, TCP events (M10).",
        label: Some("event"),
        members: &[
            c("send_errors", |s| s.send_errors),
            c("tcp_stalled", |s| s.stalled_closed),
            c("tcp_closed", |s| s.closed),
            c("framing_errors", |s| s.framing_errors),
        ],
    },
    Family {
        key: "tolerated",
        metric: "rri_tolerated_total",
        help: "Tolerated (M2, M4, M5, M6).",
        label: Some("what"),
        members: &[
            c("unknown_elements", |s| s.unknown_elements),
            c("unknown_attributes", |s| s.unknown_attributes),
            c("missing_fields", |s| s.missing_fields),
            c("missing_values", |s| s.missing_values),
            c("shape_mismatches", |s| s.shape_mismatches),
            c("truncated_strings", |s| s.truncated_strings),
            c("stray_text", |s| s.stray_text),
            c("non_finite", |s| s.non_finite),
        ],
    },
    Family {
        key: "fragments",
        metric: "rri_fragments_total",
        help: "Fragment guard (S5).",
        label: Some("event"),
        members: &[
            c("fragments", |s| s.fragments.fragments),
            c("reassembled", |s| s.fragments.reassembled),
            c("oversize", |s| s.fragments.oversize),
            c("unwanted", |s| s.fragments.unwanted),
            c("malformed", |s| s.fragments.malformed),
            c("no_buffer", |s| s.fragments.no_buffer),
            c("duplicate", |s| s.fragments.duplicate),
            c("timed_out", |s| s.fragments.timed_out),
            c("evicted", |s| s.fragments.evicted),
            c("spoiled", |s| s.fragments.spoiled),
        ],
    },
    Family {
        key: "controller",
        metric: "rri_controller_datagrams_total",
        help: "Controller datagrams at the fragment guard.",
        label: Some("outcome"),
        members: &[
            c("in", |s| s.fragments.controller_datagrams),
            c("incomplete", |s| s.fragments.controller_incomplete),
            c("dropped", |s| s.fragments.controller_dropped),
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
