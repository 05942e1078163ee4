//! The NUCLEO-144 boards' Ethernet PHY (Microchip LAN8742A) over MDIO:
//! found, reset, told to advertise only what the MAC runs at, and read for
//! the link's state. Plain logic over an [`Mdio`] trait, so it builds and
//! is unit-tested on the host; the board runs it from a slow background
//! task, never from the network stack's poll (see `nucleo::phy`).
//!
//! Why only 100BASE-TX full duplex: embassy-stm32 0.6 configures the MAC
//! once, at 100 Mbit/s full duplex, whatever the PHY negotiates. A PHY
//! that advertised everything would come up at 10 Mbit/s or half duplex
//! with a partner that offers no better, and the MAC would then lose frames
//! with the link "up". Advertising 100FD alone turns such a partner into no
//! link at all; a partner that does not negotiate (forced 100 Mbit/s, which
//! the PHY's parallel detection reads as half duplex) gives a link this
//! module reports as [`Link::Mismatch`]: down to the network stack, logged
//! with the speed and duplex it has.

/// Clause 22 management registers, as every PHY has them, and the
/// LAN8742A's own status register.
mod reg {
    /// Basic Control.
    pub const BCR: u8 = 0;
    /// Basic Status.
    pub const BSR: u8 = 1;
    /// PHY Identifier 1 (OUI bits 3..18).
    pub const ID1: u8 = 2;
    /// PHY Identifier 2 (OUI bits 19..24, model, revision).
    pub const ID2: u8 = 3;
    /// Auto-Negotiation Advertisement.
    pub const ANAR: u8 = 4;
    /// LAN8742A PHY Special Control/Status: the negotiated speed and duplex.
    pub const PSCSR: u8 = 31;
}

const BCR_RESET: u16 = 1 << 15;
const BCR_AN_ENABLE: u16 = 1 << 12;
const BCR_AN_RESTART: u16 = 1 << 9;
const BSR_LINK: u16 = 1 << 2;
const BSR_AN_COMPLETE: u16 = 1 << 5;
/// Selector field 00001 (IEEE 802.3) and the 100BASE-TX full-duplex bit:
/// nothing else is offered.
const ANAR_100_FULL_ONLY: u16 = (1 << 8) | 0b00001;
/// PSCSR bits 4:2, the speed indication.
const PSCSR_SPEED_SHIFT: u16 = 2;
const PSCSR_SPEED_MASK: u16 = 0b111;

/// Clause 22 management access (the MAC's MDIO/MDC pins). Each access is a
/// 64-bit serial frame, about 30 µs at the boards' 2 MHz MDC: never on the
/// cycle's path.
pub trait Mdio {
    /// Register `reg` of the PHY at address `phy`.
    fn read(&mut self, phy: u8, reg: u8) -> u16;
    /// Writes `value` to register `reg` of the PHY at address `phy`.
    fn write(&mut self, phy: u8, reg: u8, value: u16);
}

/// What the link is, as the board reports it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Link {
    /// No link, or auto-negotiation not complete.
    Down,
    /// 100 Mbit/s full duplex: what the MAC runs at. The only state the
    /// network stack sees as up.
    Up,
    /// A link at a speed or duplex the MAC is not configured for (a
    /// partner that does not negotiate): reported down, frames would be
    /// lost.
    Mismatch {
        /// 10 or 100.
        mbit: u16,
        full_duplex: bool,
    },
}

impl Link {
    /// Whether the network stack may use the link.
    pub fn is_up(self) -> bool {
        self == Link::Up
    }
}

/// Why the PHY could not be set up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PhyError {
    /// No address answered with an identifier (MDIO or the PHY's power or
    /// reset line).
    NotFound,
    /// The reset bit did not clear in time.
    ResetTimeout,
}

/// Reset takes at most this many polls of the control register, one per
/// millisecond of the caller's `delay_ms` (the LAN8742A needs well under
/// 500 ms).
const RESET_POLLS: u32 = 500;

/// A found PHY.
pub struct Lan8742<M> {
    mdio: M,
    addr: u8,
    /// Identifier registers 2 and 3, for the log.
    pub id: (u16, u16),
}

impl<M: Mdio> Lan8742<M> {
    /// The first address (0 first, where the NUCLEO boards strap it, then
    /// 1..=31) whose identifier reads as neither all zeros nor all ones (an
    /// MDIO line with nobody on it reads all ones).
    pub fn find(mut mdio: M) -> Result<Self, (M, PhyError)> {
        for addr in 0..32 {
            let id1 = mdio.read(addr, reg::ID1);
            if id1 != 0xffff && id1 != 0 {
                let id2 = mdio.read(addr, reg::ID2);
                return Ok(Lan8742 {
                    mdio,
                    addr,
                    id: (id1, id2),
                });
            }
        }
        Err((mdio, PhyError::NotFound))
    }

    /// The PHY's address on the management bus.
    pub fn address(&self) -> u8 {
        self.addr
    }

    /// Soft reset, waiting (bounded) for the reset bit to clear.
    pub fn reset(&mut self, mut delay_ms: impl FnMut(u32)) -> Result<(), PhyError> {
        self.mdio.write(self.addr, reg::BCR, BCR_RESET);
        for _ in 0..RESET_POLLS {
            if self.mdio.read(self.addr, reg::BCR) & BCR_RESET == 0 {
                return Ok(());
            }
            delay_ms(1);
        }
        Err(PhyError::ResetTimeout)
    }

    /// Advertises 100BASE-TX full duplex only and (re)starts
    /// auto-negotiation (see the module doc for why).
    pub fn advertise_100_full_duplex(&mut self) {
        self.mdio.write(self.addr, reg::ANAR, ANAR_100_FULL_ONLY);
        self.mdio
            .write(self.addr, reg::BCR, BCR_AN_ENABLE | BCR_AN_RESTART);
    }

    /// The link now: two management reads when it is up, one when down.
    /// The status register's link bit latches low, so a link that dropped
    /// since the last poll reads down once even if it is back.
    pub fn poll(&mut self) -> Link {
        let bsr = self.mdio.read(self.addr, reg::BSR);
        if bsr & BSR_LINK == 0 || bsr & BSR_AN_COMPLETE == 0 {
            return Link::Down;
        }
        let speed = (self.mdio.read(self.addr, reg::PSCSR) >> PSCSR_SPEED_SHIFT) & PSCSR_SPEED_MASK;
        // Bit 0 of the field: 10 Mbit/s; bit 1: 100 Mbit/s; bit 2: full
        // duplex (LAN8742A data sheet, register 31).
        let mbit = match speed & 0b011 {
            0b001 => 10,
            0b010 => 100,
            _ => return Link::Down,
        };
        let full_duplex = speed & 0b100 != 0;
        if mbit == 100 && full_duplex {
            Link::Up
        } else {
            Link::Mismatch { mbit, full_duplex }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A management bus with one PHY at `addr`: its registers, a log of
    /// writes, and how many reads the reset bit stays set for.
    struct FakeBus {
        addr: u8,
        regs: [u16; 32],
        writes: Vec<(u8, u16)>,
        reset_reads: u32,
    }

    impl FakeBus {
        fn new(addr: u8) -> Self {
            let mut regs = [0; 32];
            regs[reg::ID1 as usize] = 0x0007;
            regs[reg::ID2 as usize] = 0xc131;
            FakeBus {
                addr,
                regs,
                writes: Vec::new(),
                reset_reads: 0,
            }
        }
    }

    impl Mdio for &mut FakeBus {
        fn read(&mut self, phy: u8, r: u8) -> u16 {
            if phy != self.addr {
                return 0xffff;
            }
            if r == reg::BCR && self.reset_reads > 0 {
                self.reset_reads -= 1;
                return BCR_RESET;
            }
            self.regs[r as usize]
        }
        fn write(&mut self, phy: u8, r: u8, value: u16) {
            assert_eq!(phy, self.addr, "a write to an address nobody answers");
            self.writes.push((r, value));
        }
    }

    #[test]
    fn finds_the_phy_wherever_it_is_strapped() {
        for addr in [0, 1, 31] {
            let mut bus = FakeBus::new(addr);
            let phy = Lan8742::find(&mut bus).ok().unwrap();
            assert_eq!((phy.address(), phy.id), (addr, (0x0007, 0xc131)));
        }
        let mut nobody = FakeBus::new(0);
        nobody.addr = 40;
        assert!(matches!(
            Lan8742::find(&mut nobody),
            Err((_, PhyError::NotFound))
        ));
    }

    #[test]
    fn reset_is_bounded() {
        let mut bus = FakeBus::new(0);
        bus.reset_reads = 3;
        let mut waited = 0;
        {
            let mut phy = Lan8742::find(&mut bus).ok().unwrap();
            assert_eq!(phy.reset(|ms| waited += ms), Ok(()));
        }
        assert_eq!(waited, 3);
        assert_eq!(bus.writes, [(reg::BCR, BCR_RESET)]);

        let mut stuck = FakeBus::new(0);
        stuck.reset_reads = u32::MAX;
        let mut phy = Lan8742::find(&mut stuck).ok().unwrap();
        let mut waited = 0;
        assert_eq!(phy.reset(|ms| waited += ms), Err(PhyError::ResetTimeout));
        assert_eq!(waited, RESET_POLLS);
    }

    #[test]
    fn advertises_100_full_duplex_alone() {
        let mut bus = FakeBus::new(0);
        Lan8742::find(&mut bus)
            .ok()
            .unwrap()
            .advertise_100_full_duplex();
        assert_eq!(
            bus.writes,
            [(reg::ANAR, 0x0101), (reg::BCR, 0x1200)],
            "ANAR: selector 1 and 100BASE-TX FD only; BCR: AN enable and restart"
        );
    }

    #[test]
    fn only_100_full_duplex_is_up() {
        let cases = [
            // (BSR, PSCSR speed field, expected)
            (0x0000, 0b110, Link::Down),
            (BSR_LINK, 0b110, Link::Down), // negotiation not complete
            (BSR_AN_COMPLETE, 0b110, Link::Down),
            (BSR_LINK | BSR_AN_COMPLETE, 0b110, Link::Up),
            (
                BSR_LINK | BSR_AN_COMPLETE,
                0b010,
                Link::Mismatch {
                    mbit: 100,
                    full_duplex: false,
                },
            ),
            (
                BSR_LINK | BSR_AN_COMPLETE,
                0b101,
                Link::Mismatch {
                    mbit: 10,
                    full_duplex: true,
                },
            ),
            (
                BSR_LINK | BSR_AN_COMPLETE,
                0b001,
                Link::Mismatch {
                    mbit: 10,
                    full_duplex: false,
                },
            ),
            (BSR_LINK | BSR_AN_COMPLETE, 0b000, Link::Down), // no speed indicated
        ];
        for (bsr, speed, want) in cases {
            let mut bus = FakeBus::new(0);
            bus.regs[reg::BSR as usize] = bsr;
            bus.regs[reg::PSCSR as usize] = speed << PSCSR_SPEED_SHIFT | 0x0040;
            let got = Lan8742::find(&mut bus).ok().unwrap().poll();
            assert_eq!(got, want, "BSR {bsr:#06x} speed {speed:#05b}");
            assert_eq!(got.is_up(), want == Link::Up);
        }
    }
}
