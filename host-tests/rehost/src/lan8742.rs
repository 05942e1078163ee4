//! The NUCLEO-144 boards' Ethernet PHY, a Microchip LAN8742A strapped to
//! MDIO address 0, as its management registers answer (data sheet
//! DS00001989, §4 "Register descriptions"; registers 0-6 as IEEE 802.3
//! clause 22, §22.2.4, defines them).
//!
//! Time is core cycles, with the caller's cycles per millisecond (the
//! latest figure counts for every deadline still to come). A soft reset
//! holds 0.5 ms; auto-negotiation completes 1.5 s after it (re)started or
//! the cable ([`Link::cable`]) went in. The far end is a switch port
//! offering 10/100 half/full duplex with pause (ANLPAR 0x45E1): the link
//! runs at the best mode in common with ANAR (IEEE 802.3 Annex 28B.3),
//! and not at all when nothing is in common.
//!
//! Unknown registers read 0 and refuse writes; reserved bits written 1
//! are refused; read-only registers ignore writes. Refused as not
//! modelled: loopback, far loopback, and the MMD registers behind 13/14
//! other than MMD 3's wake-up control and status (index 32784).

use crate::link::Link;

pub const BMCR: u8 = 0;
pub const BMSR: u8 = 1;
pub const PHYID1: u8 = 2;
pub const PHYID2: u8 = 3;
pub const ANAR: u8 = 4;
pub const ANLPAR: u8 = 5;
pub const ANER: u8 = 6;
pub const MMDACR: u8 = 13;
pub const MMDAADR: u8 = 14;
pub const MCSR: u8 = 17;
pub const SMR: u8 = 18;
pub const SECR: u8 = 26;
pub const SCSIR: u8 = 27;
pub const ISFR: u8 = 29;
pub const IMR: u8 = 30;
pub const PSCSR: u8 = 31;

const BMCR_RESET: u16 = 1 << 15;
const BMCR_LOOPBACK: u16 = 1 << 14;
const BMCR_SPEED_100: u16 = 1 << 13;
const BMCR_AN_ENABLE: u16 = 1 << 12;
const BMCR_POWER_DOWN: u16 = 1 << 11;
const BMCR_ISOLATE: u16 = 1 << 10;
const BMCR_AN_RESTART: u16 = 1 << 9;
const BMCR_FULL_DUPLEX: u16 = 1 << 8;
/// The BMCR bits whose change restarts negotiation or the forced link.
const RELINK: u16 =
    BMCR_AN_ENABLE | BMCR_SPEED_100 | BMCR_FULL_DUPLEX | BMCR_POWER_DOWN | BMCR_ISOLATE;
/// BMCR's reset value: 100 Mbit/s, auto-negotiation on, full duplex.
const BMCR_DEFAULT: u16 = 0x3100;
/// BMSR but link and AN complete: 100/10 full/half, AN able, extended.
const BMSR_BASE: u16 = 0x7809;
const BMSR_LINK: u16 = 1 << 2;
const BMSR_AN_COMPLETE: u16 = 1 << 5;
/// ANAR's reset value: all four technologies, selector IEEE 802.3.
const ANAR_DEFAULT: u16 = 0x01E1;
/// The partner's page: acknowledge, pause, 100/10 full/half, IEEE 802.3.
const PARTNER: u16 = 0x45E1;
/// Register 17's ENERGYON (read-only): energy on the wire.
const ENERGYON: u16 = 1 << 1;
const FAR_LOOPBACK: u16 = 1 << 9;
/// Register 18's reset value: MODE 111 (all capable), PHYAD 0 (straps).
const SMR_DEFAULT: u16 = 0x00E0;
/// Register 29's sources: ENERGYON, AN complete, link down.
const INT_ENERGYON: u16 = 1 << 7;
const INT_AN_COMPLETE: u16 = 1 << 6;
const INT_LINK_DOWN: u16 = 1 << 4;
/// Register 31: Autodone, and the reset value (Enable 4B5B).
const PSCSR_AUTODONE: u16 = 1 << 12;
const PSCSR_DEFAULT: u16 = 0x0040;
/// MMD 3's wake-up control and status register (WUCSR), by index.
const WUCSR: u16 = 0x8010;

/// The soft reset's duration (DS00001989: 0.5 ms), in µs.
const RESET_US: u64 = 500;
/// Auto-negotiation with the switch port, in ms (a typical figure).
const AN_MS: u64 = 1500;
/// A forced (AN off) link coming up, in ms: a guess (no figure given).
const FORCED_MS: u64 = 10;
/// Cycles per millisecond until told (the 16 MHz HSI out of reset).
const POWER_ON_CYCLES_PER_MS: u64 = 16_000;

/// The mode a link runs at.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mode {
    pub mbit: u16,
    pub full_duplex: bool,
}

impl Mode {
    /// Register 31's speed indication, bits 4:2: 001 10 Mbit/s, 010 100
    /// Mbit/s, plus 100 for full duplex.
    fn code(self) -> u16 {
        u16::from(self.mbit == 10)
            | u16::from(self.mbit == 100) << 1
            | u16::from(self.full_duplex) << 2
    }
}

/// The ANAR technology bits, best first (IEEE 802.3 Annex 28B.3):
/// bit, Mbit/s, full duplex.
const TECHNOLOGIES: [(u16, u16, bool); 4] = [
    (1 << 8, 100, true),
    (1 << 7, 100, false),
    (1 << 6, 10, true),
    (1 << 5, 10, false),
];

/// A register the model knows: name, writable bits, read-only bits.
fn masks(reg: u8) -> Option<(&'static str, u16, u16)> {
    Some(match reg {
        BMCR => ("BMCR", 0xFF00, 0),
        BMSR => ("BMSR", 0, 0xFFFF),
        PHYID1 => ("PHYID1", 0, 0xFFFF),
        PHYID2 => ("PHYID2", 0, 0xFFFF),
        ANAR => ("ANAR", 0x2DE0, 0x001F),
        ANLPAR => ("ANLPAR", 0, 0xFFFF),
        ANER => ("ANER", 0, 0xFFFF),
        MMDACR => ("MMD access control", 0xC01F, 0),
        MMDAADR => ("MMD access address/data", 0xFFFF, 0),
        MCSR => ("mode control/status", 0x2240, 0x0002),
        // Bit 14 taken as writable (the data sheet is unclear here).
        SMR => ("special modes", 0x40FF, 0),
        SECR => ("symbol error counter", 0, 0xFFFF),
        SCSIR => ("special control/status indications", 0xA800, 0x0010),
        ISFR => ("interrupt source flags", 0, 0xFFFF),
        IMR => ("interrupt mask", 0x01FE, 0),
        PSCSR => ("PHY special control/status", 0x0040, 0x101C),
        _ => return None,
    })
}

/// The PHY's registers and where it is in its reset and negotiation.
#[derive(Clone, Debug)]
pub struct Phy {
    /// The registers software writes, by number (the others are computed
    /// when read).
    r: [u16; 32],
    /// The MMD address register 14 holds; MMD 3's WUCSR.
    mmd_addr: u16,
    wucsr: u16,
    /// The soft reset holds until this cycle.
    reset_until: u64,
    /// Negotiation (or the forced link) last (re)started at this cycle.
    started: u64,
    /// The cable has been in since this cycle (None: out).
    partner: Option<u64>,
    /// The latest cycles per millisecond the caller gave.
    cpm: u64,
    /// The latest time seen (accesses may come with earlier times).
    seen: u64,
    was_up: bool,
    /// BMSR's link bit latches low until read (IEEE 802.3 §22.2.4.2.13).
    latched_down: bool,
}

impl Default for Phy {
    fn default() -> Phy {
        Phy::new()
    }
}

impl Phy {
    /// At power-on: registers at reset, negotiating from cycle 0 with the
    /// cable taken as in since then (a read with it out says otherwise).
    pub fn new() -> Phy {
        let mut p = Phy {
            r: [0; 32],
            mmd_addr: 0,
            wucsr: 0,
            reset_until: 0,
            started: 0,
            partner: Some(0),
            cpm: POWER_ON_CYCLES_PER_MS,
            seen: 0,
            was_up: false,
            latched_down: false,
        };
        p.set(SMR, SMR_DEFAULT);
        p.defaults();
        p
    }

    fn r(&self, reg: u8) -> u16 {
        self.r[usize::from(reg & 31)]
    }

    fn set(&mut self, reg: u8, v: u16) {
        self.r[usize::from(reg & 31)] = v;
    }

    /// Every register but the straps (register 18) at its reset value.
    fn defaults(&mut self) {
        let straps = self.r(SMR);
        self.r = [0; 32];
        self.set(BMCR, BMCR_DEFAULT);
        self.set(ANAR, ANAR_DEFAULT);
        self.set(PSCSR, PSCSR_DEFAULT);
        self.set(SMR, straps);
        (self.mmd_addr, self.wucsr) = (0, 0);
    }

    /// Its MDIO address (register 18's PHYAD).
    pub fn address(&self) -> u8 {
        (self.r(SMR) & 0x1F) as u8
    }

    /// The mode the link would run at: negotiated (the best technology
    /// both ends advertise) or forced by BMCR; None when nothing is in
    /// common.
    pub fn mode(&self) -> Option<Mode> {
        let bmcr = self.r(BMCR);
        if bmcr & BMCR_AN_ENABLE == 0 {
            return Some(Mode {
                mbit: if bmcr & BMCR_SPEED_100 != 0 { 100 } else { 10 },
                full_duplex: bmcr & BMCR_FULL_DUPLEX != 0,
            });
        }
        TECHNOLOGIES
            .iter()
            .find(|(bit, _, _)| self.r(ANAR) & PARTNER & bit != 0)
            .map(|&(_, mbit, full_duplex)| Mode { mbit, full_duplex })
    }

    /// Whether the link is up at `now`: out of reset, powered, not
    /// isolated, the cable in, a mode in common, and negotiation (or the
    /// forced link) done.
    pub fn link_up(&self, now: u64) -> bool {
        let Some(since) = self.partner else {
            return false;
        };
        let bmcr = self.r(BMCR);
        if now < self.reset_until
            || bmcr & (BMCR_POWER_DOWN | BMCR_ISOLATE) != 0
            || self.mode().is_none()
        {
            return false;
        }
        let an = bmcr & BMCR_AN_ENABLE != 0;
        let ms = if an { AN_MS } else { FORCED_MS };
        now >= self.started.max(since) + ms * self.cpm
    }

    /// Brings the cable and link state up to `now`: a cable plugged in
    /// starts negotiating, a link lost latches BMSR's link bit low; the
    /// interrupt sources (register 29) follow.
    pub fn sense(&mut self, now: u64, cpm: u64, link: &Link) {
        self.cpm = cpm.max(1);
        let now = now.max(self.seen);
        self.seen = now;
        let mut isfr = self.r(ISFR);
        match (link.cable, self.partner) {
            (true, None) => {
                self.partner = Some(now);
                isfr |= INT_ENERGYON;
            }
            (false, Some(_)) => self.partner = None,
            _ => {}
        }
        let up = self.link_up(now);
        if up && !self.was_up && self.r(BMCR) & BMCR_AN_ENABLE != 0 {
            isfr |= INT_AN_COMPLETE;
        }
        if !up && self.was_up {
            self.latched_down = true;
            isfr |= INT_LINK_DOWN;
        }
        self.was_up = up;
        self.set(ISFR, isfr);
    }

    /// A management read of register `reg` at `now` (`cpm`: core cycles
    /// per millisecond).
    pub fn read(&mut self, reg: u8, now: u64, cpm: u64, link: &Link) -> u16 {
        self.sense(now, cpm, link);
        let now = self.seen;
        let up = self.link_up(now);
        let negotiated = up && self.r(BMCR) & BMCR_AN_ENABLE != 0;
        match reg {
            BMCR if now < self.reset_until => self.r(BMCR) | BMCR_RESET,
            BMSR => {
                let latched = std::mem::take(&mut self.latched_down);
                let link_bit = up && !latched;
                BMSR_BASE
                    | (BMSR_LINK * u16::from(link_bit))
                    | (BMSR_AN_COMPLETE * u16::from(negotiated))
            }
            PHYID1 => 0x0007,
            PHYID2 => 0xC131,
            ANLPAR => PARTNER * u16::from(negotiated),
            ANER => u16::from(negotiated), // the partner negotiates
            MMDAADR => self.mmd_read(),
            MCSR => self.r(MCSR) | (ENERGYON * u16::from(link.cable)),
            ISFR => std::mem::take(&mut self.r[usize::from(ISFR)]),
            PSCSR => match self.mode().filter(|_| up) {
                Some(mode) => {
                    self.r(PSCSR) | (mode.code() << 2) | (PSCSR_AUTODONE * u16::from(negotiated))
                }
                None => self.r(PSCSR),
            },
            SECR => 0, // no symbol errors
            _ if masks(reg).is_some() => self.r(reg),
            _ => 0,
        }
    }

    /// A management write of `value` to register `reg` at `now`.
    pub fn write(&mut self, reg: u8, value: u16, now: u64, cpm: u64) -> Result<(), String> {
        self.cpm = cpm.max(1);
        let now = now.max(self.seen);
        self.seen = now;
        let Some((name, rw, ro)) = masks(reg) else {
            return Err(format!(
                "LAN8742A: register {reg} written ({value:#06x}): no such register in the model (DS00001989 §4)"
            ));
        };
        if now < self.reset_until {
            return Err(format!(
                "LAN8742A {name} (register {reg}) written ({value:#06x}) during the soft reset (BMCR bit 15 still set)"
            ));
        }
        let reserved = value & !(rw | ro);
        if reserved != 0 {
            return Err(format!(
                "LAN8742A {name} (register {reg}): reserved bits {reserved:#06x} written (value {value:#06x}; DS00001989 §4)"
            ));
        }
        let v = value & rw;
        if (reg == BMCR && v & BMCR_LOOPBACK != 0) || (reg == MCSR && v & FAR_LOOPBACK != 0) {
            return Err(format!(
                "LAN8742A {name}: loopback ({value:#06x}) is not modelled"
            ));
        }
        match reg {
            BMCR if v & BMCR_RESET != 0 => self.soft_reset(now),
            BMCR => {
                let changed = (self.r(BMCR) ^ v) & RELINK;
                // Restart AN clears itself once negotiation restarted.
                self.set(BMCR, v & !BMCR_AN_RESTART);
                if changed != 0 || (v & BMCR_AN_RESTART != 0 && v & BMCR_AN_ENABLE != 0) {
                    self.started = now;
                }
            }
            MMDAADR => self.mmd_write(v)?,
            // Read-only registers ignore writes; the others keep their
            // read-only bits (ANAR's selector stays IEEE 802.3). A new ANAR
            // counts from the next negotiation (here: at once).
            _ if rw != 0 => {
                let keep = self.r(reg) & ro;
                self.set(reg, v | keep);
            }
            _ => {}
        }
        Ok(())
    }

    /// Registers back to their defaults (the straps in register 18 stay),
    /// the reset bit set for 0.5 ms, negotiation restarting after it.
    fn soft_reset(&mut self, now: u64) {
        self.defaults();
        self.reset_until = now + (RESET_US * self.cpm).div_ceil(1000).max(1);
        self.started = self.reset_until;
    }

    /// Register 14 read: the MMD address, or the data at it (function
    /// 01 keeps the address, 10 and 11 increment it; IEEE 802.3
    /// §22.2.4.3.11-12).
    fn mmd_read(&mut self) -> u16 {
        let ctl = self.r(MMDACR);
        if ctl >> 14 == 0 {
            return self.mmd_addr;
        }
        let wucsr = ctl & 0x1F == 3 && self.mmd_addr == WUCSR;
        let v = if wucsr { self.wucsr } else { 0 };
        if ctl >> 14 == 2 {
            self.mmd_addr = self.mmd_addr.wrapping_add(1);
        }
        v
    }

    /// Register 14 written: the MMD address, or data for MMD 3's WUCSR
    /// (any other MMD register is refused).
    fn mmd_write(&mut self, v: u16) -> Result<(), String> {
        let ctl = self.r(MMDACR);
        if ctl >> 14 == 0 {
            self.mmd_addr = v;
            return Ok(());
        }
        let device = ctl & 0x1F;
        if device != 3 || self.mmd_addr != WUCSR {
            return Err(format!(
                "LAN8742A MMD device {device} register {} written ({v:#06x}) through registers 13/14: not modelled",
                self.mmd_addr
            ));
        }
        self.wucsr = v;
        if ctl >> 14 >= 2 {
            self.mmd_addr = self.mmd_addr.wrapping_add(1);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 216 MHz.
    const CPM: u64 = 216_000;

    fn ms(n: u64) -> u64 {
        n * CPM
    }

    /// The PHY with its wire.
    struct Bench(Phy, Link);

    impl Bench {
        fn new() -> Bench {
            Bench(Phy::new(), Link::nucleo())
        }
        fn rd(&mut self, reg: u8, at: u64) -> u16 {
            self.0.read(reg, at, CPM, &self.1)
        }
        fn wr(&mut self, reg: u8, v: u16, at: u64) -> Result<(), String> {
            self.0.write(reg, v, at, CPM)
        }
    }

    #[test]
    fn identifies_as_a_lan8742a_and_refuses_unknown_registers() {
        let mut b = Bench::new();
        assert_eq!((b.rd(PHYID1, 0), b.rd(PHYID2, 0)), (0x0007, 0xC131));
        assert_eq!(b.rd(7, 0), 0);
        let e = b.wr(7, 1, 0).unwrap_err();
        assert!(e.contains("register 7"), "{e}");
        let e = b.wr(BMCR, 0x0001, 0).unwrap_err();
        assert!(e.contains("BMCR") && e.contains("reserved"), "{e}");
        assert_eq!(b.0.address(), 0);
    }

    #[test]
    fn the_soft_reset_clears_itself_after_half_a_millisecond() {
        let mut b = Bench::new();
        b.wr(ANAR, 0x0101, ms(10)).unwrap();
        b.wr(BMCR, 0x8000, ms(20)).unwrap();
        assert_ne!(b.rd(BMCR, ms(20) + 1) & BMCR_RESET, 0);
        assert!(b.wr(ANAR, 0x0101, ms(20) + 2).is_err());
        assert_eq!(b.rd(BMCR, ms(20) + CPM / 2 + 1), 0x3100);
        assert_eq!(b.rd(ANAR, ms(21)), 0x01E1);
    }

    #[test]
    fn negotiation_completes_after_its_time_with_the_cable_in() {
        let mut b = Bench::new();
        b.wr(ANAR, 0x0101, 0).unwrap();
        b.wr(BMCR, 0x1200, 0).unwrap();
        assert_eq!(b.rd(BMCR, 1), 0x1000, "restart AN clears itself");
        assert_eq!(b.rd(BMSR, ms(1000)), 0x7809);
        assert!(!b.0.link_up(ms(1000)));
        assert_eq!(b.rd(BMSR, ms(1500)), 0x7809 | 0x24);
        assert!(b.0.link_up(ms(1500)));
        assert_eq!(b.rd(ANLPAR, ms(1600)), 0x45E1);
        assert_eq!(b.rd(PSCSR, ms(1600)), 0x1000 | 0x40 | 0b110 << 2);
        assert_eq!(b.rd(ISFR, ms(1600)), INT_AN_COMPLETE);
        assert_eq!(b.rd(ISFR, ms(1600)), 0, "read clears");
    }

    #[test]
    fn no_cable_no_link_and_a_cable_plugged_in_starts_negotiation() {
        let mut b = Bench::new();
        b.1.cable = false;
        assert_eq!(b.rd(BMSR, ms(3000)) & 0x24, 0);
        b.1.cable = true;
        assert_eq!(b.rd(BMSR, ms(3000)) & 0x24, 0);
        assert_eq!(b.rd(BMSR, ms(4400)) & 0x24, 0);
        assert_eq!(b.rd(BMSR, ms(4500)) & 0x24, 0x24);
        // Pulled and plugged back in with no BMSR read in between: the
        // link bit reads low once, with the link up again.
        b.1.cable = false;
        b.rd(PHYID1, ms(5000));
        b.1.cable = true;
        b.rd(PHYID1, ms(5000));
        assert_eq!(b.rd(BMSR, ms(6600)) & 0x24, 0x20, "latched low");
        assert_eq!(b.rd(BMSR, ms(6600)) & 0x24, 0x24);
        assert_ne!(b.rd(ISFR, ms(6600)) & INT_LINK_DOWN, 0);
    }

    #[test]
    fn the_link_runs_at_the_best_mode_in_common() {
        let mut b = Bench::new();
        b.wr(ANAR, 0x0021, 0).unwrap();
        b.wr(BMCR, 0x1200, 0).unwrap();
        assert_eq!(b.rd(PSCSR, ms(2000)) & 0x1C, 0b001 << 2);
        b.wr(ANAR, 0x0001, ms(2000)).unwrap();
        b.wr(BMCR, 0x1200, ms(2000)).unwrap();
        assert!(!b.0.link_up(ms(5000)), "nothing in common: no link");
    }
}
