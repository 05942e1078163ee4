//! The device's own counters as its log shows them once a second, for the
//! QEMU runs that check them (`cargo soak`, `cargo flood`,
//! `cargo qemu-bench`).

use crate::qemu::Qemu;
use std::time::Duration;

/// The device's counters, from its once-a-second `counters:` log line.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DeviceCounters {
    pub received: u64,
    pub answered: u64,
    pub foreign: u64,
    pub invalid: u64,
    pub throttled: u64,
    pub decode: u64,
}

impl DeviceCounters {
    /// `[…] counters: received R answered A dropped foreign F invalid-source I throttled T decode D | …`.
    pub fn parse(line: &str) -> Option<DeviceCounters> {
        let (_, rest) = line.split_once("] counters: ")?;
        let words: Vec<&str> = rest.split_whitespace().collect();
        let after = |key: &str| -> Option<u64> {
            let i = words.iter().position(|w| *w == key)?;
            words.get(i + 1)?.parse().ok()
        };
        Some(DeviceCounters {
            received: after("received")?,
            answered: after("answered")?,
            foreign: after("foreign")?,
            invalid: after("invalid-source")?,
            throttled: after("throttled")?,
            decode: after("decode")?,
        })
    }

    /// Every message received was answered or dropped for a counted reason.
    pub fn add_up(&self) -> bool {
        self.received == self.answered + self.foreign + self.invalid + self.throttled + self.decode
    }

    /// Waits (up to `timeout`) for a counter line logged after line
    /// `start` and returns the last one.
    pub fn fresh(board: &Qemu, start: usize, timeout: Duration) -> Result<DeviceCounters, String> {
        let end = std::time::Instant::now() + timeout;
        loop {
            if let Some(c) = board.since(start).iter().rev().find_map(|l| Self::parse(l)) {
                return Ok(c);
            }
            if std::time::Instant::now() > end {
                let tail = board.since(start.saturating_sub(5));
                return Err(format!(
                    "no counter line from the device within {timeout:?}; its last lines:\n{}",
                    tail.join("\n")
                ));
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

#[cfg(test)]
mod counter_tests {
    use super::DeviceCounters;

    #[test]
    fn counter_line_parses_and_adds_up() {
        let c = DeviceCounters::parse("[    3.0 INFO ] counters: received 11 answered 6 dropped foreign 1 invalid-source 1 throttled 1 decode 2 | send-errors 0 stalled 0 | lost 0 dup 0").unwrap();
        assert_eq!(
            (
                c.received,
                c.answered,
                c.foreign,
                c.invalid,
                c.throttled,
                c.decode
            ),
            (11, 6, 1, 1, 1, 2)
        );
        assert!(c.add_up());
        assert!(!DeviceCounters { received: 12, ..c }.add_up());
        assert_eq!(DeviceCounters::parse("[ 1 INFO ] state CONNECTED"), None);
    }
}
