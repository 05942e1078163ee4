//! The Ethernet DMA's descriptors (RM0410 rev 5 §42.6.7 transmit, §42.6.8
//! receive; normal format, 8 words with DMABMR EDFE of which 4-7 are
//! skipped) and the MAC's receive filter (§42.5). Walked as Renode's
//! `SynopsysEthernetMAC` does: chained (TCH/RCH: word 3 is the next
//! descriptor) or ring (word 3 a second buffer, DSL words skipped), back
//! to the list's base at TER/RER. Transmit: the buffers from FS to LS are
//! one frame, sent as given (no FCS on [`crate::link::Link`]), padded to
//! 60 bytes unless DP. Receive: a frame holds the wire for its time, then
//! is filtered and written padded to 60 bytes with its FCS (unless APCS
//! or CSTF strip it); with no descriptor it is dropped and counted (MFC),
//! as is one whose descriptors run out (silicon would close the first
//! ones with an error). Lost uncounted: frames while RE, SR or the link
//! is down.

use super::*;

const OWN: u32 = 1 << 31;
// TDES0
const IC: u32 = 1 << 30;
const T_LS: u32 = 1 << 29;
const T_FS: u32 = 1 << 28;
const DP: u32 = 1 << 26;
const TER: u32 = 1 << 21;
const TCH: u32 = 1 << 20;
/// TDES0's status bits, written back 0 (no error).
const TX_STATUS: u32 = 0x0003_FFFF;
// RDES0
const FT: u32 = 1 << 5;
const R_FS: u32 = 1 << 9;
const R_LS: u32 = 1 << 8;
// RDES1
const DIC: u32 = 1 << 31;
const RER: u32 = 1 << 15;
const RCH: u32 = 1 << 14;
// MACFFR
const PM: u32 = 1;
const HU: u32 = 1 << 1;
const HM: u32 = 1 << 2;
const DAIF: u32 = 1 << 3;
const PAM: u32 = 1 << 4;
const BFD: u32 = 1 << 5;
const HPF: u32 = 1 << 10;
const RA: u32 = 1 << 31;
/// More descriptors than this in one walk is a ring that never ends.
const MAX_WALK: usize = 1024;
/// The smallest frame on the wire without its FCS (IEEE 802.3 §4.4.2).
const MIN_FRAME: usize = 60;

/// A descriptor's four words at `at`.
fn read_desc(cx: &mut Cx, at: u32) -> Result<[u32; 4], Refusal> {
    if at & 3 != 0 {
        return Err(format!("ETH: a descriptor at {at:#010x}, not word-aligned"));
    }
    let mut b = [0u8; 16];
    cx.dma.read(at, &mut b)?;
    let w = |i: usize| u32::from_le_bytes([b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]]);
    Ok([w(0), w(1), w(2), w(3)])
}

fn write_word(cx: &mut Cx, at: u32, v: u32) -> Result<(), Refusal> {
    cx.dma.write(at, &v.to_le_bytes())
}

/// IEEE 802.3's CRC-32 (reflected 0x04C11DB7, inverted in and out).
pub fn crc32(data: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in data {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = (crc >> 1) ^ (0xEDB8_8320 & (crc & 1).wrapping_neg());
        }
    }
    !crc
}

/// Where a frame goes: descriptor, RDES1, buffers' (address, bytes).
struct Piece {
    desc: u32,
    rdes1: u32,
    bufs: [(u32, usize); 2],
}

impl Eth {
    /// The descriptor after `at`: the list's base at the end of the ring,
    /// word 3 when chained, else the next in the table.
    fn next_desc(&self, at: u32, end: bool, chained: bool, des3: u32, base: u32) -> u32 {
        let bmr = self.regs.get(DMABMR);
        let size = if bmr & EDFE != 0 { 32 } else { 16 };
        if end {
            self.regs.get(base) & !3
        } else if chained {
            des3
        } else {
            at.wrapping_add(size + 4 * ((bmr >> 2) & 0x1F))
        }
    }

    /// The receive DMA (re)reads its current descriptor: waiting for a
    /// frame if it owns it, else suspended, with RBUS when it was running.
    pub(super) fn rx_fetch(&mut self, cx: &mut Cx) -> Result<(), Refusal> {
        let d = read_desc(cx, self.cur[RX])?;
        if d[0] & OWN != 0 {
            self.set_state(RPS, RPS_WAITING);
        } else if self.rps() != RPS_SUSPENDED {
            self.set_state(RPS, RPS_SUSPENDED);
            self.flag(RBUS, cx);
        }
        Ok(())
    }

    /// Whether the PHY passes frames (its link up), refusing a MAC whose
    /// speed or duplex (MACCR FES, DM) is not the link's: every frame on
    /// RMII would be garbled or collide.
    fn wire_up(&self, cx: &Cx) -> Result<bool, Refusal> {
        let Some(mode) = self
            .phy
            .mode()
            .filter(|_| cx.link.cable && self.phy.link_up(cx.now))
        else {
            return Ok(false);
        };
        // Checked at every frame, not only when the MAC starts: a pin
        // moved off its alternate function later garbles every frame.
        super::wired(cx, false, "a frame on the wire")?;
        let cr = self.regs.get(MACCR);
        let (mbit, full) = (if cr & FES != 0 { 100 } else { 10 }, cr & DM != 0);
        if (mbit, full) != (mode.mbit, mode.full_duplex) {
            return Err(format!(
                "ETH_MACCR: FES/DM say {mbit} Mbit/s {} duplex, the LAN8742A's link runs at {} Mbit/s {} duplex",
                if full { "full" } else { "half" },
                mode.mbit,
                if mode.full_duplex { "full" } else { "half" }
            ));
        }
        Ok(true)
    }

    /// Frames from the wire whose time has come.
    pub(super) fn receive(&mut self, cx: &mut Cx) -> Result<(), Refusal> {
        let now = cx.now;
        let on = self.regs.get(MACCR) & RE != 0 && self.regs.get(DMAOMR) & OMR_SR != 0;
        if !on || cx.link.to_device.is_empty() || !self.wire_up(cx)? {
            cx.link.to_device.clear();
            self.rx_due = None;
            return Ok(());
        }
        if self.rx_due.is_none() {
            // The wire was idle: the first frame starts now.
            self.wire_free = self.wire_free.max(now);
        }
        let mbit = self.phy.mode().map_or(100, |m| u64::from(m.mbit));
        while let Some(len) = cx.link.to_device.front().map(Vec::len) {
            // Preamble and SFD, FCS and the inter-frame gap: 24 bytes.
            let bits = 8 * (len.max(MIN_FRAME) as u64 + 24);
            let end = self.wire_free + (bits * cx.clocks.core_hz).div_ceil(mbit * 1_000_000).max(1);
            if end > now {
                self.rx_due = Some(end);
                return Ok(());
            }
            self.wire_free = end;
            let frame = cx.link.to_device.pop_front().unwrap_or_default();
            self.deliver(frame, cx)?;
        }
        self.rx_due = None;
        Ok(())
    }

    /// Whether the filter passes a frame to the DMA (MACFFR; perfect
    /// filter on MACA0-3, hash table MACHTHR/MACHTLR indexed by the upper
    /// six bits of the destination's CRC, bit-reversed as the Synopsys
    /// MAC does it: Linux's stmmac, dwmac1000_core.c).
    fn accept(&self, frame: &[u8]) -> bool {
        let ffr = self.regs.get(MACFFR);
        let da = frame.get(..6).unwrap_or_default();
        let pause = frame.get(12..14) == Some(&[0x88u8, 0x08][..]);
        if ffr & RA != 0 {
            return true;
        }
        // PCF 00 or 01: control frames never reach the application.
        if pause && (ffr >> 6) & 3 < 2 {
            return false;
        }
        if ffr & PM != 0 {
            return true;
        }
        if da.iter().all(|&b| b == 0xFF) {
            return ffr & BFD == 0;
        }
        let perfect = self.perfect(da) != (ffr & DAIF != 0);
        let hashed = if da.first().is_some_and(|b| b & 1 != 0) {
            if ffr & PAM != 0 {
                return true;
            }
            ffr & HM != 0
        } else {
            ffr & HU != 0
        };
        if !hashed {
            return perfect;
        }
        let index = crc32(da).reverse_bits() >> 26;
        let table = if index & 32 != 0 { MACHTHR } else { MACHTLR };
        self.regs.get(table) & (1 << (index & 31)) != 0 || (ffr & HPF != 0 && perfect)
    }

    /// The destination matches MACA0, or MACA1-3 where enabled (AE, not
    /// SA), with their MBC bytes masked.
    fn perfect(&self, da: &[u8]) -> bool {
        (0..4u32).any(|i| {
            let hi = self.regs.get(MACA0HR + 8 * i);
            let lo = self.regs.get(MACA0LR + 8 * i);
            if i > 0 && (hi & (1 << 31) == 0 || hi & (1 << 30) != 0) {
                return false;
            }
            let mbc = if i > 0 { (hi >> 24) & 0x3F } else { 0 };
            let addr = [lo, lo >> 8, lo >> 16, lo >> 24, hi, hi >> 8];
            da.iter()
                .zip(addr)
                .enumerate()
                .all(|(k, (&b, a))| mbc & (1 << k) != 0 || u32::from(b) == a & 0xFF)
        })
    }

    /// What the DMA writes for a frame, and RDES0's frame-type bits.
    fn to_memory(&self, mut frame: Vec<u8>) -> (Vec<u8>, u32) {
        let lt = frame
            .get(12..14)
            .map_or(0, |t| u16::from_be_bytes([t[0], t[1]]));
        if frame.len() < MIN_FRAME {
            frame.resize(MIN_FRAME, 0);
        }
        let cr = self.regs.get(MACCR);
        let status = if lt >= 0x600 { FT } else { 0 };
        if lt <= 1500 && cr & APCS != 0 {
            frame.truncate(14 + usize::from(lt));
        } else if !(lt >= 0x600 && cr & CSTF != 0) {
            let fcs = crc32(&frame);
            frame.extend_from_slice(&fcs.to_le_bytes());
        }
        (frame, status)
    }

    /// No descriptor for a frame: dropped and counted (MFC wraps into
    /// OMFC).
    fn miss(&mut self) {
        self.missed += 1;
        let v = self.regs.get(DMAMFBOCR);
        let mfc = (v & 0xFFFF) + 1;
        let mfc = if mfc > 0xFFFF { OMFC } else { mfc };
        self.regs.set(DMAMFBOCR, v & !0xFFFF | mfc);
    }

    /// The DMA-owned descriptors from the current one that hold `len`
    /// bytes, and the one after them; None when one is not the DMA's.
    fn rx_plan(&self, len: usize, cx: &mut Cx) -> Result<Option<(Vec<Piece>, u32)>, Refusal> {
        let (mut at, mut left, mut pieces) = (self.cur[RX], len, Vec::new());
        for _ in 0..MAX_WALK {
            let d = read_desc(cx, at)?;
            if d[0] & OWN == 0 {
                return Ok(None);
            }
            let chained = d[1] & RCH != 0;
            let n1 = ((d[1] & 0x1FFF) as usize).min(left);
            let rbs2 = if chained { 0 } else { (d[1] >> 16) & 0x1FFF };
            let n2 = (rbs2 as usize).min(left - n1);
            left -= n1 + n2;
            pieces.push(Piece {
                desc: at,
                rdes1: d[1],
                bufs: [(d[2], n1), (d[3], n2)],
            });
            at = self.next_desc(at, d[1] & RER != 0, chained, d[3], DMARDLAR);
            if left == 0 {
                return Ok(Some((pieces, at)));
            }
        }
        Err(format!(
            "ETH: {MAX_WALK} receive descriptors from {:#010x} hold no room for a {len}-byte frame",
            self.cur[RX]
        ))
    }

    /// One frame off the wire: filtered, then written where the receive
    /// descriptors say.
    fn deliver(&mut self, frame: Vec<u8>, cx: &mut Cx) -> Result<(), Refusal> {
        if frame.len() < 14 || !self.accept(&frame) {
            return Ok(());
        }
        let unicast = frame[0] & 1 == 0;
        let (data, status) = self.to_memory(frame);
        if self.rps() == RPS_SUSPENDED {
            // A frame makes a suspended receive process look again.
            self.rx_fetch(cx)?;
        }
        if self.rps() != RPS_WAITING {
            self.miss();
            return Ok(());
        }
        let Some((pieces, next)) = self.rx_plan(data.len(), cx)? else {
            self.miss();
            self.set_state(RPS, RPS_SUSPENDED);
            self.flag(RBUS, cx);
            return Ok(());
        };
        let (mut off, last) = (0, pieces.len() - 1);
        for (i, p) in pieces.iter().enumerate() {
            for &(addr, n) in p.bufs.iter().filter(|(_, n)| *n > 0) {
                cx.dma.write(addr, &data[off..off + n])?;
                (self.cur[RX_BUF], off) = (addr, off + n);
            }
            let mut rdes0 = if i == 0 { R_FS } else { 0 };
            if i == last {
                rdes0 |= R_LS | status | ((data.len() as u32) & 0x3FFF) << 16;
            }
            write_word(cx, p.desc, rdes0)?;
        }
        self.cur[RX] = next;
        if unicast {
            self.count(MMCRGUFCR);
        }
        if pieces[last].rdes1 & DIC == 0 {
            self.flag(RS, cx);
        }
        // The DMA looks at its next descriptor at once.
        self.rx_fetch(cx)
    }

    /// Transmit poll: frames from the current descriptor while the DMA
    /// owns it, then suspended (TBUS).
    pub(super) fn transmit(&mut self, cx: &mut Cx) -> Result<(), Refusal> {
        if self.regs.get(DMAOMR) & OMR_ST == 0 || self.regs.get(MACCR) & TE == 0 {
            return Ok(());
        }
        self.set_state(TPS, TPS_RUNNING);
        for _ in 0..MAX_WALK {
            let at = self.cur[TX];
            let d = read_desc(cx, at)?;
            if d[0] & OWN == 0 {
                self.set_state(TPS, TPS_SUSPENDED);
                self.flag(TBUS, cx);
                return Ok(());
            }
            if (d[0] >> 22) & 3 != 0 {
                return Err(format!(
                    "ETH: transmit descriptor at {at:#010x} asks for checksum insertion (TDES0 CIC = {}): not modelled",
                    (d[0] >> 22) & 3
                ));
            }
            if d[0] & T_FS != 0 {
                if self.tx_open.is_some() {
                    return Err(format!(
                        "ETH: transmit descriptor at {at:#010x} starts a frame (TDES0 FS) before the last one ended (LS)"
                    ));
                }
                self.tx_open = Some((Vec::new(), d[0]));
            }
            let Some((frame, _)) = self.tx_open.as_mut() else {
                return Err(format!(
                    "ETH: transmit descriptor at {at:#010x} continues a frame that never started (TDES0 FS clear)"
                ));
            };
            let chained = d[0] & TCH != 0;
            let n2 = if chained { 0 } else { (d[1] >> 16) & 0x1FFF };
            for (addr, n) in [(d[2], d[1] & 0x1FFF), (d[3], n2)] {
                if n > 0 {
                    let mut b = vec![0; n as usize];
                    cx.dma.read(addr, &mut b)?;
                    frame.extend_from_slice(&b);
                    self.cur[TX_BUF] = addr;
                }
            }
            write_word(cx, at, d[0] & !(OWN | TX_STATUS))?;
            self.cur[TX] = self.next_desc(at, d[0] & TER != 0, chained, d[3], DMATDLAR);
            if d[0] & T_LS != 0 {
                if let Some((mut frame, first)) = self.tx_open.take() {
                    if first & DP == 0 && frame.len() < MIN_FRAME {
                        frame.resize(MIN_FRAME, 0);
                    }
                    // Without a link the PHY sends nothing.
                    if self.wire_up(cx)? {
                        cx.link.from_device.push_back(frame);
                    }
                    self.count(MMCTGFCR);
                    if d[0] & IC != 0 {
                        self.flag(TS, cx);
                    }
                }
            }
        }
        Err(format!(
            "ETH: more than {MAX_WALK} transmit descriptors owned by the DMA in a row, up to {:#010x}",
            self.cur[TX]
        ))
    }
}

#[cfg(test)]
#[path = "eth_tests.rs"]
mod tests;
