//! One robot message as `cargo qemu-bench` sees it ([`Record`]), and its
//! line in the firmware's log: the `bench` build writes the line (its
//! `bench_log` task), the host tools read it back with [`Record::parse`].
//! Both sides use this one definition, so a field added here is a field
//! both know. Counts, not instructions: under QEMU `-icount` one count is
//! a fixed number of instructions (the bench's shift says how many).

/// One robot message's counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Record {
    /// Datagram (or TCP message) length.
    pub bytes: u32,
    /// Answered (`true`) or dropped.
    pub answered: bool,
    /// The engine's work.
    pub compute: u32,
    /// From the stack taking the frame that completes the message to the
    /// driver taking the reply's first frame; 0 when not answered.
    pub full: u32,
    /// The frames taken in since the last message.
    pub frames: u32,
    /// The frame that completed the message, before the span: the driver
    /// reading it from the NIC (the QEMU board's LAN9118 is read a word
    /// at a time by the CPU; the STM32 boards' DMA does that work) and
    /// smoltcp taking its token.
    pub read: u32,
    /// The same frame in the span: the driver's share.
    pub driver: u32,
    /// The same frame: the fragment guard's share.
    pub guard: u32,
    /// The same frame: smoltcp's share (up to the socket's queue).
    pub smoltcp: u32,
    /// Every other frame since the last message, all layers (the earlier
    /// fragments: work done before the full span starts).
    pub before: u32,
    /// The network runner's calls for a frame in the full span that the
    /// fragment guard's hold refused. Two are the message's own (the
    /// stack asks again in the pass that hands the message over, and once
    /// in the reply's pass); each more is a whole pass of the stack the
    /// message waited through (none since the runner is passed over while
    /// the cycle works, `fragments::guard::run_gated`).
    pub held_in: u32,
    /// Frames the stack built in the span and the hold kept from leaving
    /// (the driver refused them a token; smoltcp built each segment's
    /// header before asking).
    pub held_out: u32,
}

impl Record {
    /// A `bench key=value …` line of the log (any prefix before `] bench
    /// `), every field present; `None` for any other line, or one that
    /// lacks a field (an image older than this definition).
    pub fn parse(line: &str) -> Option<Record> {
        let (_, fields) = line.split_once("] bench ")?;
        let mut r = Record::default();
        let mut seen = 0u16;
        for field in fields.split_whitespace() {
            let (key, value) = field.split_once('=')?;
            let (bit, slot) = match key {
                "answered" => {
                    r.answered = value.parse().ok()?;
                    seen |= 1;
                    continue;
                }
                "bytes" => (1, &mut r.bytes),
                "compute" => (2, &mut r.compute),
                "full" => (3, &mut r.full),
                "frames" => (4, &mut r.frames),
                "read" => (5, &mut r.read),
                "driver" => (6, &mut r.driver),
                "guard" => (7, &mut r.guard),
                "smoltcp" => (8, &mut r.smoltcp),
                "before" => (9, &mut r.before),
                "held_in" => (10, &mut r.held_in),
                "held_out" => (11, &mut r.held_out),
                _ => continue,
            };
            *slot = value.parse().ok()?;
            seen |= 1 << bit;
        }
        (seen == (1 << 12) - 1).then_some(r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_logged_line_reads_back_whole() {
        let r = Record::parse(
            "[    1.000 INFO ] bench bytes=698 answered=true compute=11420 full=13000 frames=1 read=70 driver=90 guard=210 smoltcp=600 before=0 held_in=2 held_out=1 lost=0",
        );
        assert_eq!(
            r,
            Some(Record {
                bytes: 698,
                answered: true,
                compute: 11420,
                full: 13000,
                frames: 1,
                read: 70,
                driver: 90,
                guard: 210,
                smoltcp: 600,
                before: 0,
                held_in: 2,
                held_out: 1,
            })
        );
    }

    #[test]
    fn a_line_missing_a_field_or_garbled_is_not_a_record() {
        // An image older than the layers, or than the hold's counts.
        assert_eq!(
            Record::parse("[ 1.0 INFO ] bench bytes=698 answered=true compute=1 full=2 frames=1 read=1 driver=1 guard=1 smoltcp=1 before=1 lost=0"),
            None
        );
        assert_eq!(
            Record::parse("[ 1.0 INFO ] bench bytes=698 answered=true compute=1 full=2 lost=0"),
            None
        );
        assert_eq!(
            Record::parse(
                "] bench bytes=x answered=true compute=1 full=2 frames=1 read=1 driver=1 guard=1 smoltcp=1 before=1 held_in=0 held_out=0"
            ),
            None
        );
        assert_eq!(Record::parse("[ 1.0 INFO ] codec manual bytes=648"), None);
    }
}
