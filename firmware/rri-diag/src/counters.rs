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
    /// What it counts, in one line: the page shows it beside the figure
    /// (the build script reads it from this file into the page's script,
    /// see `build.rs`), `/metrics` in its family's `# HELP`, and the
    /// README's counter line points here. Plain text: no `"`, `\` or
    /// newline (a test checks), so it needs no escaping in JavaScript or
    /// in Prometheus's text format.
    pub means: &'static str,
    /// Its value in the engine's statistics.
    pub get: fn(&Stats) -> u64,
}

const fn c(key: &'static str, means: &'static str, get: fn(&Stats) -> u64) -> Counter {
    Counter { key, means, get }
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
            c("received", "datagrams and TCP messages the engine took in, from any source, the controller's first included", |s| s.received),
            c("answered", "robot messages answered with the reply property (M8)", |s| s.answered),
            c("periodic_sent", "one-way sends of the device's periodic properties", |s| s.periodic_sent),
        ],
    },
    Family {
        key: "dropped",
        metric: "rri_dropped_total",
        help: "Unanswered, by reason.",
        label: Some("reason"),
        members: &[
            c("foreign", "not answered: from another source than the controller (S4)", |s| s.dropped_foreign),
            c("invalid_source", "not answered: from port 0 or a broadcast or multicast address", |s| s.dropped_invalid_source),
            c("throttled", "not answered: another source again within one cycle, not decoded", |s| s.dropped_throttled),
            c("decode", "not answered: the decoder refused the message, every kind (see decode errors)", |s| s.dropped_decode),
            c("encode", "not answered: the reply did not fit the send buffer", |s| s.dropped_encode),
        ],
    },
    Family {
        key: "ids",
        metric: "rri_ids_total",
        help: "Id accounting (S3).",
        label: Some("event"),
        members: &[
            c("lost", "Ids the controller skipped, less those that came late (S3)", |s| s.lost),
            c("duplicates", "messages with the same Id as the one before, answered (S3)", |s| s.duplicates),
            c("reordered", "messages older than the newest Id, answered (S3)", |s| s.reordered),
            c("wraps", "times the Id went from 4294967295 to 0", |s| s.id_wraps),
        ],
    },
    Family {
        key: "supervision",
        metric: "rri_supervision_total",
        help: "Supervision events (S1, S2, S4).",
        label: Some("event"),
        members: &[
            c("timeouts", "silences longer than TimeOut while operating (S1)", |s| s.timeouts),
            c("max_lost", "runs of lost Ids longer than MaxLost (S1)", |s| s.max_lost_exceeded),
            c("state_changes", "changes of the sensor state or its error code (S2)", |s| s.state_changes),
            c("peer_locked", "the first controller taken as the peer (S4)", |s| s.peer_locked),
            c("peer_takeovers", "a new controller address taken after TimeOut of silence (S4)", |s| s.peer_takeovers),
            c("port_takeovers", "the controller's source port changed: it reconnected", |s| s.port_takeovers),
        ],
    },
    Family {
        key: "transport",
        metric: "rri_transport_total",
        help: "Send errors, TCP events (M10).",
        label: Some("event"),
        members: &[
            c("send_errors", "replies the network did not take: counted, the next cycle goes on", |s| s.send_errors),
            c("tcp_stalled", "TCP connections the device closed: a message held or silent longer than TimeOut", |s| s.stalled_closed),
            c("tcp_closed", "TCP connections the controller closed", |s| s.closed),
            c("framing_errors", "TCP messages longer than the receive buffer (M10)", |s| s.framing_errors),
        ],
    },
    Family {
        key: "tolerated",
        metric: "rri_tolerated_total",
        help: "Tolerated (M2, M4, M5, M6).",
        label: Some("what"),
        members: &[
            c("unknown_elements", "unknown child elements skipped (M2)", |s| s.unknown_elements),
            c("unknown_attributes", "unknown attributes skipped (M2)", |s| s.unknown_attributes),
            c("missing_fields", "fields absent from a message, the previous value kept (M2)", |s| s.missing_fields),
            c("missing_values", "values absent from a frame, joints or array field, the previous kept (M4)", |s| s.missing_values),
            c("shape_mismatches", "fields in the wrong shape or empty, the previous value kept", |s| s.shape_mismatches),
            c("truncated_strings", "received strings cut at 80 bytes (M6)", |s| s.truncated_strings),
            c("stray_text", "text between a record's fields, skipped", |s| s.stray_text),
            c("non_finite", "non-finite reals sent as zero (M5)", |s| s.non_finite),
        ],
    },
    Family {
        key: "fragments",
        metric: "rri_fragments_total",
        help: "Fragment guard (S5).",
        label: Some("event"),
        members: &[
            c("fragments", "IPv4 fragments that arrived, any sender (S5)", |s| s.fragments.fragments),
            c("reassembled", "datagrams put together from fragments", |s| s.fragments.reassembled),
            c("oversize", "fragments dropped: past what the layout accepts, never a robot message", |s| s.fragments.oversize),
            c("unwanted", "fragments dropped: not UDP, not to the device, or not to the channel port", |s| s.fragments.unwanted),
            c("malformed", "fragments dropped: a broken header or checksum, a bad length, an overlap or a second end", |s| s.fragments.malformed),
            c("no_buffer", "fragments dropped: every reassembly buffer holds a set ranked higher", |s| s.fragments.no_buffer),
            c("duplicate", "fragments dropped: a copy of one already held", |s| s.fragments.duplicate),
            c("timed_out", "sets given up: still incomplete after the reassembly time", |s| s.fragments.timed_out),
            c("evicted", "sets given up: their buffer went to a set ranked higher or the controller's newer one", |s| s.fragments.evicted),
            c("spoiled", "sets given up: a later fragment showed them unusable", |s| s.fragments.spoiled),
        ],
    },
    Family {
        key: "controller",
        metric: "rri_controller_datagrams_total",
        help: "Controller datagrams at the fragment guard.",
        label: Some("outcome"),
        members: &[
            c("in", "the controller's datagrams that reached the device whole, counted at the fragment guard once the controller is known, so the first robot message is not among them", |s| s.fragments.controller_datagrams),
            c("incomplete", "the controller's datagrams whose fragments never all arrived in time", |s| s.fragments.controller_incomplete),
            c("dropped", "the controller's datagrams lost in reassembly: spoiled or refused a buffer", |s| s.fragments.controller_dropped),
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

    /// The page's meanings are read from this file by the build script:
    /// they must be the table's, every one, in its order.
    #[test]
    fn the_page_explains_every_counter_as_the_table_does() {
        let built = include_str!(concat!(env!("OUT_DIR"), "/means.js"));
        let mut want = Vec::new();
        for f in FAMILIES {
            for m in f.members {
                want.push(format!("\"{}.{}\":\"{}\"", f.key, m.key, m.means));
            }
        }
        assert_eq!(built, format!("const MEANS={{{}}};", want.join(",")));
    }

    /// Plain text, so that neither JavaScript nor `# HELP` needs escapes,
    /// and one line that starts lower-case (it follows the figure).
    #[test]
    fn meanings_are_plain_one_line_text() {
        for f in FAMILIES {
            for m in f.members {
                assert!(!m.means.is_empty(), "{}.{}", f.key, m.key);
                assert!(
                    !m.means.contains(['"', '\\', '\n']),
                    "{}.{}: {}",
                    f.key,
                    m.key,
                    m.means
                );
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
