//! STM32H743 Ethernet: the Synopsys DWC Ethernet QoS MAC with its MTL and
//! DMA (RM0433 rev 8 §58, "Ethernet (ETH): media access control (MAC) with
//! DMA controller"; registers §58.11), wired over RMII to the NUCLEO's
//! LAN8742A at MDIO address 0 ([`crate::lan8742`]).
//!
//! Registers: offsets, reset values, writable and hardware bits are the
//! fields of ST's STM32H743 SVD (v2.4, Apache-2.0), which follows RM0433;
//! where the SVD leaves a register out (MACHWF0R) or places it elsewhere
//! (MACARPAR: 0x0AE0 in the SVD, 0x0210 in ST's CMSIS header
//! stm32h743xx.h, which the HAL uses) the header and RM0433 win. Reserved
//! bits written stop the run, as in every model here.
//!
//! What the firmware's driver needs, with the rules RM0433 states:
//! - the software reset (DMAMR SWR) ends only while the PHY's 50 MHz
//!   REF_CLK runs, and no register may be written before SWR reads 0;
//! - MDIO frames (eth_mdio.rs) take 64 MDC clocks at HCLK / the CR
//!   divider, and a CR that does not match HCLK (or an MDC above the
//!   2.5 MHz of IEEE 802.3 22.2.2.13) is refused;
//! - TE, RE or a DMA start with the RMII pins or SYSCFG's RMII selection
//!   wrong is refused (the MAC would not reach the PHY);
//! - the descriptor rings (eth_desc.rs): frames to and from
//!   [`crate::link::Link`] through memory the DMA reaches, once the PHY
//!   has the link, with DMACSR's flags and the ETH line (level: raised at
//!   every access and advance while an enabled summary is set).
//!
//! The tests are in eth_tests.rs.
//!
//! Not modelled, and refused when switched on rather than silently
//! ignored: loopback, ARP offload, source address insertion, hash and
//! inverse address filtering, the receive watchdog, checksum insertion,
//! TCP segmentation, context descriptors, timestamps and the layer 3/4
//! filters.

use crate::bus::{reg, widen, Cx, Peripheral, Refusal, Reg, Regs};
use crate::h7::rcc::cycles;
use crate::lan8742::Phy;
use mdio::Mdio;

#[path = "eth_desc.rs"]
mod desc;
#[path = "eth_mdio.rs"]
mod mdio;
#[cfg(test)]
#[path = "eth_tests.rs"]
mod tests;

// MAC (RM0433 §58.11.4).
const MACCR: u32 = 0x0000;
const MACPFR: u32 = 0x0008;
const MACMDIOAR: u32 = 0x0200;
const MACMDIODR: u32 = 0x0204;
const MACA0HR: u32 = 0x0300;
const MACA0LR: u32 = 0x0304;
const MMC_CONTROL: u32 = 0x0700;
const TX_PACKET_COUNT_GOOD: u32 = 0x0768;
const RX_UNICAST_PACKETS_GOOD: u32 = 0x07C4;
/// The MMC counters RM0433 lists (read-only; cleared by CNTRST, or on
/// read with RSTONRD).
const MMC_COUNTERS: [u32; 10] = [
    0x074C, 0x0750, 0x0768, 0x0794, 0x0798, 0x07C4, 0x07EC, 0x07F0, 0x07F4, 0x07F8,
];
// MTL (RM0433 §58.11.3).
const MTLTXQOMR: u32 = 0x0D00;
const MTLRXQMPOCR: u32 = 0x0D34;
// DMA (RM0433 §58.11.2).
const DMAMR: u32 = 0x1000;
const DMAISR: u32 = 0x1008;
const DMADSR: u32 = 0x100C;
const DMACCR: u32 = 0x1100;
const DMACTCR: u32 = 0x1104;
const DMACRCR: u32 = 0x1108;
const DMACTDLAR: u32 = 0x1114;
const DMACRDLAR: u32 = 0x111C;
const DMACTDTPR: u32 = 0x1120;
const DMACRDTPR: u32 = 0x1128;
const DMACTDRLR: u32 = 0x112C;
const DMACRDRLR: u32 = 0x1130;
const DMACIER: u32 = 0x1134;
const DMACRIWTR: u32 = 0x1138;
const DMACCATDR: u32 = 0x1144;
const DMACCARDR: u32 = 0x114C;
const DMACCATBR: u32 = 0x1154;
const DMACCARBR: u32 = 0x115C;
const DMACSR: u32 = 0x1160;
const DMACMFCR: u32 = 0x116C;

// ETH_MACCR.
const RE: u32 = 1 << 0;
const TE: u32 = 1 << 1;
const FES: u32 = 1 << 14;
const ACS: u32 = 1 << 20;
const CST: u32 = 1 << 21;
/// LM (loopback), SARC (source address insertion), ARPEN (ARP offload).
const MACCR_NOT_MODELLED: u32 = (1 << 12) | (7 << 28) | (1 << 31);
// ETH_MACPFR.
const PR: u32 = 1 << 0;
const PM: u32 = 1 << 4;
const DBF: u32 = 1 << 5;
const RA: u32 = 1 << 31;
/// HUC, HMC, DAIF, SAF, VTFE, IPFE: hash, inverse, source, VLAN and
/// layer 3/4 filtering.
const MACPFR_NOT_MODELLED: u32 = 0b1110 | (1 << 9) | (1 << 16) | (1 << 20);
// ETH_MACMDIOAR.
const GB: u32 = 1 << 0;
// MMC_CONTROL.
const CNTRST: u32 = 1 << 0;
const CNTSTOPRO: u32 = 1 << 1;
const RSTONRD: u32 = 1 << 2;
const CNTFREEZ: u32 = 1 << 3;
// ETH_MTLTXQOMR.
const FTQ: u32 = 1 << 0;
// ETH_DMAMR.
const SWR: u32 = 1 << 0;
// ETH_DMACTCR and ETH_DMACRCR.
const ST: u32 = 1 << 0;
const SR: u32 = 1 << 0;
// ETH_DMACSR; ETH_DMACIER's enables sit at the same positions.
const TI: u32 = 1 << 0;
const TPS: u32 = 1 << 1;
const TBU: u32 = 1 << 2;
const RI: u32 = 1 << 6;
const RBU: u32 = 1 << 7;
const RPS: u32 = 1 << 8;
const AIS: u32 = 1 << 14;
const NIS: u32 = 1 << 15;
/// What NIS summarises: TI, TBU, RI, ERI (RM0433 §58.11.2, ETH_DMACSR).
const NORMAL: u32 = TI | TBU | RI | (1 << 11);
/// What AIS summarises: TPS, RBU, RPS, RWT, ETI, FBE, CDE.
const ABNORMAL: u32 = TPS | RBU | RPS | (1 << 9) | (1 << 10) | (1 << 12) | (1 << 13);
/// DMACSR's write-1-to-clear bits.
const W1C: u32 = 0xFFC7;
// ETH_DMADSR RPS0 and TPS0 states.
const RX_STOPPED: u32 = 0;
const RX_WAITING: u32 = 3;
const RX_SUSPENDED: u32 = 4;
const TX_STOPPED: u32 = 0;
const TX_SUSPENDED: u32 = 6;

/// RM0433 §58.11 through ST's SVD: offset, name, reset, writable, hardware
/// bits. MACCR resets to 0x0000_8000 as RM0433 gives it (bit 15, which
/// the SVD leaves out, kept as a hardware bit). MACVR is the SVD's
/// 0x3041 (Renode's STM32H7 model says 0x3142); MACHWF0R is Renode's
/// 0x0A0D_73F7, MACHWF1R and MACHWF2R the SVD's.
#[rustfmt::skip]
const TABLE: &[Reg] = &[
    reg(MACCR, "MACCR", 0x0000_8000, 0xFFFB_7F7F, 0x0000_8000),
    reg(0x0004, "MACECR", 0, 0x3F07_3FFF, 0), reg(MACPFR, "MACPFR", 0, 0x8031_07FF, 0),
    reg(0x000C, "MACWTR", 0, 0x0000_010F, 0),
    reg(0x0010, "MACHT0R", 0, 0xFFFF_FFFF, 0), reg(0x0014, "MACHT1R", 0, 0xFFFF_FFFF, 0),
    reg(0x0050, "MACVTR", 0, 0xBF7F_FFFF, 0), reg(0x0058, "MACVHTR", 0, 0x0000_FFFF, 0),
    reg(0x0060, "MACVIR", 0, 0x001F_FFFF, 0), reg(0x0064, "MACIVIR", 0, 0x001F_FFFF, 0),
    reg(0x0070, "MACQTXFCR", 0, 0xFFFF_00F3, 0), reg(0x0090, "MACRXFCR", 0, 0x0000_0003, 0),
    reg(0x00B0, "MACISR", 0, 0, 0x0000_7738), reg(0x00B4, "MACIER", 0, 0x0000_7038, 0),
    reg(0x00B8, "MACRXTXSR", 0, 0, 0x0000_013F),
    reg(0x00C0, "MACPCSR", 0, 0x9F00_0607, 0x0000_0060),
    reg(0x00C4, "MACRWKPFR", 0, 0xFFFF_FFFF, 0),
    reg(0x00D0, "MACLCSR", 0, 0x001F_0000, 0x0000_030F),
    reg(0x00D4, "MACLTCR", 0x03E8_0000, 0x03FF_FFFF, 0), reg(0x00D8, "MACLETR", 0, 0x0001_FFFF, 0),
    reg(0x00DC, "MAC1USTCR", 0, 0x0000_0FFF, 0),
    reg(0x0110, "MACVR", 0x0000_3041, 0, 0x0000_FFFF), reg(0x0114, "MACDR", 0, 0, 0x0007_0007),
    reg(0x011C, "MACHWF0R", 0x0A0D_73F7, 0, 0xFFFF_FFFF),
    reg(0x0120, "MACHWF1R", 0x1184_1904, 0, 0xFFFF_FFFF),
    reg(0x0124, "MACHWF2R", 0x4100_0000, 0, 0xFFFF_FFFF),
    reg(MACMDIOAR, "MACMDIOAR", 0, 0x0FFF_7F1F, 0), reg(MACMDIODR, "MACMDIODR", 0, 0xFFFF_FFFF, 0),
    reg(0x0210, "MACARPAR", 0, 0xFFFF_FFFF, 0),
    reg(MACA0HR, "MACA0HR", 0x8000_FFFF, 0x0000_FFFF, 0x8000_0000),
    reg(MACA0LR, "MACA0LR", 0xFFFF_FFFF, 0xFFFF_FFFF, 0),
    reg(0x0308, "MACA1HR", 0x0000_FFFF, 0xFF00_FFFF, 0), reg(0x030C, "MACA1LR", !0, !0, 0),
    reg(0x0310, "MACA2HR", 0x0000_FFFF, 0xFF00_FFFF, 0), reg(0x0314, "MACA2LR", !0, !0, 0),
    reg(0x0318, "MACA3HR", 0x0000_FFFF, 0xFF00_FFFF, 0), reg(0x031C, "MACA3LR", !0, !0, 0),
    reg(MMC_CONTROL, "MMC_CONTROL", 0, 0x0000_013F, 0),
    reg(0x0704, "MMC_RX_INTERRUPT", 0, 0, 0x0C02_0060),
    reg(0x0708, "MMC_TX_INTERRUPT", 0, 0, 0x0C20_C000),
    reg(0x070C, "MMC_RX_INTERRUPT_MASK", 0, 0x0402_0060, 0x0800_0000),
    reg(0x0710, "MMC_TX_INTERRUPT_MASK", 0, 0x0420_C000, 0x0800_0000),
    reg(0x074C, "TX_SINGLE_COLLISION_GOOD_PACKETS", 0, 0, !0),
    reg(0x0750, "TX_MULTIPLE_COLLISION_GOOD_PACKETS", 0, 0, !0),
    reg(TX_PACKET_COUNT_GOOD, "TX_PACKET_COUNT_GOOD", 0, 0, !0),
    reg(0x0794, "RX_CRC_ERROR_PACKETS", 0, 0, !0),
    reg(0x0798, "RX_ALIGNMENT_ERROR_PACKETS", 0, 0, !0),
    reg(RX_UNICAST_PACKETS_GOOD, "RX_UNICAST_PACKETS_GOOD", 0, 0, !0),
    reg(0x07EC, "TX_LPI_USEC_CNTR", 0, 0, !0), reg(0x07F0, "TX_LPI_TRAN_CNTR", 0, 0, !0),
    reg(0x07F4, "RX_LPI_USEC_CNTR", 0, 0, !0), reg(0x07F8, "RX_LPI_TRAN_CNTR", 0, 0, !0),
    reg(0x0C00, "MTLOMR", 0, 0x0000_0302, 0), reg(0x0C20, "MTLISR", 0, 0, 0x0000_0001),
    reg(MTLTXQOMR, "MTLTXQOMR", 0x0007_0008, 0x0007_0073, 0x0000_000C),
    reg(0x0D04, "MTLTXQUR", 0, 0, 0x0000_0FFF), reg(0x0D08, "MTLTXQDR", 0, 0, 0x0077_003F),
    reg(0x0D2C, "MTLQICSR", 0, 0x0101_0101, 0),
    reg(0x0D30, "MTLRXQOMR", 0x0070_0000, 0x0001_C7FB, 0x0070_0000),
    reg(MTLRXQMPOCR, "MTLRXQMPOCR", 0, 0, 0x0FFF_0FFF), reg(0x0D38, "MTLRXQDR", 0, 0, 0x3FFF_0037),
    reg(DMAMR, "DMAMR", 0, 0x0001_0001, 0x0000_7802),
    reg(0x1004, "DMASBMR", 0x0101_0000, 0x0000_1001, 0x0000_C000),
    reg(DMAISR, "DMAISR", 0, 0, 0x0003_0001), reg(DMADSR, "DMADSR", 0, 0, 0x0000_FF01),
    reg(DMACCR, "DMACCR", 0, 0x001D_3FFF, 0), reg(DMACTCR, "DMACTCR", 0, 0x003F_1011, 0),
    reg(DMACRCR, "DMACRCR", 0, 0x803F_7FFF, 0),
    reg(DMACTDLAR, "DMACTDLAR", 0, 0xFFFF_FFFC, 0), reg(DMACRDLAR, "DMACRDLAR", 0, 0xFFFF_FFFC, 0),
    reg(DMACTDTPR, "DMACTDTPR", 0, 0xFFFF_FFFC, 0), reg(DMACRDTPR, "DMACRDTPR", 0, 0xFFFF_FFFC, 0),
    reg(DMACTDRLR, "DMACTDRLR", 0, 0x0000_03FF, 0), reg(DMACRDRLR, "DMACRDRLR", 0, 0x0000_03FF, 0),
    reg(DMACIER, "DMACIER", 0, 0x0000_FFC7, 0), reg(DMACRIWTR, "DMACRIWTR", 0, 0x0000_00FF, 0),
    reg(DMACCATDR, "DMACCATDR", 0, 0, !0), reg(DMACCARDR, "DMACCARDR", 0, 0, !0),
    reg(DMACCATBR, "DMACCATBR", 0, 0, !0), reg(DMACCARBR, "DMACCARBR", 0, 0, !0),
    reg(DMACSR, "DMACSR", 0, W1C, 0x003F_0000), reg(DMACMFCR, "DMACMFCR", 0, 0, 0x0000_87FF),
];

/// The ETH block: its registers, the PHY on its MDIO bus, and the state
/// of the MDIO frame, the software reset and the DMA's packets.
pub struct Eth {
    regs: Regs,
    irq: u32,
    /// The LAN8742A at MDIO address 0.
    pub phy: Phy,
    mdio: Option<Mdio>,
    /// When the software reset may end (it ends only with REF_CLK).
    swr_at: Option<u64>,
    /// REF_CLK ran at the last advance (for `next_event`).
    ref_clock: bool,
    /// The earliest time the next frame from the wire may land.
    rx_at: u64,
    /// Frames were waiting on the wire at the last advance.
    rx_waiting: bool,
    /// A transmit packet begun (FD seen, LD not yet) and its TDES3 CPC.
    tx_frame: Option<(Vec<u8>, u32)>,
    missed: u64,
}

impl Eth {
    /// The block at reset; `irq` is the ETH line (61 on the H743).
    pub fn new(irq: u32) -> Eth {
        Eth {
            regs: Regs::new(TABLE),
            irq,
            phy: Phy::new(),
            mdio: None,
            swr_at: None,
            ref_clock: false,
            rx_at: 0,
            rx_waiting: false,
            tx_frame: None,
            missed: 0,
        }
    }

    /// Frames dropped for want of a receive descriptor since power-on (not
    /// cleared by reading DMACMFCR).
    pub fn missed(&self) -> u64 {
        self.missed
    }

    /// Refuses `what` while the MAC cannot reach the PHY: RMII not selected
    /// in SYSCFG_PMCR, or an RMII data pin not on AF11 (UM1974's wiring;
    /// MDC and MDIO are checked when an MDIO frame starts).
    fn check_wiring(&self, cx: &Cx, what: &str) -> Result<(), Refusal> {
        let faults = cx.wiring.rmii_faults_of(false);
        if faults.is_empty() {
            return Ok(());
        }
        Err(format!(
            "{what} while the MAC cannot reach the LAN8742A: {} (RM0433 §58; UM1974 RMII wiring)",
            faults.join("; ")
        ))
    }

    /// DMACSR's summaries, DMAISR DC0IS and the line: NIS and AIS are the
    /// OR of their enabled causes, the line is NIS & NIE | AIS & AIE
    /// (RM0433 §58.11.2, ETH_DMACSR and ETH_DMACIER). Level-sensitive: the
    /// line is raised at every access and advance while it is high.
    fn update_irq(&mut self, cx: &mut Cx) {
        let ier = self.regs.get(DMACIER);
        let mut csr = self.regs.get(DMACSR);
        if csr & ier & NORMAL != 0 {
            csr |= NIS;
        }
        if csr & ier & ABNORMAL != 0 {
            csr |= AIS;
        }
        self.regs.set(DMACSR, csr);
        let line = csr & ier & (NIS | AIS) != 0;
        self.regs.set(DMAISR, u32::from(line));
        if line {
            cx.raise.push(self.irq);
        }
    }

    /// DMADSR's TPS0 and RPS0 process states.
    fn set_state(&mut self, tx: Option<u32>, rx: Option<u32>) {
        let mut dsr = self.regs.get(DMADSR);
        if let Some(tx) = tx {
            dsr = (dsr & !(0xF << 12)) | (tx << 12);
        }
        if let Some(rx) = rx {
            dsr = (dsr & !(0xF << 8)) | (rx << 8);
        }
        self.regs.set(DMADSR, dsr);
    }

    /// DMAMR SWR: every MAC, MTL and DMA register back to its reset value;
    /// SWR clears itself about a microsecond later, but only while REF_CLK
    /// runs (the MAC's clock domains need it: RM0433 §58.11.2, ETH_DMAMR).
    fn software_reset(&mut self, cx: &mut Cx) {
        self.regs = Regs::new(TABLE);
        cx.link.listening = false;
        self.regs.set(DMAMR, SWR);
        self.mdio = None;
        self.tx_frame = None;
        self.swr_at = Some(cx.now + cycles(cx, 1));
    }

    /// MACCR: TE or RE switched on needs the wiring and the RCC's ETH1TX
    /// or ETH1RX clock; TE switched on sends what the ring holds.
    fn write_maccr(&mut self, old: u32, new: u32, cx: &mut Cx) -> Result<(), Refusal> {
        if new & MACCR_NOT_MODELLED != 0 {
            return Err(format!(
                "ETH_MACCR = {new:#010x}: LM, SARC or ARPEN (loopback, source address insertion, ARP offload) are not modelled"
            ));
        }
        let rising = new & !old & (TE | RE);
        if rising != 0 {
            self.check_wiring(cx, "ETH_MACCR: TE or RE set")?;
        }
        for (bit, what, clock) in [(TE, "TE", "ETH1TX"), (RE, "RE", "ETH1RX")] {
            if rising & bit != 0 && !cx.clocks.enabled.contains(&clock) {
                return Err(format!(
                    "ETH_MACCR: {what} set with RCC_AHB1ENR {clock}EN clear: that path of the MAC has no clock (RM0433 §8.7)"
                ));
            }
        }
        if rising & TE != 0 {
            self.transmit(cx)?;
        }
        cx.link.listening = new & RE != 0;
        Ok(())
    }

    /// A write, after the rules that hold whatever the register.
    fn write_reg(
        &mut self,
        reg: u32,
        offset: u32,
        size: u32,
        value: u32,
        cx: &mut Cx,
    ) -> Result<(), Refusal> {
        // An offset with no register is refused as reserved first.
        self.regs.read("ETH", offset, size)?;
        let name = self.regs.name(reg);
        if self.regs.get(DMAMR) & SWR != 0 {
            return Err(format!(
                "ETH_{name} written while ETH_DMAMR SWR is set: no register may be programmed before SWR reads 0 (RM0433 §58.11.2){}",
                if self.ref_clock { "" } else { "; REF_CLK does not run, so the reset never ends" }
            ));
        }
        if (reg == MACMDIOAR || reg == MACMDIODR) && self.mdio.is_some() {
            return Err(format!(
                "ETH_{name} written while ETH_MACMDIOAR GB is set: not before the MDIO frame under way ends (RM0433 §58.11.4)"
            ));
        }
        let running = [(DMACTDLAR, DMACTCR), (DMACRDLAR, DMACRCR)];
        if running
            .iter()
            .any(|&(r, cr)| r == reg && self.regs.get(cr) & 1 != 0)
        {
            return Err(format!(
                "ETH_{name} written while its DMA channel runs: only while it is stopped (RM0433 §58.11.2)"
            ));
        }
        let old_csr = self.regs.get(DMACSR);
        let (old, new) = self.regs.write("ETH", offset, size, value)?;
        let rising = new & !old;
        let falling = old & !new;
        match reg {
            MACCR => self.write_maccr(old, new, cx)?,
            MACPFR if new & MACPFR_NOT_MODELLED != 0 => {
                return Err(format!(
                    "ETH_MACPFR = {new:#010x}: hash, inverse, source-address, VLAN or layer 3/4 filtering is not modelled (perfect, broadcast, multicast, promiscuous and receive-all are)"
                ))
            }
            MACMDIOAR if new & GB != 0 => self.start_mdio(new, cx)?,
            MMC_CONTROL if new & CNTRST != 0 => {
                for r in MMC_COUNTERS {
                    self.regs.set(r, 0);
                }
                self.regs.set_bits(MMC_CONTROL, CNTRST, false);
            }
            // The flush ends at once: frames leave the queue as they come.
            MTLTXQOMR => self.regs.set_bits(MTLTXQOMR, FTQ, false),
            DMAMR if new & SWR != 0 => self.software_reset(cx),
            DMACTCR => {
                if rising & ST != 0 {
                    self.check_wiring(cx, "ETH_DMACTCR: ST set")?;
                    self.transmit(cx)?;
                }
                if falling & ST != 0 {
                    self.regs.set_bits(DMACSR, TPS, true);
                    self.set_state(Some(TX_STOPPED), None);
                }
            }
            DMACRCR => {
                if rising & SR != 0 {
                    self.check_wiring(cx, "ETH_DMACRCR: SR set")?;
                    if self.rbsz() == 0 {
                        return Err("ETH_DMACRCR: SR set with RBSZ = 0".into());
                    }
                    self.set_state(None, Some(RX_WAITING));
                }
                if falling & SR != 0 {
                    self.regs.set_bits(DMACSR, RPS, true);
                    self.set_state(None, Some(RX_STOPPED));
                }
            }
            DMACTDLAR => self.regs.set(DMACCATDR, new),
            DMACRDLAR => self.regs.set(DMACCARDR, new),
            // The transmit poll demand (RM0433 §58.11.2, ETH_DMACTXDTPR).
            DMACTDTPR => self.transmit(cx)?,
            DMACRIWTR if new != 0 => {
                return Err("ETH_DMACRIWTR: the receive interrupt watchdog is not modelled".into())
            }
            DMACSR => {
                let clear = widen(0, offset, size, value) & W1C;
                self.regs.set(DMACSR, old_csr & !clear);
            }
            _ => {}
        }
        Ok(())
    }
}

/// The MAC's register groups this model leaves out: refused by name rather
/// than as reserved offsets.
fn unmodelled(reg: u32) -> Result<(), Refusal> {
    let what = match reg {
        0x0900..=0x094C => "layer 3 and 4 filter",
        0x0B00..=0x0BD0 => "timestamp and PTP offload",
        _ => return Ok(()),
    };
    Err(format!(
        "ETH: offset {reg:#06x} is one of the MAC's {what} registers (RM0433 §58.11.4), which this model does not implement"
    ))
}

impl Peripheral for Eth {
    fn name(&self) -> &'static str {
        "ETH"
    }

    fn read(&mut self, offset: u32, size: u32, _cx: &mut Cx) -> Result<u32, Refusal> {
        let reg = offset & !3;
        unmodelled(reg)?;
        let value = self.regs.read("ETH", offset, size)?;
        let on_read = self.regs.get(MMC_CONTROL) & RSTONRD != 0 && MMC_COUNTERS.contains(&reg);
        // Clear on read (RM0433 §58.11.2-58.11.4).
        if reg == DMACMFCR || reg == MTLRXQMPOCR || on_read {
            self.regs.set(reg, 0);
        }
        Ok(value)
    }

    fn write(&mut self, offset: u32, size: u32, value: u32, cx: &mut Cx) -> Result<(), Refusal> {
        let reg = offset & !3;
        unmodelled(reg)?;
        let before = self.regs.clone();
        let result = self.write_reg(reg, offset, size, value, cx);
        if result.is_err() {
            self.regs = before;
        }
        self.update_irq(cx);
        result
    }

    fn advance(&mut self, cx: &mut Cx) -> Result<(), Refusal> {
        self.ref_clock = cx.link.ref_clock;
        // The PHY follows the cable (plugged in: it negotiates again).
        let per_ms = (cx.clocks.core_hz / 1000).max(1);
        self.phy.sense(cx.now, per_ms, cx.link);
        if cx.link.ref_clock && self.swr_at.is_some_and(|at| at <= cx.now) {
            self.swr_at = None;
            self.regs.set_bits(DMAMR, SWR, false);
        }
        if let Some(op) = self.mdio.filter(|op| op.at <= cx.now) {
            self.mdio = None;
            self.finish_mdio(op, cx)?;
        }
        self.receive_due(cx)?;
        self.rx_waiting = !cx.link.to_device.is_empty();
        self.update_irq(cx);
        Ok(())
    }

    fn next_event(&self, _now: u64) -> Option<u64> {
        let swr = self.swr_at.filter(|_| self.ref_clock);
        let rx = self.rx_waiting.then_some(self.rx_at);
        [swr, self.mdio.map(|op| op.at), rx]
            .into_iter()
            .flatten()
            .min()
    }
}
