//! Why the board last started, and where it crashed if it did: kept
//! across the reset in a few words of RAM that start-up never clears.
//!
//! A HardFault, a panic or (on QEMU, whose watchdog raises an NMI first)
//! a watchdog writes a [`CrashRecord`] just before it resets the board;
//! the next start reads it, adds what the chip's own reset flags say
//! (the STM32's RCC: watchdog, software, pin, power-on, brown-out), and
//! writes a fresh record that counts the starts since power-on. The
//! record's place is a linker symbol at the end of RAM that no section
//! covers (`__crash_record` in each memory map), so neither cortex-m-rt's
//! start-up nor QEMU's reset (which restores every ELF segment) touches
//! it.
//!
//! RAM after power-on holds anything, so the record carries a magic word
//! and a checksum, and a board whose flags say power-on never trusts it
//! (on the H743 it is not even read before it is written: its RAM has
//! ECC, and random contents may not read back cleanly).
//!
//! The encoding is plain logic, unit-tested on the host; the boards only
//! supply the address and the flags.

/// Longest panic file name kept (its last bytes: the file name matters
/// more than the directories).
pub const FILE_BYTES: usize = 48;

const MAGIC: u32 = 0x5252_4943; // "RRIC"

/// Why the board started.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Cause {
    /// Power was applied (or nothing says otherwise).
    PowerOn,
    /// The reset pin (the NUCLEO's button, or a debug probe).
    Pin,
    /// The supply dipped.
    BrownOut,
    /// The watchdog: the cycle stopped turning.
    Watchdog,
    /// Software asked for it.
    Software,
    /// A HardFault; the handler logged it and reset.
    HardFault,
    /// A panic; the handler logged it and reset.
    Panic,
    /// The stack reached its guard ([`crate::stack_guard`]); the fault
    /// handler logged it and reset.
    StackOverflow,
}

impl Cause {
    /// As the log, the page and the JSON name it.
    pub const fn name(self) -> &'static str {
        match self {
            Cause::PowerOn => "power-on",
            Cause::Pin => "reset pin",
            Cause::BrownOut => "brown-out",
            Cause::Watchdog => "watchdog",
            Cause::Software => "software",
            Cause::HardFault => "HardFault",
            Cause::Panic => "panic",
            Cause::StackOverflow => "stack overflow",
        }
    }
}

/// What the chip's own reset flags say, where it has them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flags {
    /// No flags (QEMU): the record alone tells.
    None,
    /// The flags' verdict.
    Chip(Cause),
}

/// What a start learned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Report {
    /// The cause.
    pub cause: Cause,
    /// A HardFault's or a stack overflow's stacked PC and LR (0 when the
    /// core could not stack them: the overflow's frame itself hit the
    /// guard).
    pub pc: Option<(u32, u32)>,
    /// A panic's file (its last [`FILE_BYTES`] bytes), that length, and
    /// its line.
    pub panic: Option<([u8; FILE_BYTES], u8, u32)>,
    /// Starts since power-on, this one included.
    pub boots: u32,
}

impl Report {
    /// Before start-up has read the record (all zero bytes, so a
    /// `static` holding it starts in `.bss`).
    pub const UNKNOWN: Report = Report {
        cause: Cause::PowerOn,
        pc: None,
        panic: None,
        boots: 0,
    };

    /// The panic's file name (the bytes kept) and line, if it was a panic.
    pub fn panic_file(&self) -> Option<(&[u8], u32)> {
        let (file, len, line) = self.panic.as_ref()?;
        Some((file.get(..usize::from(*len)).unwrap_or(&[]), *line))
    }
}

/// The words kept across a reset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct CrashRecord {
    magic: u32,
    /// 0: none, else a [`Cause`] code.
    kind: u32,
    pc: u32,
    lr: u32,
    line: u32,
    file_len: u32,
    file: [u8; FILE_BYTES],
    boots: u32,
    check: u32,
}

fn code(c: Cause) -> u32 {
    match c {
        Cause::PowerOn => 1,
        Cause::Pin => 2,
        Cause::BrownOut => 3,
        Cause::Watchdog => 4,
        Cause::Software => 5,
        Cause::HardFault => 6,
        Cause::Panic => 7,
        Cause::StackOverflow => 8,
    }
}

fn cause(code: u32) -> Option<Cause> {
    Some(match code {
        1 => Cause::PowerOn,
        2 => Cause::Pin,
        3 => Cause::BrownOut,
        4 => Cause::Watchdog,
        5 => Cause::Software,
        6 => Cause::HardFault,
        7 => Cause::Panic,
        8 => Cause::StackOverflow,
        _ => return None,
    })
}

impl CrashRecord {
    /// A record of `boots` starts and no crash.
    pub const fn fresh(boots: u32) -> Self {
        let mut r = CrashRecord {
            magic: MAGIC,
            kind: 0,
            pc: 0,
            lr: 0,
            line: 0,
            file_len: 0,
            file: [0; FILE_BYTES],
            boots,
            check: 0,
        };
        r.check = r.sum();
        r
    }

    #[inline(never)]
    const fn sum(&self) -> u32 {
        let mut s = self.magic ^ self.kind.rotate_left(3) ^ self.pc.rotate_left(7);
        s ^= self.lr.rotate_left(11) ^ self.line.rotate_left(13) ^ self.file_len.rotate_left(17);
        s ^= self.boots.rotate_left(19);
        let mut i = 0;
        while i < FILE_BYTES {
            s = s.rotate_left(5) ^ self.file[i] as u32;
            i += 1;
        }
        s
    }

    /// Whether the words are a record we wrote (not power-on noise).
    pub fn valid(&self) -> bool {
        self.magic == MAGIC && self.check == self.sum()
    }

    /// Notes a HardFault at `pc` (`lr`) before the reset.
    #[inline(never)]
    pub fn fault(&mut self, pc: u32, lr: u32) {
        self.fault_of(Cause::HardFault, pc, lr);
    }

    /// Notes a stack overflow at `pc` (`lr`) before the reset.
    pub fn stack_overflow(&mut self, pc: u32, lr: u32) {
        self.fault_of(Cause::StackOverflow, pc, lr);
    }

    fn fault_of(&mut self, cause: Cause, pc: u32, lr: u32) {
        self.kind = code(cause);
        self.pc = pc;
        self.lr = lr;
        self.check = self.sum();
    }

    /// Notes a panic at `file`:`line` before the reset.
    #[inline(never)]
    pub fn panic(&mut self, file: &str, line: u32) {
        let bytes = file.as_bytes();
        let tail = bytes
            .get(bytes.len().saturating_sub(FILE_BYTES)..)
            .unwrap_or(&[]);
        self.file = [0; FILE_BYTES];
        for (d, s) in self.file.iter_mut().zip(tail) {
            *d = *s;
        }
        self.kind = code(Cause::Panic);
        self.file_len = tail.len() as u32;
        self.line = line;
        self.check = self.sum();
    }

    /// Notes a watchdog reset (where the board sees it coming).
    pub fn watchdog(&mut self) {
        self.kind = code(Cause::Watchdog);
        self.check = self.sum();
    }

    /// At start-up: what this record (trusted only when the chip's flags
    /// do not say power-on) and the `flags` tell, and the record to write
    /// for the run that starts now.
    pub fn start(&self, flags: Flags) -> (Report, CrashRecord) {
        let power_on = matches!(flags, Flags::Chip(Cause::PowerOn | Cause::BrownOut));
        let kept = (!power_on && self.valid()).then_some(*self);
        let crash = kept.and_then(|r| cause(r.kind));
        let cause = match (crash, flags) {
            (Some(c), _) => c,
            (None, Flags::Chip(c)) => c,
            // QEMU: a reset we did not write down was the power switch or
            // a reset we do not know of.
            (None, Flags::None) if kept.is_some() => Cause::Software,
            (None, Flags::None) => Cause::PowerOn,
        };
        let boots = kept.map_or(1, |r| r.boots.saturating_add(1));
        let report = Report {
            cause,
            pc: kept
                .filter(|_| matches!(cause, Cause::HardFault | Cause::StackOverflow))
                .map(|r| (r.pc, r.lr)),
            panic: kept
                .filter(|_| cause == Cause::Panic)
                .map(|r| (r.file, (r.file_len as usize).min(FILE_BYTES) as u8, r.line)),
            boots,
        };
        (report, CrashRecord::fresh(boots))
    }
}

/// Set by the first fault or panic handler to run ([`claim`]).
static HANDLING: core::sync::atomic::AtomicBool = core::sync::atomic::AtomicBool::new(false);

/// Claims the crash record for a fault or panic handler: `true` for the
/// first handler to run, `false` when one is already being handled (then
/// the caller keeps the first record, logs nothing and resets: a panic of
/// the logger the first one logged through, `crate::fault`).
pub fn claim() -> bool {
    !HANDLING.swap(true, core::sync::atomic::Ordering::SeqCst)
}

/// The record in RAM, at the board's `__crash_record`.
#[cfg(app_board)]
pub(crate) mod ram {
    #![allow(unsafe_code)]
    use super::{CrashRecord, Flags, Report};

    extern "C" {
        /// The memory map's reserved words (no section covers them).
        static mut __crash_record: CrashRecord;
    }

    fn place() -> *mut CrashRecord {
        // Only the address is taken; the memory map reserves 128 bytes
        // there (`CrashRecord` is 80).
        core::ptr::addr_of_mut!(__crash_record)
    }

    /// Reads the record (unless `flags` say power-on: then it may be
    /// noise, and on ECC RAM unreadable) and writes a fresh one.
    pub(crate) fn start(flags: Flags) -> Report {
        let power_on = matches!(
            flags,
            Flags::Chip(super::Cause::PowerOn | super::Cause::BrownOut)
        );
        let old = if power_on {
            CrashRecord::fresh(0)
        } else {
            // SAFETY: the reserved words, read once at start-up before any
            // interrupt can write them; any bit pattern is a valid record.
            unsafe { core::ptr::read_volatile(place()) }
        };
        let (report, fresh) = old.start(flags);
        // SAFETY: as above; nothing else runs yet.
        unsafe { core::ptr::write_volatile(place(), fresh) };
        report
    }

    /// Changes the record in place, from a fault or panic handler (the
    /// board resets right after). In place, not as a volatile copy of the
    /// whole record: that copy cost 650 bytes of flash; the fence keeps
    /// the stores before the reset that follows.
    #[inline(never)]
    pub(crate) fn note(f: &mut dyn FnMut(&mut CrashRecord)) {
        // SAFETY: the reserved words, which nothing else references; the
        // handlers that call this never return, and interrupts of lower
        // priority cannot run meanwhile.
        f(unsafe { &mut *place() });
        core::sync::atomic::compiler_fence(core::sync::atomic::Ordering::SeqCst);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_hardfault_is_reported_at_the_next_start_with_its_pc() {
        let (first, mut r) = CrashRecord::fresh(0).start(Flags::None);
        assert_eq!(first.cause, Cause::Software, "a valid record, no crash");
        r.fault(0x1234, 0x5678);
        let (report, next) = r.start(Flags::None);
        assert_eq!(report.cause, Cause::HardFault);
        assert_eq!(report.pc, Some((0x1234, 0x5678)));
        assert_eq!(report.boots, first.boots + 1);
        // The next start after that is a clean one.
        assert_eq!(next.start(Flags::None).0.pc, None);
    }

    #[test]
    fn a_stack_overflow_is_reported_apart_from_a_hardfault() {
        let mut r = CrashRecord::fresh(1);
        r.stack_overflow(0x0800_1000, 0x0800_2001);
        let (report, _) = r.start(Flags::Chip(Cause::Software));
        assert_eq!(report.cause, Cause::StackOverflow);
        assert_eq!(report.cause.name(), "stack overflow");
        assert_eq!(report.pc, Some((0x0800_1000, 0x0800_2001)));
        assert_eq!(
            cause(code(Cause::StackOverflow)),
            Some(Cause::StackOverflow)
        );
    }

    #[test]
    fn a_panic_keeps_the_tail_of_its_file_name_and_its_line() {
        let mut r = CrashRecord::fresh(3);
        let long = format!("{}/src/codec/decode/events.rs", "x".repeat(80));
        r.panic(&long, 42);
        let (report, _) = r.start(Flags::Chip(Cause::Software));
        assert_eq!(report.cause, Cause::Panic);
        let (file, len, line) = report.panic.unwrap();
        let kept = std::str::from_utf8(&file[..len as usize]).unwrap();
        assert!(kept.ends_with("src/codec/decode/events.rs") && kept.len() == FILE_BYTES);
        assert_eq!((line, report.boots), (42, 4));
    }

    #[test]
    fn power_on_noise_is_never_taken_for_a_record() {
        let noise = CrashRecord {
            magic: MAGIC,
            kind: 6,
            pc: 1,
            lr: 2,
            line: 0,
            file_len: 0,
            file: [0xa5; FILE_BYTES],
            boots: 9,
            check: 0xdead_beef,
        };
        assert!(!noise.valid());
        let (report, fresh) = noise.start(Flags::None);
        assert_eq!(
            (report.cause, report.boots, report.pc),
            (Cause::PowerOn, 1, None)
        );
        assert!(fresh.valid());
        // A valid record is not trusted when the chip says power-on.
        let mut r = CrashRecord::fresh(5);
        r.fault(1, 2);
        let (report, _) = r.start(Flags::Chip(Cause::PowerOn));
        assert_eq!((report.cause, report.boots), (Cause::PowerOn, 1));
    }

    #[test]
    fn the_chips_flags_name_the_cause_when_nothing_crashed() {
        let (report, _) = CrashRecord::fresh(1).start(Flags::Chip(Cause::Watchdog));
        assert_eq!((report.cause, report.boots), (Cause::Watchdog, 2));
        let mut r = CrashRecord::fresh(1);
        r.watchdog();
        assert_eq!(r.start(Flags::None).0.cause, Cause::Watchdog);
    }
}
