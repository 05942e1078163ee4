//! The Ethernet MAC's station management (MDIO) interface (RM0433 rev 8
//! §58.11.4, ETH_MACMDIOAR and ETH_MACMDIODR): clause 22 frames to the
//! LAN8742A, each 64 MDC clocks long (32-bit preamble, 32-bit frame: IEEE
//! 802.3 22.2.4.5), MDC being HCLK divided as CR selects. GB stays set
//! until the frame ends, and the PHY answers at that time.

// The parent's names: its registers and bits, Cx, Refusal.
use super::*;
use crate::clocks::mhz;

// ETH_MACMDIOAR.
const C45E: u32 = 1 << 1;
const PSE: u32 = 1 << 27;

/// An MDIO frame under way (MACMDIOAR GB set): what it does and when it
/// ends.
#[derive(Clone, Copy, Debug)]
pub(super) struct Mdio {
    pub(super) at: u64,
    write: bool,
    clause45: bool,
    phy: u32,
    reg: u8,
    data: u16,
}

impl Eth {
    /// MACMDIOAR written with GB: checks CR against HCLK (RM0433 §58.11.4,
    /// ETH_MACMDIOAR CR; MDC at most 2.5 MHz, IEEE 802.3 22.2.2.13) and the
    /// MDC and MDIO pins, then starts a frame of 64 MDC clocks (32 with
    /// PSE, the preamble suppressed).
    pub(super) fn start_mdio(&mut self, ar: u32, cx: &Cx) -> Result<(), Refusal> {
        let cr = (ar >> 8) & 0xF;
        let hclk = cx.clocks.hclk_hz;
        let (div, range): (u64, Option<(u64, u64)>) = match cr {
            0 => (42, Some((60, 100))),
            1 => (62, Some((100, 150))),
            2 => (16, Some((20, 35))),
            3 => (26, Some((35, 60))),
            4 => (102, Some((150, 250))),
            5 => (124, Some((250, 300))),
            8..=15 => (u64::from(4 + 2 * (cr - 8)), None),
            _ => {
                return Err(format!(
                    "ETH_MACMDIOAR: CR = {cr} is reserved (RM0433 §58.11.4)"
                ))
            }
        };
        let mdc = hclk / div;
        let fast = mdc > 2_500_000;
        let limit = "the 2.5 MHz IEEE 802.3 22.2.2.13 allows";
        if let Some((lo, hi)) = range {
            if !(lo * 1_000_000..=hi * 1_000_000).contains(&hclk) {
                return Err(format!(
                    "ETH_MACMDIOAR: CR = {cr} is for HCLK {lo}-{hi} MHz (MDC = HCLK/{div}) with HCLK at {} MHz: MDC would run at {} MHz{} (RM0433 §58.11.4)",
                    mhz(hclk),
                    mhz(mdc),
                    if fast { format!(", above {limit}") } else { String::new() }
                ));
            }
        }
        if fast {
            return Err(format!(
                "ETH_MACMDIOAR: CR = {cr} (HCLK/{div}) with HCLK at {} MHz: MDC would run at {} MHz, above {limit}",
                mhz(hclk),
                mhz(mdc)
            ));
        }
        let clause45 = ar & C45E != 0;
        let write = match (ar >> 2) & 3 {
            1 => true,
            3 => false,
            2 if clause45 => false,
            goc => {
                return Err(format!(
                    "ETH_MACMDIOAR: GOC = {goc:02b} is not an operation (01 write, 11 read; 10 for clause 45 only)"
                ))
            }
        };
        let pins = cx.wiring.rmii_faults_of(true);
        if !pins.is_empty() {
            return Err(format!(
                "ETH_MACMDIOAR: an MDIO frame started while {}: it would not reach the PHY",
                pins.join("; ")
            ));
        }
        let clocks = if ar & PSE != 0 { 32 } else { 64 };
        let time = clocks * div * cx.clocks.core_hz.max(1) / hclk.max(1);
        self.mdio = Some(Mdio {
            at: cx.now + time.max(1),
            write,
            clause45,
            phy: (ar >> 21) & 0x1F,
            reg: ((ar >> 16) & 0x1F) as u8,
            data: self.regs.get(MACMDIODR) as u16,
        });
        Ok(())
    }

    /// The frame ends: the PHY answers at its address (0 on the NUCLEO),
    /// clause 22 only; nothing else is on the bus, and the LAN8742A ignores
    /// clause 45 frames, so MDIO's pull-up reads 0xFFFF there. MD holds a
    /// read's data, GB clears.
    pub(super) fn finish_mdio(&mut self, op: Mdio, cx: &mut Cx) -> Result<(), Refusal> {
        let per_ms = (cx.clocks.core_hz / 1000).max(1);
        let ours = op.phy == u32::from(self.phy.address()) && !op.clause45;
        let read = match (op.write, ours) {
            (true, true) => {
                let write = self.phy.write(op.reg, op.data, op.at, per_ms);
                write.map_err(|e| format!("MDIO write to the LAN8742A: {e}"))?;
                None
            }
            (true, false) => None,
            (false, true) => Some(self.phy.read(op.reg, op.at, per_ms, cx.link)),
            (false, false) => Some(0xFFFF),
        };
        if let Some(value) = read {
            let dr = self.regs.get(MACMDIODR);
            self.regs
                .set(MACMDIODR, (dr & 0xFFFF_0000) | u32::from(value));
        }
        self.regs.set_bits(MACMDIOAR, GB, false);
        Ok(())
    }
}
