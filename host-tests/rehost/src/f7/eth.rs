//! The STM32F76x/77x Ethernet MAC with its DMA (RM0410 rev 5 §42,
//! registers §42.8), over RMII to the NUCLEO's LAN8742A
//! ([`crate::lan8742`]); frames travel on [`crate::link::Link`].
//!
//! Refused, as silicon would misbehave: an offset or reserved bit the
//! manual does not define; the MAC enabled or its DMA started with an
//! RMII data pin off its alternate function (the management pins, PA2
//! and PC1, when an MDIO frame starts: drivers set them up later); MDC
//! out of range for HCLK (MACMIIAR CR; IEEE 802.3 clause 22.2.2.13: 2.5
//! MHz at most); any write while DMABMR's software reset runs, which
//! never ends without the PHY's REF_CLK (the MAC's clock domains need
//! it); a frame on the wire while MACCR FES/DM disagree with the PHY's
//! link. Descriptors: `eth_desc.rs`; tests: `eth_tests.rs`.

use crate::bus::{reg, widen, Cx, Peripheral, Refusal, Reg, Regs};
use crate::clocks::mhz;
use crate::lan8742::Phy;

#[path = "eth_desc.rs"]
mod desc;

const NAME: &str = "ETH";

// MAC (§42.8.1), MMC (§42.8.2) and DMA (§42.8.3) offsets.
const MACCR: u32 = 0x00;
const MACFFR: u32 = 0x04;
const MACHTHR: u32 = 0x08;
const MACHTLR: u32 = 0x0C;
const MACMIIAR: u32 = 0x10;
const MACMIIDR: u32 = 0x14;
const MACFCR: u32 = 0x18;
const MACA0HR: u32 = 0x40;
const MACA0LR: u32 = 0x44;
const MMCCR: u32 = 0x100;
const MMCTGFCR: u32 = 0x168;
const MMCRGUFCR: u32 = 0x1C4;
const COUNTERS: [u32; 6] = [0x14C, 0x150, MMCTGFCR, 0x194, 0x198, MMCRGUFCR];
const DMABMR: u32 = 0x1000;
const DMATPDR: u32 = 0x1004;
const DMARPDR: u32 = 0x1008;
const DMARDLAR: u32 = 0x100C;
const DMATDLAR: u32 = 0x1010;
const DMASR: u32 = 0x1014;
const DMAOMR: u32 = 0x1018;
const DMAIER: u32 = 0x101C;
const DMAMFBOCR: u32 = 0x1020;
/// DMACHTDR; DMACHRDR, DMACHTBAR and DMACHRBAR follow.
const DMACHTDR: u32 = 0x1048;

// Bits: MACCR, MACMIIAR, DMABMR, DMAOMR.
const RE: u32 = 1 << 2;
const TE: u32 = 1 << 3;
const APCS: u32 = 1 << 7;
const DM: u32 = 1 << 11;
const FES: u32 = 1 << 14;
const CSTF: u32 = 1 << 25;
const MB: u32 = 1;
const MW: u32 = 1 << 1;
const BMR_SR: u32 = 1;
const EDFE: u32 = 1 << 7;
const OMR_SR: u32 = 1 << 1;
const OMR_ST: u32 = 1 << 13;
const FTF: u32 = 1 << 20;
// DMASR: sources, summaries (NISE and AISE sit at the same bits in
// DMAIER), the process states.
const TS: u32 = 1;
const TPSS: u32 = 1 << 1;
const TBUS: u32 = 1 << 2;
const RS: u32 = 1 << 6;
const RBUS: u32 = 1 << 7;
const RPSS: u32 = 1 << 8;
const AIS: u32 = 1 << 15;
const NIS: u32 = 1 << 16;
/// What NIS summarises: TS, TBUS, RS, ERS.
const NORMAL: u32 = TS | TBUS | RS | 1 << 14;
/// What AIS summarises: TPSS, TJTS, ROS, TUS, RBUS, RPSS, RWTS, ETS, FBES.
const ABNORMAL: u32 = 0x0000_27BA;
/// Written 1 to clear, NIS and AIS included (sticky: RM0410 §42.8.3).
const W1C: u32 = 0x0001_E7FF;
const RPS: u32 = 17;
const TPS: u32 = 20;
const RPS_WAITING: u32 = 0b011;
const RPS_SUSPENDED: u32 = 0b100;
const TPS_RUNNING: u32 = 0b001;
const TPS_SUSPENDED: u32 = 0b110;
/// DMAMFBOCR OMFC: MFC overflowed.
const OMFC: u32 = 1 << 16;
// MMCCR: counters reset, stop at full, reset on read, freeze.
const MMC_CR: u32 = 1;
const MMC_CSR: u32 = 1 << 1;
const MMC_ROR: u32 = 1 << 2;
const MMC_MCF: u32 = 1 << 3;

/// Settings the model does not implement, refused when set: register,
/// bits, what.
const UNMODELLED: &[(u32, u32, &str)] = &[
    (MACCR, 1 << 12, "MACCR LM (loopback)"),
    (MMCCR, 1 << 4, "MMCCR MCP (counter preset)"),
    (DMAOMR, 1 << 24, "DMAOMR DFRF (keeping frames)"),
];

/// RM0410 §42.8: offset, reset value, writable bits, hardware bits. No
/// PTP block (0x700..): the images do not use it.
const TABLE: &[Reg] = &[
    reg(MACCR, "MACCR", 0x0000_8000, 0x02CF_7EFC, 0),
    reg(MACFFR, "MACFFR", 0, 0x8000_07FF, 0),
    reg(MACHTHR, "MACHTHR", 0, 0xFFFF_FFFF, 0),
    reg(MACHTLR, "MACHTLR", 0, 0xFFFF_FFFF, 0),
    reg(MACMIIAR, "MACMIIAR", 0, 0x0000_FFDF, 0),
    reg(MACMIIDR, "MACMIIDR", 0, 0x0000_FFFF, 0),
    reg(MACFCR, "MACFCR", 0, 0xFFFF_00BF, 0),
    reg(0x1C, "MACVLANTR", 0, 0x0001_FFFF, 0),
    reg(0x28, "MACRWUFFR", 0, 0xFFFF_FFFF, 0),
    reg(0x2C, "MACPMTCSR", 0, 0x8000_0207, 0x0000_0060),
    reg(0x34, "MACDBGR", 0, 0, 0x037F_0377),
    reg(0x38, "MACSR", 0, 0, 0x0000_0278),
    reg(0x3C, "MACIMR", 0, 0x0000_0208, 0),
    reg(MACA0HR, "MACA0HR", 0x8000_FFFF, 0x0000_FFFF, 0x8000_0000),
    reg(MACA0LR, "MACA0LR", 0xFFFF_FFFF, 0xFFFF_FFFF, 0),
    reg(0x48, "MACA1HR", 0x0000_FFFF, 0xFF00_FFFF, 0),
    reg(0x4C, "MACA1LR", 0xFFFF_FFFF, 0xFFFF_FFFF, 0),
    reg(0x50, "MACA2HR", 0x0000_FFFF, 0xFF00_FFFF, 0),
    reg(0x54, "MACA2LR", 0xFFFF_FFFF, 0xFFFF_FFFF, 0),
    reg(0x58, "MACA3HR", 0x0000_FFFF, 0xFF00_FFFF, 0),
    reg(0x5C, "MACA3LR", 0xFFFF_FFFF, 0xFFFF_FFFF, 0),
    reg(MMCCR, "MMCCR", 0, 0x0000_003F, 0),
    reg(0x104, "MMCRIR", 0, 0, 0x0002_0060),
    reg(0x108, "MMCTIR", 0, 0, 0x0020_C000),
    reg(0x10C, "MMCRIMR", 0, 0x0002_0060, 0),
    // TGFM is bit 21 in RM0410 (16 in the SVD files).
    reg(0x110, "MMCTIMR", 0, 0x0020_C000, 0),
    reg(0x14C, "MMCTGFSCCR", 0, 0, 0xFFFF_FFFF),
    reg(0x150, "MMCTGFMSCCR", 0, 0, 0xFFFF_FFFF),
    reg(MMCTGFCR, "MMCTGFCR", 0, 0, 0xFFFF_FFFF),
    reg(0x194, "MMCRFCECR", 0, 0, 0xFFFF_FFFF),
    reg(0x198, "MMCRFAECR", 0, 0, 0xFFFF_FFFF),
    reg(MMCRGUFCR, "MMCRGUFCR", 0, 0, 0xFFFF_FFFF),
    reg(DMABMR, "DMABMR", 0x0002_0101, 0x07FF_FFFF, 0),
    reg(DMATPDR, "DMATPDR", 0, 0xFFFF_FFFF, 0),
    reg(DMARPDR, "DMARPDR", 0, 0xFFFF_FFFF, 0),
    reg(DMARDLAR, "DMARDLAR", 0, 0xFFFF_FFFF, 0),
    reg(DMATDLAR, "DMATDLAR", 0, 0xFFFF_FFFF, 0),
    reg(DMASR, "DMASR", 0, W1C, 0x3BFE_0000),
    reg(DMAOMR, "DMAOMR", 0, 0x0731_E0DE, 0),
    reg(DMAIER, "DMAIER", 0, 0x0001_E7FF, 0),
    reg(DMAMFBOCR, "DMAMFBOCR", 0, 0, 0x1FFF_FFFF),
    reg(0x1024, "DMARSWTR", 0, 0x0000_00FF, 0),
    reg(DMACHTDR, "DMACHTDR", 0, 0, 0xFFFF_FFFF),
    reg(0x104C, "DMACHRDR", 0, 0, 0xFFFF_FFFF),
    reg(0x1050, "DMACHTBAR", 0, 0, 0xFFFF_FFFF),
    reg(0x1054, "DMACHRBAR", 0, 0, 0xFFFF_FFFF),
];

/// MACMIIAR CR 000-100: HCLK divider, the HCLK range it is for (MHz).
const CLOCK_RANGES: [(u64, u64, u64); 5] = [
    (42, 60, 100),
    (62, 100, 150),
    (16, 20, 35),
    (26, 35, 60),
    (102, 150, 216),
];

/// The software reset's duration: no figure in the manual (it ends once
/// every clock domain saw it); taken as 1 µs.
const RESET_US: u64 = 1;

/// An MDIO frame under way: 64 MDC clocks (IEEE 802.3 §22.2.4.5: 32
/// bits of preamble, 32 of frame).
#[derive(Clone, Copy, Debug)]
struct Mdio {
    due: u64,
    phy: u8,
    reg: u8,
    write: bool,
    data: u16,
}

/// The MAC, its DMA and the PHY behind it.
pub struct Eth {
    regs: Regs,
    irq: u32,
    /// The LAN8742A, on the MDIO bus and at the other end of RMII.
    pub phy: Phy,
    mdio: Option<Mdio>,
    /// When DMABMR.SR clears (None while REF_CLK is missing).
    reset_due: Option<u64>,
    /// Current transmit and receive descriptors, then buffers (what
    /// DMACHTDR, DMACHRDR, DMACHTBAR and DMACHRBAR read).
    cur: [u32; 4],
    /// A frame whose last segment the DMA does not own yet, and the TDES0
    /// of its first descriptor.
    tx_open: Option<(Vec<u8>, u32)>,
    /// The wire is free from this cycle; the frame at the head of
    /// `link.to_device` has fully arrived at `rx_due`.
    wire_free: u64,
    rx_due: Option<u64>,
    missed: u64,
}

// Indices into `Eth::cur`.
const TX: usize = 0;
const RX: usize = 1;
const TX_BUF: usize = 2;
const RX_BUF: usize = 3;

/// Core cycles in `us` microseconds (at least one).
fn micros(cx: &Cx, us: u64) -> u64 {
    (cx.clocks.core_hz * us).div_ceil(1_000_000).max(1)
}

fn cycles_per_ms(cx: &Cx) -> u64 {
    (cx.clocks.core_hz / 1000).max(1)
}

/// Refuses `what` when the RMII wiring is incomplete: the management
/// pins (`management`) or the others, with SYSCFG's RMII selection.
fn wired(cx: &Cx, management: bool, what: &str) -> Result<(), Refusal> {
    let faults = cx.wiring.rmii_faults_of(management);
    if faults.is_empty() {
        return Ok(());
    }
    Err(format!(
        "ETH: {what} with the RMII wiring incomplete: {}",
        faults.join("; ")
    ))
}

impl Eth {
    /// At reset, raising `irq` (61 on the F7, RM0410 Table 46).
    pub fn new(irq: u32) -> Eth {
        Eth {
            regs: Regs::new(TABLE),
            irq,
            phy: Phy::new(),
            mdio: None,
            // DMABMR.SR reads 1 out of reset until the clocks have run
            // (1 µs of the 16 MHz HSI).
            reset_due: Some(16),
            cur: [0; 4],
            tx_open: None,
            wire_free: 0,
            rx_due: None,
            missed: 0,
        }
    }

    /// Frames dropped since reset because no receive descriptor was free
    /// (what DMAMFBOCR MFC counts until read).
    pub fn missed(&self) -> u64 {
        self.missed
    }

    fn rps(&self) -> u32 {
        (self.regs.get(DMASR) >> RPS) & 7
    }

    /// Sets DMASR's RPS or TPS field.
    fn set_state(&mut self, shift: u32, state: u32) {
        let sr = self.regs.get(DMASR) & !(7 << shift);
        self.regs.set(DMASR, sr | state << shift);
    }

    /// The interrupt line: a summary set and enabled.
    fn line(&self) -> bool {
        self.regs.get(DMASR) & self.regs.get(DMAIER) & (NIS | AIS) != 0
    }

    /// Status bits set; the summaries follow the enabled sources, and the
    /// line is raised when an enabled source was just set.
    fn flag(&mut self, bits: u32, cx: &mut Cx) {
        let ier = self.regs.get(DMAIER);
        let mut sr = self.regs.get(DMASR) | bits;
        if sr & ier & NORMAL != 0 {
            sr |= NIS;
        }
        if sr & ier & ABNORMAL != 0 {
            sr |= AIS;
        }
        self.regs.set(DMASR, sr);
        if bits & ier & (NORMAL | ABNORMAL) != 0 && self.line() {
            cx.raise.push(self.irq);
        }
    }

    /// A frame counted in an MMC counter (MMCCR: frozen, or stopping at
    /// all ones).
    fn count(&mut self, counter: u32) {
        let (cr, v) = (self.regs.get(MMCCR), self.regs.get(counter));
        if cr & MMC_MCF == 0 && (cr & MMC_CSR == 0 || v != u32::MAX) {
            self.regs.set(counter, v.wrapping_add(1));
        }
    }

    /// MB written 1: an MDIO frame at the MDC that CR makes of HCLK.
    fn start_mdio(&mut self, v: u32, cx: &Cx) -> Result<(), Refusal> {
        wired(cx, true, "an MDIO frame (MACMIIAR MB)")?;
        let cr = (v >> 2) & 7;
        let Some(&(div, lo, hi)) = CLOCK_RANGES.get(cr as usize) else {
            return Err(format!("ETH_MACMIIAR: CR = {cr:03b} is reserved"));
        };
        let hclk = cx.clocks.hclk_hz;
        let mdc = hclk / div;
        if !(lo * 1_000_000..=hi * 1_000_000).contains(&hclk) || mdc > 2_500_000 {
            return Err(format!(
                "ETH_MACMIIAR: CR = {cr:03b} divides HCLK by {div}, for HCLK {lo}-{hi} MHz, but HCLK is {} MHz: MDC would be {} MHz (at most 2.5 MHz, IEEE 802.3 clause 22.2.2.13; RM0410 §42.8.1)",
                mhz(hclk),
                mhz(mdc)
            ));
        }
        self.mdio = Some(Mdio {
            due: cx.now + (64 * div * cx.clocks.core_hz).div_ceil(hclk).max(1),
            phy: ((v >> 11) & 0x1F) as u8,
            reg: ((v >> 6) & 0x1F) as u8,
            write: v & MW != 0,
            data: self.regs.get(MACMIIDR) as u16,
        });
        Ok(())
    }

    /// The MDIO frame done: the PHY at its address answers; a read from
    /// any other address gets the idle bus's all ones.
    fn finish_mdio(&mut self, m: Mdio, cx: &mut Cx) -> Result<(), Refusal> {
        self.mdio = None;
        self.regs.set_bits(MACMIIAR, MB, false);
        let cpm = cycles_per_ms(cx);
        if m.phy == self.phy.address() && m.write {
            let r = self.phy.write(m.reg, m.data, m.due, cpm);
            r.map_err(|e| format!("an MDIO write to the PHY: {e}"))?;
        } else if m.phy == self.phy.address() {
            let v = self.phy.read(m.reg, m.due, cpm, cx.link);
            self.regs.set(MACMIIDR, u32::from(v));
        } else if !m.write {
            self.regs.set(MACMIIDR, 0xFFFF);
        }
        Ok(())
    }

    /// DMAOMR written: the flush is at once; a process started checks the
    /// pins and fetches its descriptor, a process stopped says so.
    fn operation_mode(&mut self, old: u32, new: u32, cx: &mut Cx) -> Result<(), Refusal> {
        self.regs.set_bits(DMAOMR, FTF, false);
        let (rising, falling) = (new & !old, old & !new);
        if rising & (OMR_SR | OMR_ST) != 0 {
            wired(cx, false, "starting the DMA (DMAOMR SR/ST)")?;
        }
        if rising & OMR_SR != 0 {
            self.set_state(RPS, RPS_WAITING);
            self.rx_fetch(cx)?;
        }
        if falling & OMR_SR != 0 {
            self.set_state(RPS, 0);
            self.flag(RPSS, cx);
        }
        if rising & OMR_ST != 0 {
            self.set_state(TPS, TPS_RUNNING);
            self.transmit(cx)?;
        }
        if falling & OMR_ST != 0 {
            self.set_state(TPS, 0);
            self.flag(TPSS, cx);
        }
        Ok(())
    }

    /// A write through the register table, then what it sets going.
    fn written(&mut self, offset: u32, size: u32, value: u32, cx: &mut Cx) -> Result<(), Refusal> {
        let off = offset & !3;
        let resetting = self.regs.get(DMABMR) & BMR_SR != 0;
        let line_before = self.line();
        let (old, new) = self.regs.write(NAME, offset, size, value)?;
        let name = self.regs.name(off);
        if resetting && off != DMABMR {
            return Err(format!(
                "ETH_{name}: written while DMABMR.SR is set: the software reset has not completed (it needs the PHY's REF_CLK; RM0410 §42.8.3)"
            ));
        }
        if let Some((_, _, what)) = UNMODELLED.iter().find(|u| u.0 == off && new & u.1 != 0) {
            return Err(format!("ETH: {what} is not modelled"));
        }
        if off == MACCR {
            cx.link.listening = new & RE != 0;
        }
        match off {
            MACCR if new & !old & (TE | RE) != 0 => {
                wired(cx, false, "enabling the MAC (MACCR TE/RE)")?;
                self.transmit(cx)?;
            }
            MACMIIAR if new & MB != 0 => self.start_mdio(new, cx)?,
            // FCB: one pause frame, sent at once in full duplex.
            MACFCR if self.regs.get(MACCR) & DM != 0 => self.regs.set_bits(MACFCR, 1, false),
            MMCCR if new & MMC_CR != 0 => {
                COUNTERS.iter().for_each(|&c| self.regs.set(c, 0));
                self.regs.set_bits(MMCCR, MMC_CR, false);
            }
            DMABMR if new & BMR_SR != 0 => {
                // Every register back to reset, the DMA idle; SR clears
                // once the clock domains saw it. The PHY keeps its state.
                self.regs = Regs::new(TABLE);
                cx.link.listening = false;
                (self.mdio, self.tx_open, self.cur) = (None, None, [0; 4]);
                let due = cx.now + micros(cx, RESET_US);
                self.reset_due = cx.link.ref_clock.then_some(due);
            }
            // SR is set by software, cleared by the hardware only.
            DMABMR => self.regs.set_bits(DMABMR, BMR_SR, old & BMR_SR != 0),
            DMATPDR => self.transmit(cx)?,
            DMARPDR if self.rps() == RPS_SUSPENDED => self.rx_fetch(cx)?,
            DMARDLAR | DMATDLAR => {
                let (i, running) = if off == DMARDLAR {
                    (RX, OMR_SR)
                } else {
                    (TX, OMR_ST)
                };
                if self.regs.get(DMAOMR) & running != 0 {
                    return Err(format!(
                        "ETH_{name}: written while its DMA process runs (DMAOMR): RM0410 §42.8.3 allows it only while stopped"
                    ));
                }
                self.cur[i] = new & !3;
            }
            DMASR => self
                .regs
                .set(DMASR, old & !(widen(0, offset, size, value) & W1C)),
            DMAOMR => self.operation_mode(old, new, cx)?,
            DMAIER => {
                // Sources already set count once enabled.
                self.flag(0, cx);
                if self.line() && !line_before {
                    cx.raise.push(self.irq);
                }
            }
            _ => {}
        }
        Ok(())
    }
}

impl Peripheral for Eth {
    fn name(&self) -> &'static str {
        NAME
    }

    fn read(&mut self, offset: u32, size: u32, _cx: &mut Cx) -> Result<u32, Refusal> {
        let off = offset & !3;
        for (i, v) in (0u32..).zip(self.cur) {
            self.regs.set(DMACHTDR + 4 * i, v);
        }
        let v = self.regs.read(NAME, offset, size)?;
        let counter = COUNTERS.contains(&off) && self.regs.get(MMCCR) & MMC_ROR != 0;
        if off == DMAMFBOCR || counter {
            self.regs.set(off, 0); // cleared by the read
        }
        Ok(v)
    }

    fn write(&mut self, offset: u32, size: u32, value: u32, cx: &mut Cx) -> Result<(), Refusal> {
        let off = offset & !3;
        if self.mdio.is_some() && (off == MACMIIAR || off == MACMIIDR) {
            return Err(format!(
                "ETH_{}: written while an MDIO frame is under way (MACMIIAR MB set; RM0410 §42.8.1)",
                self.regs.name(off)
            ));
        }
        let before = self.regs.clone();
        let result = self.written(offset, size, value, cx);
        if result.is_err() {
            self.regs = before;
        }
        result
    }

    fn advance(&mut self, cx: &mut Cx) -> Result<(), Refusal> {
        let now = cx.now;
        if self.regs.get(DMABMR) & BMR_SR == 0 || !cx.link.ref_clock {
            self.reset_due = None;
        } else if now >= *self.reset_due.get_or_insert(now + micros(cx, RESET_US)) {
            self.regs.set_bits(DMABMR, BMR_SR, false);
            self.reset_due = None;
        }
        if let Some(m) = self.mdio.filter(|m| now >= m.due) {
            self.finish_mdio(m, cx)?;
        }
        self.phy.sense(now, cycles_per_ms(cx), cx.link);
        self.receive(cx)
    }

    fn next_event(&self, _now: u64) -> Option<u64> {
        let mdio = self.mdio.map(|m| m.due);
        [mdio, self.reset_due, self.rx_due]
            .into_iter()
            .flatten()
            .min()
    }
}
