//! The Ethernet model's tests (a file of their own: eth.rs and
//! eth_desc.rs are near their line budget): a memory the fake DMA reaches,
//! the NUCLEO's RMII wiring, and the driver's start-up sequence.

use super::desc::{crc32, BUF1V, FD, LD, OWN, RDES3_IOC, TDES2_IOC};
use super::*;
use crate::bus::{Dma, Shared};
use crate::link::Link;
use crate::wiring::{AF_ETH, NUCLEO_RMII};

const CORE_HZ: u64 = 400_000_000;
const HCLK_HZ: u64 = 200_000_000;
const US: u64 = CORE_HZ / 1_000_000;
/// Ten seconds after power-on: the PHY's auto-negotiation long done.
const SETTLED: u64 = 10 * CORE_HZ;
/// 64 MDC clocks at HCLK / 102 (CR = 4), in core cycles.
const MDIO_BUSY: u64 = 64 * 102 * CORE_HZ / HCLK_HZ;
/// MACCR DM: full duplex.
const DM: u32 = 1 << 13;
// Where the rings and buffers are (D2 SRAM1, which the DMA reaches).
const MEM: u32 = 0x3000_0000;
const TX_RING: u32 = MEM;
const RX_RING: u32 = MEM + 0x100;
const TX_BUF: u32 = MEM + 0x1000;
const RX_BUF: u32 = MEM + 0x2000;
const RX_SIZE: u32 = 1536;

/// Memory at `MEM`, as the Ethernet DMA sees it.
struct Mem(Vec<u8>);

impl Mem {
    fn span(&self, addr: u32, len: usize) -> Result<usize, Refusal> {
        let i = addr.wrapping_sub(MEM) as usize;
        if addr < MEM || i + len > self.0.len() {
            return Err(format!("no test memory at {addr:#010x}..+{len}"));
        }
        Ok(i)
    }
}

impl Dma for Mem {
    fn read(&mut self, addr: u32, buf: &mut [u8]) -> Result<(), Refusal> {
        let i = self.span(addr, buf.len())?;
        buf.copy_from_slice(&self.0[i..i + buf.len()]);
        Ok(())
    }
    fn write(&mut self, addr: u32, data: &[u8]) -> Result<(), Refusal> {
        let i = self.span(addr, data.len())?;
        self.0[i..i + data.len()].copy_from_slice(data);
        Ok(())
    }
}

/// The model on a NUCLEO: RMII selected, every RMII pin on AF11, the PHY's
/// clock running and the cable in, HCLK 200 MHz, the ETH clocks on.
struct Rig {
    eth: Eth,
    shared: Shared,
    mem: Mem,
    now: u64,
}

impl Rig {
    fn new() -> Rig {
        let mut shared = Shared {
            link: Link::nucleo(),
            ..Shared::default()
        };
        shared.wiring.rmii = true;
        for (pin, _) in NUCLEO_RMII {
            let port = (pin.as_bytes()[1] - b'A') as usize;
            let n: usize = pin[2..].parse().unwrap();
            shared.wiring.pins[port][n] = (2, AF_ETH);
        }
        shared.clocks.core_hz = CORE_HZ;
        shared.clocks.hclk_hz = HCLK_HZ;
        shared.clocks.enabled = vec!["ETH1MAC", "ETH1TX", "ETH1RX"];
        Rig {
            eth: Eth::new(61),
            shared,
            mem: Mem(vec![0; 0x4000]),
            now: 0,
        }
    }

    /// One access at `now`, after the model's advance, as the bus makes it.
    fn access(&mut self, offset: u32, write: Option<u32>) -> Result<u32, Refusal> {
        let mut cx = self.shared.cx(self.now, &mut self.mem);
        self.eth.advance(&mut cx)?;
        match write {
            Some(v) => self.eth.write(offset, 4, v, &mut cx).map(|()| 0),
            None => self.eth.read(offset, 4, &mut cx),
        }
    }

    fn read(&mut self, offset: u32) -> u32 {
        self.access(offset, None).unwrap()
    }

    fn write(&mut self, offset: u32, value: u32) {
        self.access(offset, Some(value)).unwrap();
    }

    /// Time moves on `cycles`.
    fn wait(&mut self, cycles: u64) {
        self.now += cycles;
        let mut cx = self.shared.cx(self.now, &mut self.mem);
        self.eth.advance(&mut cx).unwrap();
    }

    fn word(&mut self, addr: u32) -> u32 {
        let mut b = [0; 4];
        self.mem.read(addr, &mut b).unwrap();
        u32::from_le_bytes(b)
    }

    fn set_word(&mut self, addr: u32, value: u32) {
        self.mem.write(addr, &value.to_le_bytes()).unwrap();
    }

    /// A clause 22 read of PHY register `reg` at address 0, to its end.
    fn mdio_read(&mut self, reg: u32) -> u16 {
        self.write(MACMDIOAR, (4 << 8) | (reg << 16) | (3 << 2) | GB);
        self.wait(MDIO_BUSY);
        assert_eq!(self.read(MACMDIOAR) & GB, 0);
        self.read(MACMDIODR) as u16
    }

    /// The driver's start, once the link is up: software reset; MAC
    /// address 02:00:00:00:00:02; four owned receive descriptors and the
    /// receive tail `rx_tail`; the transmit ring empty; MAC and both DMA
    /// channels on, with NIE, AIE, TIE, RIE and RBUE.
    fn start(&mut self, rx_tail: u32) {
        self.now = SETTLED;
        self.mdio_read(1);
        self.write(DMAMR, SWR);
        self.wait(2 * US);
        assert_eq!(self.read(DMAMR) & SWR, 0);
        self.write(MACA0LR, 0x0000_0002);
        self.write(MACA0HR, 0x0000_0200);
        for i in 0..4 {
            let d = RX_RING + 16 * i;
            self.set_word(d, RX_BUF + RX_SIZE * i);
            self.set_word(d + 12, OWN | RDES3_IOC | BUF1V);
        }
        self.write(DMACTDLAR, TX_RING);
        self.write(DMACTDRLR, 3);
        self.write(DMACRDLAR, RX_RING);
        self.write(DMACRDRLR, 3);
        self.write(DMACRDTPR, rx_tail);
        self.write(DMACRCR, RX_SIZE << 1);
        self.write(DMACIER, NIS | AIS | TI | RI | RBU);
        self.write(MACCR, TE | RE | DM | FES);
        self.write(DMACTCR, ST);
        self.write(DMACRCR, (RX_SIZE << 1) | SR);
        self.shared.raised.clear();
    }
}

/// An ARP request from 02:00:00:00:00:01, broadcast: 42 bytes.
fn arp_request() -> Vec<u8> {
    let mut frame = vec![0xFF; 6];
    frame.extend([0x02, 0, 0, 0, 0, 0x01, 0x08, 0x06]);
    frame.extend((0..28).map(|i| i as u8));
    frame
}

#[test]
fn the_fcs_is_ieee_802_3_crc_32() {
    assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
}

#[test]
fn a_frame_lands_in_an_owned_descriptor_before_the_tail() {
    let mut rig = Rig::new();
    assert!(!rig.shared.link.listening);
    rig.start(RX_RING + 3 * 16);
    // MACCR.RE on: the wire says the MAC listens (the engine paces from
    // here, `machine/pace.rs`).
    assert!(rig.shared.link.listening);
    let frame = arp_request();
    rig.shared.link.to_device.push_back(frame.clone());
    rig.wait(US);
    // Written back: OWN, CTXT and ES clear; FD, LD; LT 1 (type packet);
    // PL 64: padded to 60 bytes, and the FCS (CST clear).
    assert_eq!(rig.word(RX_RING + 12), FD | LD | (1 << 16) | 64);
    assert_eq!([0, 4, 8].map(|w| rig.word(RX_RING + w)), [0; 3]);
    let mut got = vec![0; 64];
    rig.mem.read(RX_BUF, &mut got).unwrap();
    assert_eq!(got[..42], frame[..]);
    assert!(got[42..60].iter().all(|&b| b == 0));
    assert_eq!(got[60..], crc32(&got[..60]).to_le_bytes());
    assert_eq!(rig.read(DMACSR) & (RI | NIS | RBU), RI | NIS);
    assert!(rig.shared.raised.contains(&61));
    assert_eq!(rig.read(DMACCARDR), RX_RING + 16);
    assert_eq!(rig.word(RX_RING + 16 + 12), OWN | RDES3_IOC | BUF1V);
    // Cleared, the line drops.
    rig.write(DMACSR, RI | NIS);
    rig.shared.raised.clear();
    rig.wait(US);
    assert!(rig.shared.raised.is_empty());
}

#[test]
fn with_no_descriptor_before_the_tail_a_frame_is_dropped_and_counted() {
    let mut rig = Rig::new();
    // The tail at the current descriptor: none for the DMA.
    rig.start(RX_RING);
    rig.shared.link.to_device.push_back(arp_request());
    rig.wait(US);
    assert_eq!(rig.word(RX_RING + 12), OWN | RDES3_IOC | BUF1V);
    assert_eq!(rig.read(DMACSR) & (RBU | AIS | RI), RBU | AIS);
    assert!(rig.shared.raised.contains(&61));
    assert_eq!(rig.read(DMACMFCR), 1);
    // Clear on read.
    assert_eq!(rig.read(DMACMFCR), 0);
    assert_eq!(rig.read(MTLRXQMPOCR), 1 << 16);
    assert_eq!(rig.eth.missed(), 1);
    assert_eq!((rig.read(DMADSR) >> 8) & 0xF, RX_SUSPENDED);
}

#[test]
fn a_packet_over_two_descriptors_leaves_as_one_frame_on_a_tail_write() {
    let mut rig = Rig::new();
    rig.start(RX_RING + 3 * 16);
    let frame: Vec<u8> = (0..64).collect();
    rig.mem.write(TX_BUF, &frame[..30]).unwrap();
    rig.mem.write(TX_BUF + 0x100, &frame[30..]).unwrap();
    rig.set_word(TX_RING, TX_BUF);
    rig.set_word(TX_RING + 8, 30);
    rig.set_word(TX_RING + 12, OWN | FD | 64);
    rig.set_word(TX_RING + 16, TX_BUF + 0x100);
    rig.set_word(TX_RING + 16 + 8, TDES2_IOC | 34);
    rig.set_word(TX_RING + 16 + 12, OWN | LD | 64);
    assert!(rig.shared.link.from_device.is_empty());
    rig.write(DMACTDTPR, TX_RING + 2 * 16);
    assert_eq!(rig.shared.link.from_device, [frame]);
    assert_eq!(rig.word(TX_RING + 12), FD);
    assert_eq!(rig.word(TX_RING + 16 + 12), LD);
    assert_eq!(rig.read(DMACSR) & (TI | TBU | NIS), TI | TBU | NIS);
    assert_eq!(rig.read(DMACCATDR), TX_RING + 2 * 16);
    assert!(rig.shared.raised.contains(&61));
}

#[test]
fn an_mdio_read_returns_the_phy_id_after_64_mdc_clocks() {
    let mut rig = Rig::new();
    rig.now = SETTLED;
    rig.write(MACMDIOAR, (4 << 8) | (2 << 16) | (3 << 2) | GB);
    assert_eq!(rig.eth.next_event(rig.now), Some(SETTLED + MDIO_BUSY));
    rig.wait(MDIO_BUSY - 1);
    assert_eq!(rig.read(MACMDIOAR) & GB, GB);
    rig.wait(1);
    assert_eq!(rig.read(MACMDIOAR) & GB, 0);
    // LAN8742A PHY identifier 1.
    assert_eq!(rig.read(MACMDIODR) & 0xFFFF, 0x0007);
}

#[test]
fn a_clock_range_too_fast_for_hclk_is_refused_naming_mdc() {
    let mut rig = Rig::new();
    // CR = 0 (HCLK 60-100 MHz, /42) with HCLK at 200 MHz: MDC 4.762 MHz.
    let e = rig
        .access(MACMDIOAR, Some((2 << 16) | (3 << 2) | GB))
        .unwrap_err();
    assert!(e.contains("MDC") && e.contains("4.762 MHz"), "{e}");
    assert_eq!(rig.read(MACMDIOAR) & GB, 0);
}

#[test]
fn without_the_reference_clock_the_software_reset_never_ends() {
    let mut rig = Rig::new();
    rig.shared.link.ref_clock = false;
    rig.write(DMAMR, SWR);
    rig.wait(CORE_HZ);
    assert_eq!(rig.read(DMAMR) & SWR, SWR);
    assert_eq!(rig.eth.next_event(rig.now), None);
    let e = rig.access(DMACTCR, Some(ST)).unwrap_err();
    assert!(e.contains("SWR") && e.contains("REF_CLK"), "{e}");
    // The clock back, the reset ends.
    rig.shared.link.ref_clock = true;
    rig.wait(1);
    assert_eq!(rig.read(DMAMR) & SWR, 0);
}

#[test]
fn an_rmii_pin_on_the_wrong_alternate_function_refuses_the_mac_enable() {
    let mut rig = Rig::new();
    rig.shared.wiring.pins[6][13] = (2, 0);
    let e = rig.access(MACCR, Some(TE | RE)).unwrap_err();
    assert!(e.contains("PG13 (RMII_TXD0)"), "{e}");
    assert_eq!(rig.read(MACCR) & (TE | RE), 0);
}

#[test]
fn a_pin_moved_off_af11_after_the_start_refuses_the_next_frame() {
    let mut rig = Rig::new();
    rig.start(RX_RING + 3 * 16);
    rig.mem.write(TX_BUF, &[0xA5; 64]).unwrap();
    rig.set_word(TX_RING, TX_BUF);
    rig.set_word(TX_RING + 8, 64);
    rig.set_word(TX_RING + 12, OWN | FD | LD | 64);
    rig.shared.wiring.pins[6][13] = (2, 10);
    let e = rig.access(DMACTDTPR, Some(TX_RING + 16)).unwrap_err();
    assert!(
        e.contains("a frame on the wire") && e.contains("PG13 (RMII_TXD0) is in mode 2 with AF10"),
        "{e}"
    );
    assert!(rig.shared.link.from_device.is_empty());
}

/// DMAMR.SWR puts every register back to reset, MACCR.RE with them: the
/// wire no longer says the MAC listens (the engine's pacing).
#[test]
fn a_software_reset_turns_the_receiver_off() {
    let mut rig = Rig::new();
    rig.start(RX_RING + 3 * 16);
    assert!(rig.shared.link.listening);
    rig.write(DMAMR, SWR);
    assert!(!rig.shared.link.listening);
}
