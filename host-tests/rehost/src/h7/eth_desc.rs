//! The Ethernet DMA's descriptor rings (RM0433 rev 8 §58.10.4,
//! "Descriptors"; Renode's SynopsysDWCEthernetQualityOfService model, its
//! _DMA.cs and _Descriptors.cs, as the public statement of the same
//! semantics).
//!
//! A ring is DMACxDRLR + 1 descriptors of four words (plus DMACCR DSL
//! words, 32-bit ones on the H7's 32-bit AHB master) from the list
//! address. The DMA works from its current descriptor (DMACCAxDR) while
//! the descriptor is owned (OWN) and the current pointer is not the tail
//! pointer (DMACxDTPR): it stops at the tail as Renode does, by equality,
//! so a tail pointer that is not a descriptor's address never stops it.
//!
//! Transmit ("read" format): TDES0/TDES1 buffer 1/2 addresses, TDES2 B1L
//! [13:0], B2L [29:16], IOC bit 31; TDES3 OWN 31, CTXT 30, FD 29, LD 28,
//! CPC [27:26], TSE 18, CIC [17:16], FL [14:0]. The buffers from FD to LD
//! make one frame; each descriptor is written back with OWN clear, FD and
//! LD kept and no error status (TDES0-2 left: no timestamps).
//!
//! Receive ("read" format): RDES0 buffer 1, RDES2 buffer 2, RDES3 OWN 31,
//! IOC 30, BUF2V 25, BUF1V 24, each buffer DMACRCR RBSZ bytes. Written
//! back: RDES0-2 zero (RS0V-RS2V clear: no VLAN, IP or filter status),
//! RDES3 FD 29, LD 28, LT [18:16] and PL [14:0] on the last descriptor,
//! OWN, CTXT and ES clear.

// The parent's names: its registers and bits, Cx, Refusal, cycles.
use super::*;

pub(super) const OWN: u32 = 1 << 31;
const CTXT: u32 = 1 << 30;
pub(super) const FD: u32 = 1 << 29;
pub(super) const LD: u32 = 1 << 28;
pub(super) const TDES2_IOC: u32 = 1 << 31;
const TSE: u32 = 1 << 18;
pub(super) const RDES3_IOC: u32 = 1 << 30;
pub(super) const BUF2V: u32 = 1 << 25;
pub(super) const BUF1V: u32 = 1 << 24;
/// The shortest frame on the wire, less its FCS (IEEE 802.3 minFrameSize,
/// 64 bytes): the sender's MAC pads shorter ones.
const MIN_FRAME: usize = 60;

/// A descriptor's four words.
fn load(cx: &mut Cx, at: u32) -> Result<[u32; 4], Refusal> {
    let mut b = [0u8; 16];
    cx.dma.read(at, &mut b)?;
    Ok(std::array::from_fn(|i| {
        u32::from_le_bytes([b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]])
    }))
}

fn store(cx: &mut Cx, at: u32, words: &[u32]) -> Result<(), Refusal> {
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    cx.dma.write(at, &bytes)
}

/// The FCS: IEEE 802.3's CRC-32 (reflected, polynomial 0x04C11DB7), sent
/// least significant byte first. The wire model carries frames without
/// it, so the receiver computes the one the MAC would have checked.
pub(super) fn crc32(data: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &byte in data {
        crc ^= u32::from(byte);
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

impl Eth {
    /// DMACRCR RBSZ in bytes; its two low bits are ignored (a multiple of
    /// the 32-bit bus width, RM0433 §58.11.2).
    pub(super) fn rbsz(&self) -> u32 {
        (self.regs.get(DMACRCR) >> 1) & 0x3FFC
    }

    /// The descriptor after `at` in the ring at `list` with `len` + 1
    /// descriptors (Renode's IncreaseDescriptorPointer).
    fn step(&self, at: u32, list: u32, len: u32) -> u32 {
        let size = 16 + 4 * ((self.regs.get(DMACCR) >> 18) & 7);
        let count = (self.regs.get(len) & 0x3FF) + 1;
        let base = self.regs.get(list);
        base.wrapping_add((at.wrapping_sub(base) / size + 1) % count * size)
    }

    /// The PHY passes frames both ways once its link is up. A MAC at
    /// another speed than the link's (MACCR FES) garbles every frame on
    /// RMII (RM0433 §58.11.4, ETH_MACCR FES): refused when a frame passes.
    fn wire_up(&self, cx: &Cx) -> Result<bool, Refusal> {
        if !(cx.link.cable && self.phy.link_up(cx.now)) {
            return Ok(false);
        }
        // Checked at every frame, not only when the MAC starts: a pin
        // moved off its alternate function later garbles every frame.
        self.check_wiring(cx, "a frame on the wire")?;
        let fes = self.regs.get(MACCR) & FES != 0;
        match self.phy.mode() {
            Some(mode) if (mode.mbit == 100) != fes => Err(format!(
                "ETH_MACCR: FES = {} ({} Mbit/s) while the LAN8742A's link runs at {} Mbit/s: every frame on RMII would be garbled",
                u32::from(fes),
                if fes { 100 } else { 10 },
                mode.mbit
            )),
            _ => Ok(true),
        }
    }

    /// An MMC counter counts one (unless MMC_CONTROL CNTFREEZ; CNTSTOPRO
    /// stops it at its maximum instead of rolling over).
    fn count(&mut self, reg: u32) {
        let ctl = self.regs.get(MMC_CONTROL);
        if ctl & CNTFREEZ == 0 {
            let v = self.regs.get(reg);
            let n = if ctl & CNTSTOPRO != 0 {
                v.saturating_add(1)
            } else {
                v.wrapping_add(1)
            };
            self.regs.set(reg, n);
        }
    }

    /// The transmit DMA's walk (on ST or TE set and every write of the tail
    /// pointer, the poll demand): from the current descriptor while it is
    /// owned and not the tail, then suspended with TBU (Renode's StartTx).
    /// TI when the last descriptor of a packet has IOC.
    pub(super) fn transmit(&mut self, cx: &mut Cx) -> Result<(), Refusal> {
        if self.regs.get(DMACTCR) & ST == 0 {
            return Ok(());
        }
        self.set_state(Some(TX_SUSPENDED), None);
        if self.regs.get(MACCR) & TE == 0 {
            return Ok(());
        }
        loop {
            let at = self.regs.get(DMACCATDR);
            if at == self.regs.get(DMACTDTPR) {
                break;
            }
            let d = load(cx, at)?;
            if d[3] & OWN == 0 {
                break;
            }
            let fault = |rule: &str| {
                format!(
                    "ETH transmit descriptor at {at:#010x} (TDES3 {:#010x}): {rule} (RM0433 §58.10.4)",
                    d[3]
                )
            };
            if d[3] & (CTXT | TSE) != 0 {
                return Err(fault(
                    "context descriptors and TCP segmentation are not modelled",
                ));
            }
            let first = d[3] & FD != 0;
            match (self.tx_frame.is_some(), first) {
                (false, false) => return Err(fault("FD clear with no packet begun")),
                (true, true) => return Err(fault("FD set before the packet begun had its LD")),
                _ => {}
            }
            if first {
                if (d[3] >> 16) & 3 != 0 {
                    return Err(fault("CIC set: checksum insertion is not modelled"));
                }
                self.tx_frame = Some((Vec::new(), (d[3] >> 26) & 3));
            }
            for (addr, len) in [(d[0], d[2] & 0x3FFF), (d[1], (d[2] >> 16) & 0x3FFF)] {
                if len == 0 {
                    continue;
                }
                let mut buf = vec![0; len as usize];
                cx.dma.read(addr, &mut buf)?;
                self.regs.set(DMACCATBR, addr);
                if let Some((frame, _)) = &mut self.tx_frame {
                    frame.extend_from_slice(&buf);
                }
            }
            store(cx, at + 12, &[d[3] & (FD | LD)])?;
            let next = self.step(at, DMACTDLAR, DMACTDRLR);
            self.regs.set(DMACCATDR, next);
            if d[3] & LD != 0 {
                if let Some((frame, cpc)) = self.tx_frame.take() {
                    self.send(frame, cpc, cx)?;
                }
                if d[2] & TDES2_IOC != 0 {
                    self.regs.set_bits(DMACSR, TI, true);
                }
            }
        }
        self.regs.set_bits(DMACSR, TBU, true);
        Ok(())
    }

    /// A packet leaves: TDES3 CPC 00 pads it to the minimum and appends
    /// the FCS, 01 appends the FCS only, 10 and 11 send the FCS the buffers
    /// hold (here taken off again: the wire model carries no FCS). Lost
    /// when the PHY has no link.
    fn send(&mut self, mut frame: Vec<u8>, cpc: u32, cx: &mut Cx) -> Result<(), Refusal> {
        match cpc {
            0 => frame.resize(frame.len().max(MIN_FRAME), 0),
            1 => {}
            _ => frame.truncate(frame.len().saturating_sub(4)),
        }
        self.count(TX_PACKET_COUNT_GOOD);
        if self.wire_up(cx)? {
            cx.link.from_device.push_back(frame);
        }
        Ok(())
    }

    /// Frames from the wire, at most one a microsecond of virtual time.
    /// With RE or SR clear, or no link at the PHY, they are lost uncounted,
    /// as on the wire.
    pub(super) fn receive_due(&mut self, cx: &mut Cx) -> Result<(), Refusal> {
        if cx.link.to_device.is_empty() {
            return Ok(());
        }
        if !self.rx_waiting {
            self.rx_at = self.rx_at.max(cx.now);
        }
        let open = self.regs.get(DMACRCR) & SR != 0 && self.regs.get(MACCR) & RE != 0;
        if !open || !self.wire_up(cx)? {
            cx.link.to_device.clear();
            return Ok(());
        }
        let us = cycles(cx, 1);
        while self.rx_at <= cx.now {
            let Some(frame) = cx.link.to_device.pop_front() else {
                break;
            };
            self.receive(frame, cx)?;
            self.rx_at += us;
        }
        Ok(())
    }

    /// One frame: filtered, then written from the current descriptor on
    /// (Renode's StartRx). All its descriptors are found before a byte is
    /// written: when the ring runs out first (not owned, or the tail) the
    /// frame is dropped whole, where silicon would hold it in the 2 KB RX
    /// FIFO and fill the descriptors it has.
    fn receive(&mut self, mut frame: Vec<u8>, cx: &mut Cx) -> Result<(), Refusal> {
        frame.resize(frame.len().max(MIN_FRAME), 0);
        if !self.accepts(&frame[..6]) {
            return Ok(());
        }
        let unicast = frame[0] & 1 == 0;
        let (data, lt) = self.to_memory(frame);
        let rbsz = self.rbsz() as usize;
        if rbsz == 0 {
            return Err("ETH_DMACRCR: RBSZ = 0 with a frame to receive".into());
        }
        let count = (self.regs.get(DMACRDRLR) & 0x3FF) as usize + 1;
        let mut at = self.regs.get(DMACCARDR);
        let mut descs: Vec<(u32, u32)> = Vec::new();
        let mut chunks: Vec<(u32, usize, usize)> = Vec::new();
        let mut placed = 0;
        while placed < data.len() {
            if at == self.regs.get(DMACRDTPR) || descs.len() == count {
                return self.miss();
            }
            let d = load(cx, at)?;
            if d[3] & OWN == 0 {
                return self.miss();
            }
            if d[3] & (BUF1V | BUF2V) == 0 {
                return Err(format!(
                    "ETH receive descriptor at {at:#010x}: RDES3 {:#010x} is owned with neither BUF1V nor BUF2V (RM0433 §58.10.4)",
                    d[3]
                ));
            }
            for (valid, addr) in [(BUF1V, d[0]), (BUF2V, d[2])] {
                if d[3] & valid != 0 && placed < data.len() {
                    let end = data.len().min(placed + rbsz);
                    chunks.push((addr, placed, end));
                    placed = end;
                }
            }
            descs.push((at, d[3]));
            at = self.step(at, DMACRDLAR, DMACRDRLR);
        }
        for (addr, start, end) in chunks {
            cx.dma.write(addr, &data[start..end])?;
            self.regs.set(DMACCARBR, addr);
        }
        let last = descs.len() - 1;
        for (i, &(d, _)) in descs.iter().enumerate() {
            let first = if i == 0 { FD } else { 0 };
            let end = if i == last {
                LD | (lt << 16) | (data.len() as u32 & 0x7FFF)
            } else {
                0
            };
            store(cx, d, &[0, 0, 0, first | end])?;
        }
        self.regs.set(DMACCARDR, at);
        if descs[last].1 & RDES3_IOC != 0 {
            self.regs.set_bits(DMACSR, RI, true);
        }
        if unicast {
            self.count(RX_UNICAST_PACKETS_GOOD);
        }
        self.set_state(None, Some(RX_WAITING));
        Ok(())
    }

    /// No descriptor for a frame: dropped and counted in DMACMFCR MFC and
    /// MTLRXQMPOCR MISPKTCNT (each stops at its maximum and sets its
    /// overflow bit), RBU set, the receive DMA suspended until a frame
    /// finds a descriptor again.
    fn miss(&mut self) -> Result<(), Refusal> {
        self.missed += 1;
        let mfc = self.regs.get(DMACMFCR);
        let mfc = if mfc & 0x7FF == 0x7FF {
            mfc | (1 << 15)
        } else {
            mfc + 1
        };
        self.regs.set(DMACMFCR, mfc);
        let mpoc = self.regs.get(MTLRXQMPOCR);
        let mpoc = if (mpoc >> 16) & 0x7FF == 0x7FF {
            mpoc | (1 << 27)
        } else {
            mpoc + (1 << 16)
        };
        self.regs.set(MTLRXQMPOCR, mpoc);
        self.regs.set_bits(DMACSR, RBU, true);
        self.set_state(None, Some(RX_SUSPENDED));
        Ok(())
    }

    /// The destination address filter (RM0433 §58.11.4, ETH_MACPFR and
    /// ETH_MACAxHR/LR): everything with PR or RA; broadcast unless DBF;
    /// multicast with PM; otherwise a perfect match on MACA0, or on MACA1-3
    /// with AE set and SA clear, MBC masking bytes.
    fn accepts(&self, da: &[u8]) -> bool {
        let pfr = self.regs.get(MACPFR);
        if pfr & (PR | RA) != 0 {
            return true;
        }
        if da.iter().all(|&b| b == 0xFF) {
            return pfr & DBF == 0;
        }
        if da[0] & 1 != 0 && pfr & PM != 0 {
            return true;
        }
        (0..4).any(|n| {
            let hi = self.regs.get(MACA0HR + 8 * n);
            let lo = self.regs.get(MACA0LR + 8 * n);
            let addr = [lo, lo >> 8, lo >> 16, lo >> 24, hi, hi >> 8].map(|b| b as u8);
            let mbc = (hi >> 24) & 0x3F;
            let enabled = hi & (1 << 31) != 0 && hi & (1 << 30) == 0;
            enabled && (0..6).all(|i| mbc & (1 << i) != 0 || addr[i] == da[i])
        })
    }

    /// What the MAC hands the DMA, and RDES3's LT (0 length packet, 1 type
    /// packet, 4 VLAN-tagged): the frame with its FCS, unless MACCR strips
    /// it (ACS: packets whose length/type field is below 1536, their pad
    /// too; CST: type packets).
    fn to_memory(&self, mut frame: Vec<u8>) -> (Vec<u8>, u32) {
        let len_type = usize::from(u16::from_be_bytes([frame[12], frame[13]]));
        let maccr = self.regs.get(MACCR);
        let (strip, lt) = match len_type {
            0x8100 => (maccr & CST != 0, 4),
            0x0600..=0xFFFF => (maccr & CST != 0, 1),
            _ => (maccr & ACS != 0, 0),
        };
        if !strip {
            let fcs = crc32(&frame);
            frame.extend_from_slice(&fcs.to_le_bytes());
        } else if lt == 0 {
            frame.truncate((14 + len_type).min(frame.len()));
        }
        (frame, lt)
    }
}
