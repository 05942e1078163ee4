//! The independent watchdog (RM0410 rev 5 §30, RM0433 rev 8 §45; one
//! layout): started by 0xCCCC in KR, PR/RLR/WINR writable only after
//! 0x5555 (otherwise silicon ignores the write: it stops the run here),
//! the counter running down from RLR at the LSI's 32 kHz divided by the
//! prescaler, 0xAAAA reloading it. When it reaches zero the chip resets
//! (the machine restarts it, or stops where the run allows no reset).

use crate::bus::{Cx, Peripheral, Refusal, ResetCause};

const KR: u32 = 0x00;
const PR: u32 = 0x04;
const RLR: u32 = 0x08;
const SR: u32 = 0x0C;
const WINR: u32 = 0x10;

/// The LSI's nominal frequency (DS11532 Table 38: 17-47 kHz, 32 typical).
pub const LSI_HZ: u64 = 32_000;

pub struct Iwdg {
    name: &'static str,
    pr: u32,
    rlr: u32,
    winr: u32,
    unlocked: bool,
    /// When the counter was last reloaded, and whether it runs.
    reloaded_at: Option<u64>,
    /// Core clock in Hz at the last access, for the timeout.
    core_hz: u64,
}

impl Iwdg {
    pub fn new(name: &'static str) -> Iwdg {
        Iwdg {
            name,
            pr: 0,
            rlr: 0xFFF,
            winr: 0xFFF,
            unlocked: false,
            reloaded_at: None,
            core_hz: 16_000_000,
        }
    }

    /// Core cycles from a reload to the reset.
    fn timeout(&self) -> u64 {
        let div = 4u64 << self.pr.min(6);
        (u64::from(self.rlr) + 1) * div * self.core_hz / LSI_HZ
    }
}

impl Peripheral for Iwdg {
    fn name(&self) -> &'static str {
        self.name
    }

    fn read(&mut self, offset: u32, _size: u32, _cx: &mut Cx) -> Result<u32, Refusal> {
        match offset & !3 {
            KR => Ok(0),
            PR => Ok(self.pr),
            RLR => Ok(self.rlr),
            // PVU/RVU/WVU: the update completes within the access here.
            SR => Ok(0),
            WINR => Ok(self.winr),
            _ => Err(format!("no register at offset {offset:#x} (reserved)")),
        }
    }

    fn write(&mut self, offset: u32, _size: u32, value: u32, cx: &mut Cx) -> Result<(), Refusal> {
        self.core_hz = cx.clocks.core_hz.max(1);
        match offset & !3 {
            KR => match value & 0xFFFF {
                0xCCCC => {
                    self.reloaded_at = Some(cx.now);
                    self.unlocked = false;
                }
                0xAAAA => {
                    if self.reloaded_at.is_some() {
                        self.reloaded_at = Some(cx.now);
                    }
                    self.unlocked = false;
                }
                0x5555 => self.unlocked = true,
                other => return Err(format!("{}_KR: {other:#06x} is no key", self.name)),
            },
            PR | RLR | WINR if !self.unlocked => {
                return Err(format!(
                "{}: offset {offset:#x} written without the 0x5555 key in KR: silicon ignores it",
                self.name
            ))
            }
            PR => self.pr = value & 7,
            RLR => self.rlr = value & 0xFFF,
            WINR => self.winr = value & 0xFFF,
            _ => return Err(format!("no register at offset {offset:#x} (reserved)")),
        }
        Ok(())
    }

    fn advance(&mut self, cx: &mut Cx) -> Result<(), Refusal> {
        if let Some(at) = self.reloaded_at {
            if cx.now >= at + self.timeout() {
                // The machine restarts the chip (or stops, if the run
                // allows no reset), naming the timeout.
                *cx.reset = Some(ResetCause::Watchdog {
                    after_ms: self.timeout() * 1000 / self.core_hz,
                });
                self.reloaded_at = None;
            }
        }
        Ok(())
    }

    fn next_event(&self, _now: u64) -> Option<u64> {
        self.reloaded_at.map(|at| at + self.timeout())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::{no_dma, Shared};

    #[test]
    fn an_expired_watchdog_resets_the_chip_once() {
        let mut w = Iwdg::new("IWDG");
        let mut shared = Shared::default();
        shared.clocks.core_hz = 16_000_000;
        let mut cx = shared.cx(0, no_dma());
        w.write(KR, 4, 0xCCCC, &mut cx).unwrap();
        // PR 0 (/4), RLR 0xFFF: 4096 * 4 / 32 kHz = 512 ms.
        let timeout = 4096 * 4 * 16_000_000 / LSI_HZ;
        let mut cx = shared.cx(timeout - 1, no_dma());
        w.advance(&mut cx).unwrap();
        assert_eq!(*cx.reset, None, "not yet");
        let mut cx = shared.cx(timeout, no_dma());
        w.advance(&mut cx).unwrap();
        assert_eq!(*cx.reset, Some(ResetCause::Watchdog { after_ms: 512 }));
        *cx.reset = None;
        w.advance(&mut cx).unwrap();
        assert_eq!(*cx.reset, None, "stopped until started again");
    }
}
