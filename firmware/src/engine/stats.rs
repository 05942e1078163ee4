//! Statistics: a counter for every error kind, drop reason and event, and a
//! latency histogram, readable as one `Copy` snapshot.

use crate::codec::DecodeErrorKind;

/// Receive → reply-ready time in device clock ticks (µs), in power-of-two
/// buckets: bucket `i` counts latencies below `2^i` µs (and at least
/// `2^(i-1)`); the last bucket counts everything from 2^15 µs (32.8 ms) on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Histogram {
    /// Latencies per bucket (see [`Histogram::bucket_limit_us`]).
    pub buckets: [u64; Histogram::BUCKETS],
    /// Latencies recorded.
    pub count: u64,
    /// Shortest, µs; 0 while `count` is 0 (an empty histogram is all zero
    /// bytes, so the `static`s that hold one start in `.bss`, not in flash).
    pub min_us: u32,
    /// Longest, µs.
    pub max_us: u32,
    /// Sum of all latencies, for the mean.
    pub total_us: u64,
    /// When the longest was recorded (device time, µs; see
    /// [`Histogram::record_at`]).
    pub max_at_us: u64,
}

impl Default for Histogram {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Histogram {
    /// No latency recorded yet.
    pub const EMPTY: Histogram = Histogram {
        buckets: [0; Histogram::BUCKETS],
        count: 0,
        min_us: 0,
        max_us: 0,
        total_us: 0,
        max_at_us: 0,
    };

    /// 0 µs, <2, <4, … <2^15 µs (32.8 ms), and above.
    pub const BUCKETS: usize = 17;

    /// Counts one latency of `micros` µs (`min_us` and `max_us` saturate at
    /// `u32::MAX`; `total_us` takes it whole).
    pub fn record(&mut self, micros: u64) {
        let us = u32::try_from(micros).unwrap_or(u32::MAX);
        let bucket = (u32::BITS - us.leading_zeros()) as usize;
        let bucket = bucket.min(Self::BUCKETS - 1);
        if let Some(b) = self.buckets.get_mut(bucket) {
            *b = b.saturating_add(1);
        }
        self.min_us = if self.count == 0 {
            us
        } else {
            self.min_us.min(us)
        };
        self.count = self.count.saturating_add(1);
        self.max_us = self.max_us.max(us);
        self.total_us = self.total_us.saturating_add(micros);
    }

    /// Counts one latency of `micros` µs that ended at device time `at_us`:
    /// when it is the longest so far, `max_at_us` says when it happened.
    pub fn record_at(&mut self, micros: u64, at_us: u64) {
        let us = u32::try_from(micros).unwrap_or(u32::MAX);
        if self.count == 0 || us > self.max_us {
            self.max_at_us = at_us;
        }
        self.record(micros);
    }

    /// The mean in µs (0 while empty).
    pub fn mean_us(&self) -> u64 {
        self.total_us.checked_div(self.count).unwrap_or(0)
    }

    /// Upper bound (exclusive) of bucket `i` in µs; `None` for the last.
    pub fn bucket_limit_us(i: usize) -> Option<u32> {
        (i + 1 < Self::BUCKETS).then(|| 1u32 << i)
    }
}

/// Why a datagram got no answer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DropReason {
    /// Not from the controller (or a pinned controller's address), and the
    /// peer has not been silent for `TimeOut`.
    ForeignSource,
    /// A source no controller can have: port 0, or a broadcast,
    /// multicast, reserved or `0.x.x.x` address (spoofed or broken).
    /// Never admitted, never answered.
    InvalidSource,
    /// From an admitted source other than the peer (a second port of its
    /// address, or a new address after `TimeOut`) within
    /// [`super::STRANGER_INTERVAL_MS`] of the last one decoded: a flood from
    /// there cannot cost more than one decode per robot cycle.
    Throttled,
    /// Could not be decoded (the kind is counted separately).
    Decode(DecodeErrorKind),
    /// The reply did not fit the buffer (a wrong buffer size; never with
    /// one of the generated `MAX_SEND_LEN`).
    Encode,
}

impl core::fmt::Display for DropReason {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let text = match self {
            Self::ForeignSource => "source is not the controller (S4)",
            Self::InvalidSource => "source can be no controller: port 0 or not unicast (S4)",
            Self::Throttled => "source other than the peer, throttled to one decode per cycle (S4)",
            Self::Decode(kind) => return core::fmt::Display::fmt(kind, f),
            Self::Encode => "reply larger than the send buffer",
        };
        f.write_str(text)
    }
}

impl core::error::Error for DropReason {}

/// Every counter of the engine. Counters are `u64` (issue 42 #11): at the
/// controller's 250 messages a second a `u32` stopped after 199 days,
/// which a device in a cell outlives; a `u64` lasts two billion years, so
/// its saturation (kept, not wrapping) is never reached in a service life.
/// What it costs the cycle is measured by `cargo qemu-bench`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Stats {
    /// Datagrams (or TCP messages) handed to the engine.
    pub received: u64,
    /// Replies produced (answers and periodic sends).
    pub sent: u64,
    /// Answers to robot messages (M8).
    pub answered: u64,
    /// Periodic sends of one-way streams.
    pub periodic_sent: u64,
    /// Not from the controller ([`DropReason::ForeignSource`], S4).
    pub dropped_foreign: u64,
    /// From port 0 or a non-unicast address ([`DropReason::InvalidSource`]).
    pub dropped_invalid_source: u64,
    /// Not the peer, within one cycle of the last such source decoded
    /// ([`DropReason::Throttled`]).
    pub dropped_throttled: u64,
    /// Rejected by the decoder, all kinds ([`DropReason::Decode`]).
    pub dropped_decode: u64,
    /// Replies that did not fit the send buffer ([`DropReason::Encode`]).
    pub dropped_encode: u64,
    /// Per [`DecodeErrorKind`], in the order of `DecodeErrorKind::ALL`.
    pub decode_errors: [u64; DecodeErrorKind::ALL.len()],
    /// S3: ids skipped (lost messages); a message that arrives late
    /// (reordered) fills its gap and is taken off again.
    pub lost: u64,
    /// S3: the same Id as the last one (answered all the same).
    pub duplicates: u64,
    /// S3: an Id older than the newest (arrived late; answered).
    pub reordered: u64,
    /// The id counter wrapped from 4294967295 to 0.
    pub id_wraps: u64,
    /// Gap bursts longer than `MaxLost` (S1).
    pub max_lost_exceeded: u64,
    /// Silences longer than `TimeOut` while operating (S1).
    pub timeouts: u64,
    /// The first peer locked on.
    pub peer_locked: u64,
    /// The peer's address changed after it was silent for `TimeOut`.
    pub peer_takeovers: u64,
    /// The peer's source port changed (a controller that reconnected).
    pub port_takeovers: u64,
    /// S2 transitions, a change of error code included.
    pub state_changes: u64,
    /// M2 tolerances, summed over all messages (see [`crate::codec::Tally`]):
    /// unknown child elements, skipped.
    pub unknown_elements: u64,
    /// Unknown attributes, skipped (M2).
    pub unknown_attributes: u64,
    /// Fields absent from a message, previous value kept (M2).
    pub missing_fields: u64,
    /// Attributes absent from a frame, joints or array field, previous
    /// value kept (M4).
    pub missing_values: u64,
    /// Fields in the wrong shape (text for attributes or the other way
    /// round, or empty), previous value kept.
    pub shape_mismatches: u64,
    /// Received strings cut at 80 bytes (M6).
    pub truncated_strings: u64,
    /// Non-whitespace text between a record's fields, skipped.
    pub stray_text: u64,
    /// M5: non-finite reals sent as zero.
    pub non_finite: u64,
    /// M10: TCP messages longer than the receive buffer.
    pub framing_errors: u64,
    /// TCP peers that closed the connection.
    pub closed: u64,
    /// Replies the transport failed to send (a full queue, no route, a
    /// connection reset while writing): counted, never fatal.
    pub send_errors: u64,
    /// TCP connections the device closed because they stalled: an
    /// incomplete message held longer than `TimeOut`, or silence for
    /// `TimeOut` while another connection waited.
    pub stalled_closed: u64,
    /// Receive → reply-ready time of every answer (periodic sends are not
    /// timed).
    pub latency: Histogram,
    /// IPv4 fragments (S5): counted by the fragment guard in front of the
    /// board's driver ([`crate::fragments`]) and copied in by the cycle
    /// after every turn ([`super::Engine::set_fragment_stats`]); zero
    /// where there is no guard (the host sensor on std sockets).
    pub fragments: FragmentStats,
}

impl Default for Stats {
    fn default() -> Self {
        Self::ZERO
    }
}

impl Stats {
    /// Every counter at zero (usable in a `static`).
    pub const ZERO: Stats = Stats {
        received: 0,
        sent: 0,
        answered: 0,
        periodic_sent: 0,
        dropped_foreign: 0,
        dropped_invalid_source: 0,
        dropped_throttled: 0,
        dropped_decode: 0,
        dropped_encode: 0,
        decode_errors: [0; DecodeErrorKind::ALL.len()],
        lost: 0,
        duplicates: 0,
        reordered: 0,
        id_wraps: 0,
        max_lost_exceeded: 0,
        timeouts: 0,
        peer_locked: 0,
        peer_takeovers: 0,
        port_takeovers: 0,
        state_changes: 0,
        unknown_elements: 0,
        unknown_attributes: 0,
        missing_fields: 0,
        missing_values: 0,
        shape_mismatches: 0,
        truncated_strings: 0,
        stray_text: 0,
        non_finite: 0,
        framing_errors: 0,
        closed: 0,
        send_errors: 0,
        stalled_closed: 0,
        latency: Histogram::EMPTY,
        fragments: FragmentStats::ZERO,
    };
}

pub(crate) fn bump(c: &mut u64) {
    *c = c.saturating_add(1);
}

pub(crate) fn add(c: &mut u64, n: u64) {
    *c = c.saturating_add(n);
}

impl Stats {
    pub(crate) fn count_drop(&mut self, reason: DropReason) {
        match reason {
            DropReason::ForeignSource => bump(&mut self.dropped_foreign),
            DropReason::InvalidSource => bump(&mut self.dropped_invalid_source),
            DropReason::Throttled => bump(&mut self.dropped_throttled),
            DropReason::Decode(kind) => {
                bump(&mut self.dropped_decode);
                if let Some(c) = self.decode_errors.get_mut(kind.index()) {
                    bump(c);
                }
            }
            DropReason::Encode => bump(&mut self.dropped_encode),
        }
    }

    pub(crate) fn count_tally(&mut self, t: &crate::codec::Tally) {
        add(&mut self.unknown_elements, t.unknown_elements.into());
        add(&mut self.unknown_attributes, t.unknown_attributes.into());
        add(&mut self.missing_fields, t.missing_fields.into());
        add(&mut self.missing_values, t.missing_values.into());
        add(&mut self.shape_mismatches, t.shape_mismatches.into());
        add(&mut self.truncated_strings, t.truncated_strings.into());
        add(&mut self.stray_text, t.stray_text.into());
    }

    /// Decode errors of one kind.
    pub fn decode_errors_of(&self, kind: DecodeErrorKind) -> u64 {
        self.decode_errors.get(kind.index()).copied().unwrap_or(0)
    }
}

/// The fragment counters (S5), `u64` like [`Stats`]'s, saturating. Fragments dropped on arrival
/// are counted per [`crate::fragments::FragmentDrop`], sets given up per
/// [`crate::fragments::SetLoss`]; the fragment guard (`crate::fragments`)
/// counts them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FragmentStats {
    /// IPv4 fragments that arrived (any protocol, any sender).
    pub fragments: u64,
    /// Datagrams put together and handed to the stack.
    pub reassembled: u64,
    /// Fragments dropped: [`crate::fragments::FragmentDrop::Oversize`].
    pub oversize: u64,
    /// Fragments dropped: [`crate::fragments::FragmentDrop::Unwanted`].
    pub unwanted: u64,
    /// Fragments dropped: [`crate::fragments::FragmentDrop::Malformed`].
    pub malformed: u64,
    /// Fragments dropped: [`crate::fragments::FragmentDrop::NoBuffer`].
    pub no_buffer: u64,
    /// Fragments dropped: [`crate::fragments::FragmentDrop::Duplicate`].
    pub duplicate: u64,
    /// Sets given up: [`crate::fragments::SetLoss::TimedOut`].
    pub timed_out: u64,
    /// Sets given up: [`crate::fragments::SetLoss::Evicted`] and [`crate::fragments::SetLoss::Superseded`].
    pub evicted: u64,
    /// Sets given up: [`crate::fragments::SetLoss::Spoiled`].
    pub spoiled: u64,
    /// The controller's sets ([`crate::fragments::Rank::Controller`]) given up incomplete,
    /// timed out or superseded: a fragment of a robot message never
    /// reached the device (in time).
    pub controller_incomplete: u64,
    /// The controller's robot messages lost in reassembly itself: a set
    /// spoiled by a malformed or overlapping fragment or a wrong UDP
    /// checksum once whole, or refused a buffer (never evicted: nothing
    /// ranks above them; a set shown oversize or for another port was no
    /// robot message and is not counted here).
    pub controller_dropped: u64,
    /// The controller's datagrams to the channel port handed to the stack
    /// whole and valid, in one frame (its IPv4 header checksum and length
    /// right; its UDP checksum is the NIC's or the stack's to check) or
    /// reassembled (its UDP checksum checked here): the robot messages
    /// that reached the device (the floods' losses are split with it).
    pub controller_datagrams: u64,
}

impl FragmentStats {
    /// Every counter at zero (for statics).
    pub const ZERO: FragmentStats = FragmentStats {
        fragments: 0,
        reassembled: 0,
        oversize: 0,
        unwanted: 0,
        malformed: 0,
        no_buffer: 0,
        duplicate: 0,
        timed_out: 0,
        evicted: 0,
        spoiled: 0,
        controller_incomplete: 0,
        controller_dropped: 0,
        controller_datagrams: 0,
    };

    /// Fragments dropped on arrival, all reasons.
    pub fn dropped(&self) -> u64 {
        self.oversize
            .saturating_add(self.unwanted)
            .saturating_add(self.malformed)
            .saturating_add(self.no_buffer)
            .saturating_add(self.duplicate)
    }

    /// Sets given up after holding a buffer, all reasons.
    pub fn sets_lost(&self) -> u64 {
        self.timed_out
            .saturating_add(self.evicted)
            .saturating_add(self.spoiled)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn histogram_buckets_are_powers_of_two() {
        let mut h = Histogram::default();
        for us in [0, 1, 2, 3, 4, 1000, 40_000, u64::MAX] {
            h.record(us);
        }
        assert_eq!(h.buckets[0], 1); // 0
        assert_eq!(h.buckets[1], 1); // 1
        assert_eq!(h.buckets[2], 2); // 2, 3
        assert_eq!(h.buckets[3], 1); // 4
        assert_eq!(h.buckets[10], 1); // 1000 < 1024
        assert_eq!(h.buckets[Histogram::BUCKETS - 1], 2); // 40 ms and more
        assert_eq!((h.count, h.min_us, h.max_us), (8, 0, u32::MAX));
        assert_eq!(Histogram::bucket_limit_us(10), Some(1024));
        let mut h = Histogram::default();
        h.record_at(5, 100);
        h.record_at(3, 200);
        h.record_at(9, 300);
        h.record_at(9, 400);
        assert_eq!((h.max_us, h.max_at_us, h.mean_us()), (9, 300, 6));
        assert_eq!(Histogram::bucket_limit_us(Histogram::BUCKETS - 1), None);
    }

    #[test]
    fn decode_error_kinds_have_their_own_counters() {
        assert_eq!(
            DecodeErrorKind::ALL.len(),
            Stats::default().decode_errors.len()
        );
        for (i, k) in DecodeErrorKind::ALL.iter().enumerate() {
            assert_eq!(k.index(), i);
        }
    }

    #[test]
    fn drop_reasons_say_why_and_which_rule() {
        assert_eq!(
            DropReason::InvalidSource.to_string(),
            "source can be no controller: port 0 or not unicast (S4)"
        );
        assert_eq!(
            DropReason::Decode(DecodeErrorKind::InvalidBool).to_string(),
            DecodeErrorKind::InvalidBool.to_string()
        );
    }
}
