//! The Ethernet model's tests: a fake DMA memory, a NUCLEO's clocks and
//! wiring, and the MAC driven through its registers as a driver does.

use super::*;
use crate::bus::{Dma, Shared};
use crate::link::Link;
use crate::wiring::{AF_ETH, NUCLEO_RMII};

const RAM: u32 = 0x2002_0000;
/// 2 s at 216 MHz: the PHY has linked.
const T0: u64 = 432_000_000;
/// One MDIO frame at HCLK/102: 64 MDC clocks.
const MDIO: u64 = 64 * 102;

/// Memory the DMA reaches, at `RAM`.
struct Ram(Vec<u8>);

impl Ram {
    fn at(&mut self, addr: u32, len: usize) -> Result<&mut [u8], Refusal> {
        let o = addr.wrapping_sub(RAM) as usize;
        self.0
            .get_mut(o..o + len)
            .ok_or_else(|| format!("{addr:#x}: not in the test RAM"))
    }
    fn word(&mut self, addr: u32) -> u32 {
        u32::from_le_bytes(self.at(addr, 4).unwrap().try_into().unwrap())
    }
    fn put(&mut self, addr: u32, words: &[u32]) {
        let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        self.at(addr, bytes.len()).unwrap().copy_from_slice(&bytes);
    }
}

impl Dma for Ram {
    fn read(&mut self, addr: u32, buf: &mut [u8]) -> Result<(), Refusal> {
        buf.copy_from_slice(self.at(addr, buf.len())?);
        Ok(())
    }
    fn write(&mut self, addr: u32, data: &[u8]) -> Result<(), Refusal> {
        self.at(addr, data.len())?.copy_from_slice(data);
        Ok(())
    }
}

/// The MAC at reset on a NUCLEO: 216 MHz, every RMII pin on AF11.
struct Bench(Ram, Shared, Eth);

impl Bench {
    fn new(ref_clock: bool) -> Bench {
        let mut s = Shared {
            link: Link {
                ref_clock,
                ..Link::nucleo()
            },
            ..Shared::default()
        };
        (s.clocks.core_hz, s.clocks.hclk_hz, s.wiring.rmii) = (216_000_000, 216_000_000, true);
        for (pin, _) in NUCLEO_RMII {
            let port = usize::from(pin.as_bytes()[1] - b'A');
            s.wiring.pins[port][pin[2..].parse::<usize>().unwrap()] = (2, AF_ETH);
        }
        Bench(Ram(vec![0; 0x2000]), s, Eth::new(61))
    }

    /// Reset as a driver does it, MAC address 00:11:22:33:44:55, two
    /// chained receive descriptors (the DMA's if `rx`) at RAM, the
    /// transmit list at RAM + 0x100, interrupts on, MAC and DMA started.
    fn started(rx: bool) -> Bench {
        let mut b = Bench::new(true);
        b.wr(T0, DMABMR, 0x0002_0101).unwrap();
        let own = if rx { OWN } else { 0 };
        let (buf0, buf1) = (RAM + 0x400, RAM + 0xA00);
        b.0.put(
            RAM,
            &[
                own,
                RCH | 1536,
                buf0,
                RAM + 0x10,
                own,
                RER | RCH | 1536,
                buf1,
                0,
            ],
        );
        for (off, v) in [
            (MACA0HR, 0x5544),
            (MACA0LR, 0x3322_1100),
            (DMARDLAR, RAM),
            (DMATDLAR, RAM + 0x100),
            (DMAIER, NIS | AIS | RBUS | RS | TS),
            (MACCR, 0xC80C),
            (DMAOMR, OMR_ST | OMR_SR),
        ] {
            b.wr(T0 + 1000, off, v).unwrap();
        }
        b
    }

    fn wr(&mut self, at: u64, off: u32, v: u32) -> Result<(), Refusal> {
        let mut cx = self.1.cx(at, &mut self.0);
        self.2.advance(&mut cx)?;
        self.2.write(off, 4, v, &mut cx)
    }

    fn rd(&mut self, at: u64, off: u32) -> u32 {
        let mut cx = self.1.cx(at, &mut self.0);
        self.2.advance(&mut cx).unwrap();
        self.2.read(off, 4, &mut cx).unwrap()
    }
}

#[test]
fn a_frame_lands_in_an_owned_descriptor() {
    let mut b = Bench::started(true);
    // MACCR.RE on: the wire says the MAC listens (the engine paces from
    // here, `machine/pace.rs`).
    assert!(b.1.link.listening);
    let mut frame: Vec<u8> = [[0xFF; 6], [2, 0, 0, 0, 0, 1]].concat();
    frame.extend([0x08, 0x06]);
    frame.resize(60, 0xA5);
    // Another station's frame is filtered out; the broadcast is taken.
    let mut other = frame.clone();
    other[..6].copy_from_slice(&[0, 0x11, 0x22, 0x33, 0x44, 0x56]);
    b.1.link.to_device.extend([other, frame.clone()]);
    b.rd(T0 + 2000, DMASR);
    assert_eq!(b.0.word(RAM), OWN, "still on the wire");
    assert!(b.2.next_event(T0 + 2000).is_some_and(|t| t > T0 + 2000));
    let sr = b.rd(T0 + 216_000, DMASR);
    assert_eq!(b.0.word(RAM), R_FS | R_LS | FT | 64 << 16);
    let fcs = crc32(&frame).to_le_bytes();
    assert_eq!(
        b.0.at(RAM + 0x400, 64).unwrap(),
        [&frame[..], &fcs[..]].concat()
    );
    assert_eq!(sr & (RS | NIS), RS | NIS);
    assert!(b.1.raised.contains(&61));
    assert_eq!(b.0.word(RAM + 0x10), OWN, "the next descriptor untouched");
}

#[test]
fn with_no_descriptor_a_frame_is_dropped_and_counted() {
    let mut b = Bench::started(false);
    b.1.link.to_device.push_back(vec![0xFF; 60]);
    b.rd(T0 + 2000, DMASR);
    let sr = b.rd(T0 + 216_000, DMASR);
    assert_eq!((b.2.missed(), b.rd(T0 + 216_000, DMAMFBOCR)), (1, 1));
    assert_eq!(b.rd(T0 + 216_000, DMAMFBOCR), 0, "cleared by the read");
    assert_eq!(sr & (RBUS | AIS), RBUS | AIS);
    assert_eq!((sr >> RPS) & 7, RPS_SUSPENDED);
    assert_eq!(b.0.word(RAM), 0, "nothing written");
}

#[test]
fn a_transmit_chain_from_fs_to_ls_is_one_frame() {
    let mut b = Bench::started(true);
    let (d0, d1) = (RAM + 0x100, RAM + 0x110);
    let (d0w, d1w) = (OWN | IC | T_FS | TCH, OWN | IC | T_LS | TCH | TER);
    b.0.put(d0, &[d0w, 20, RAM + 0x1000, d1, d1w, 50, RAM + 0x1100, 0]);
    let bytes: Vec<u8> = (0..70).collect();
    b.0.at(RAM + 0x1000, 20)
        .unwrap()
        .copy_from_slice(&bytes[..20]);
    b.0.at(RAM + 0x1100, 50)
        .unwrap()
        .copy_from_slice(&bytes[20..]);
    b.wr(T0 + 2000, DMATPDR, 1).unwrap();
    assert_eq!(b.1.link.from_device.drain(..).collect::<Vec<_>>(), [bytes]);
    assert_eq!((b.0.word(d0), b.0.word(d1)), (d0w & !OWN, d1w & !OWN));
    assert_ne!(b.rd(T0 + 2000, DMASR) & TS, 0);
    assert!(b.1.raised.contains(&61));
}

#[test]
fn an_mdio_read_takes_64_mdc_clocks() {
    let mut b = Bench::started(true);
    let t = T0 + 2000;
    b.wr(t, MACMIIAR, 2 << 6 | 0b100 << 2 | MB).unwrap();
    assert_eq!(b.2.next_event(t), Some(t + MDIO));
    assert_eq!(b.rd(t + MDIO - 1, MACMIIAR) & MB, MB, "busy");
    assert_eq!(b.rd(t + MDIO, MACMIIAR) & MB, 0);
    assert_eq!(b.rd(t + MDIO, MACMIIDR), 0x0007, "PHYID1");
    b.wr(t + MDIO, MACMIIAR, 1 << 11 | 2 << 6 | 0b100 << 2 | MB)
        .unwrap();
    assert_eq!(b.rd(t + 2 * MDIO, MACMIIDR), 0xFFFF, "nobody at address 1");
}

#[test]
fn an_mdc_too_fast_for_hclk_is_refused() {
    let mut b = Bench::started(true);
    // CR 010 is HCLK/16, for 20-35 MHz: 13.5 MHz at 216 MHz.
    let e = b.wr(T0 + 2000, MACMIIAR, 0b010 << 2 | MB).unwrap_err();
    assert!(e.contains("MDC would be 13.500 MHz"), "{e}");
    assert_eq!(b.rd(T0 + 2000, MACMIIAR) & MB, 0, "no frame started");
}

#[test]
fn without_ref_clk_the_software_reset_never_ends() {
    let mut b = Bench::new(false);
    b.wr(T0, DMABMR, 0x0002_0101).unwrap();
    assert_eq!(b.rd(10 * T0, DMABMR) & BMR_SR, BMR_SR);
    assert_eq!(b.2.next_event(10 * T0), None);
    let e = b.wr(10 * T0, DMAOMR, OMR_ST | OMR_SR).unwrap_err();
    assert!(e.contains("DMABMR.SR") && e.contains("REF_CLK"), "{e}");
}

#[test]
fn the_mac_needs_its_pins_and_mdio_its_own() {
    let mut b = Bench::new(true);
    b.1.wiring.pins[6][13] = (2, 0);
    let e = b.wr(T0, MACCR, 0x8008).unwrap_err();
    assert!(e.contains("PG13 (RMII_TXD0)"), "{e}");
    (b.1.wiring.pins[6][13], b.1.wiring.pins[0][2]) = ((2, AF_ETH), (3, 0));
    b.wr(T0, MACCR, 0x8008).unwrap();
    let e = b.wr(T0, MACMIIAR, 0b100 << 2 | MB).unwrap_err();
    assert!(e.contains("PA2 (RMII_MDIO)"), "{e}");
}

#[test]
fn a_pin_moved_off_af11_after_the_start_refuses_the_next_frame() {
    let mut b = Bench::started(true);
    let d0 = RAM + 0x100;
    b.0.put(d0, &[OWN | T_FS | T_LS | TCH | TER, 60, RAM + 0x1000, d0]);
    b.1.wiring.pins[6][13] = (2, 10);
    let e = b.wr(T0 + 2000, DMATPDR, 1).unwrap_err();
    assert!(
        e.contains("a frame on the wire") && e.contains("PG13 (RMII_TXD0) is in mode 2 with AF10"),
        "{e}"
    );
    assert!(b.1.link.from_device.is_empty());
}

/// DMABMR.SR puts every register back to reset, MACCR.RE with them: the
/// wire no longer says the MAC listens (the engine's pacing).
#[test]
fn a_software_reset_turns_the_receiver_off() {
    let mut b = Bench::started(true);
    assert!(b.1.link.listening);
    b.wr(T0 + 3000, DMABMR, BMR_SR).unwrap();
    assert!(!b.1.link.listening);
}
