//! SMSC LAN9118 Ethernet controller (as QEMU emulates it on `mps2-an500`),
//! behind the `embassy-net-driver` contract: `receive`/`transmit` never
//! block; when nothing is there they register the waker and return `None`,
//! and the interrupt ([`on_interrupt`]) wakes it.
//!
//! The chip is programmed through 32-bit registers only (PIO, no DMA):
//! frames come out of the RX data FIFO word by word after their status word
//! (the length there includes the 4-byte CRC, which we drop), and go into
//! the TX data FIFO after two command words. The register access is a
//! trait ([`Registers`]) so the host tests drive the same code against a
//! fake register file.
//!
//! QEMU specifics the driver relies on or works around (from QEMU's
//! `hw/net/lan9118.c`, 7.2 and 10.x):
//! - the interrupt line is active-low until `IRQ_CFG` selects push-pull,
//!   active-high, so that is written before the NVIC line is enabled;
//! - `RX_DP_CTRL`'s fast-forward corrupts the FIFO accounting: a frame we
//!   cannot take is discarded by reading its words;
//! - TX end alignment is ignored: exactly `ceil(len / 4)` data words follow
//!   the command words;
//! - popping an empty status FIFO returns a stale entry: the used counts in
//!   `RX_FIFO_INF` / `TX_FIFO_INF` are checked first;
//! - a frame that does not fit the RX FIFOs (2,640 data words, 176 status
//!   entries) is dropped silently: `RX_DROP` always reads 0 and no status
//!   bit is set ("TODO" in QEMU's model). On a real chip `RX_DROP` counts
//!   them (cleared on read: Linux's smsc911x adds each read to its
//!   `rx_dropped`) and `INT_STS` flags a full status FIFO; [`nic_counters`]
//!   reads both, and the FIFO's fill when the driver takes a frame, for
//!   the firmware's counter line.

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use core::task::Context;
use embassy_net_driver::{Capabilities, HardwareAddress, LinkState};
use embassy_sync::waitqueue::AtomicWaker;

/// Register offsets (bytes from the chip's base address).
pub mod reg {
    pub const RX_DATA_FIFO: usize = 0x00;
    pub const TX_DATA_FIFO: usize = 0x20;
    pub const RX_STATUS_FIFO: usize = 0x40;
    pub const TX_STATUS_FIFO: usize = 0x48;
    pub const ID_REV: usize = 0x50;
    pub const IRQ_CFG: usize = 0x54;
    pub const INT_STS: usize = 0x58;
    pub const INT_EN: usize = 0x5c;
    pub const BYTE_TEST: usize = 0x64;
    pub const FIFO_INT: usize = 0x68;
    pub const TX_CFG: usize = 0x70;
    pub const HW_CFG: usize = 0x74;
    pub const RX_FIFO_INF: usize = 0x7c;
    pub const TX_FIFO_INF: usize = 0x80;
    pub const PMT_CTRL: usize = 0x84;
    pub const RX_DROP: usize = 0xa0;
    pub const MAC_CSR_CMD: usize = 0xa4;
    pub const MAC_CSR_DATA: usize = 0xa8;
}

/// MAC control and status registers, reached through `MAC_CSR_CMD/DATA`.
pub mod mac_csr {
    pub const MAC_CR: u32 = 1;
    pub const ADDRH: u32 = 2;
    pub const ADDRL: u32 = 3;
    pub const MII_ACC: u32 = 6;
    pub const MII_DATA: u32 = 7;
}

/// `BYTE_TEST` always reads this on a working bus.
pub const BYTE_TEST_VALUE: u32 = 0x8765_4321;
const HW_CFG_SRST: u32 = 1;
const PMT_CTRL_READY: u32 = 1;
/// `IRQ_CFG`: IRQ_EN | IRQ_POL (active high) | IRQ_TYPE (push-pull).
const IRQ_CFG_ENABLED: u32 = (1 << 8) | (1 << 4) | 1;
/// `INT_STS`/`INT_EN`: RX status FIFO level reached.
pub const INT_RSFL: u32 = 1 << 3;
/// `INT_STS`: RX status FIFO full (frames are being dropped).
pub const INT_RSFF: u32 = 1 << 4;
/// `INT_STS`: a received frame was dropped (`RX_DROP` counted it).
pub const INT_RXDF: u32 = 1 << 6;
const MAC_CR_RXEN: u32 = 1 << 2;
const MAC_CR_TXEN: u32 = 1 << 3;
const MAC_CR_FDPX: u32 = 1 << 20;
const TX_CFG_TX_ON: u32 = 1 << 1;
const CSR_BUSY: u32 = 1 << 31;
const CSR_READ: u32 = 1 << 30;
const MII_BUSY: u32 = 1;
const PHY_BMSR: u32 = 1;
const BMSR_LINK: u32 = 1 << 2;
/// TX command A: first and last segment of a one-buffer frame.
const TX_CMD_A_FIRST_LAST: u32 = (1 << 13) | (1 << 12);

/// Largest Ethernet frame we send or take (no VLAN tag, no CRC).
pub const MTU: usize = 1514;
/// Frame plus CRC, rounded up to whole FIFO words.
const RX_BUF: usize = (MTU + 4).div_ceil(4) * 4;
/// How long a MAC CSR or MII access may stay busy before we give up (a
/// real chip needs a few; QEMU completes at once).
const BUSY_POLLS: u32 = 10_000;

/// 32-bit register access to the chip.
pub trait Registers {
    fn read(&self, offset: usize) -> u32;
    fn write(&self, offset: usize, value: u32);
}

/// Why the chip could not be brought up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum InitError {
    /// `BYTE_TEST` read something else: no chip, or a bus problem.
    NoChip(u32),
    /// `PMT_CTRL.READY` never came up after the soft reset.
    NotReady,
    /// A MAC CSR access stayed busy.
    CsrTimeout,
}

/// Counters of what the driver saw, for the board's statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    pub rx_frames: u32,
    pub tx_frames: u32,
    /// Frames with the error bit, or too short or too long to be Ethernet,
    /// discarded.
    pub rx_discarded: u32,
    /// The most bytes the RX data FIFO held when a frame was taken.
    pub rx_fifo_max: u32,
}

/// Woken by the chip's interrupt: the network stack polls `receive` again.
static RX_WAKER: AtomicWaker = AtomicWaker::new();

/// The chip's receive counters, readable from any task while the driver
/// lives inside the network stack (one chip per board).
static RX_FRAMES: AtomicU32 = AtomicU32::new(0);
static RX_DROPPED: AtomicU32 = AtomicU32::new(0);
static RX_STATUS_FULL: AtomicU32 = AtomicU32::new(0);
static RX_FIFO_MAX: AtomicU32 = AtomicU32::new(0);
/// The link as `link_state` last read it.
static LINK_UP: AtomicBool = AtomicBool::new(false);

/// Adds the chip's dropped-frame count since the last read (reading
/// clears it).
fn take_rx_drop<R: Registers>(regs: &R) {
    let dropped = regs.read(reg::RX_DROP);
    if dropped != 0 {
        RX_DROPPED.fetch_add(dropped, Ordering::Relaxed);
    }
}

/// The board calls this from the chip's interrupt handler: acknowledge
/// everything pending (the NVIC input is level-triggered), note a full
/// status FIFO or dropped frames, and wake the network stack.
pub fn on_interrupt<R: Registers>(regs: &R) {
    let pending = regs.read(reg::INT_STS);
    regs.write(reg::INT_STS, pending);
    if pending & INT_RSFF != 0 {
        RX_STATUS_FULL.fetch_add(1, Ordering::Relaxed);
    }
    if pending & INT_RXDF != 0 {
        take_rx_drop(regs);
    }
    RX_WAKER.wake();
}

/// What the chip and the driver counted on the receive side so far
/// (reads `RX_DROP`, which has no effect on the FIFOs: safe beside the
/// driver).
pub fn nic_counters<R: Registers>(regs: &R) -> crate::NicCounters {
    take_rx_drop(regs);
    crate::NicCounters {
        rx_frames: RX_FRAMES.load(Ordering::Relaxed),
        rx_dropped: RX_DROPPED.load(Ordering::Relaxed),
        // RX_DROP is 32 bits and read on every receive interrupt: it
        // cannot pass its end between two reads.
        rx_dropped_at_least: false,
        status_full: RX_STATUS_FULL.load(Ordering::Relaxed),
        fifo_max: RX_FIFO_MAX.load(Ordering::Relaxed),
        fifo: true,
    }
}

/// The link as the driver last read it from the PHY (for the
/// diagnostics; the stack asks the driver itself).
pub fn link() -> crate::LinkInfo {
    crate::LinkInfo {
        up: LINK_UP.load(Ordering::Relaxed),
        speed_mbps: None,
        full_duplex: None,
    }
}

/// The driver.
pub struct Lan9118<R: Registers> {
    regs: R,
    mac: [u8; 6],
    rx: [u8; RX_BUF],
    tx: [u8; MTU],
    counters: Counters,
    /// The PHY's link bit as last read, and how many polls ago.
    link_up: bool,
    link_age: u32,
}

/// `link_state` is polled by the network stack on every wake-up; the PHY
/// is read over MII (a dozen register accesses) only every this many polls.
const LINK_POLL_EVERY: u32 = 1024;

impl<R: Registers> Lan9118<R> {
    /// Resets the chip, sets `mac` as its address, enables RX/TX and the
    /// RX interrupt. The caller enables the interrupt line afterwards.
    pub fn new(regs: R, mac: [u8; 6]) -> Result<Self, InitError> {
        let test = regs.read(reg::BYTE_TEST);
        if test != BYTE_TEST_VALUE {
            return Err(InitError::NoChip(test));
        }
        regs.write(reg::HW_CFG, HW_CFG_SRST);
        let mut ready = false;
        for _ in 0..BUSY_POLLS {
            if regs.read(reg::HW_CFG) & HW_CFG_SRST == 0
                && regs.read(reg::PMT_CTRL) & PMT_CTRL_READY != 0
            {
                ready = true;
                break;
            }
        }
        if !ready {
            return Err(InitError::NotReady);
        }
        let nic = Lan9118 {
            regs,
            mac,
            rx: [0; RX_BUF],
            tx: [0; MTU],
            counters: Counters::default(),
            link_up: false,
            link_age: LINK_POLL_EVERY,
        };
        nic.regs.write(reg::INT_EN, 0);
        nic.regs.write(reg::INT_STS, u32::MAX);
        nic.regs.write(reg::IRQ_CFG, IRQ_CFG_ENABLED);
        // Interrupt as soon as one RX status is waiting.
        nic.regs.write(reg::FIFO_INT, 0);
        let [m0, m1, m2, m3, m4, m5] = mac;
        nic.csr_write(mac_csr::ADDRL, u32::from_le_bytes([m0, m1, m2, m3]))?;
        nic.csr_write(mac_csr::ADDRH, u32::from_le_bytes([m4, m5, 0, 0]))?;
        // Exact address match plus broadcast (ARP), full duplex.
        nic.csr_write(mac_csr::MAC_CR, MAC_CR_RXEN | MAC_CR_TXEN | MAC_CR_FDPX)?;
        nic.regs.write(reg::TX_CFG, TX_CFG_TX_ON);
        nic.regs.write(reg::INT_EN, INT_RSFL);
        Ok(nic)
    }

    /// The chip's registers, e.g. for the interrupt handler's acknowledge.
    pub fn registers(&self) -> &R {
        &self.regs
    }

    pub fn counters(&self) -> Counters {
        self.counters
    }

    fn csr_wait(&self) -> Result<(), InitError> {
        for _ in 0..BUSY_POLLS {
            if self.regs.read(reg::MAC_CSR_CMD) & CSR_BUSY == 0 {
                return Ok(());
            }
        }
        Err(InitError::CsrTimeout)
    }

    fn csr_write(&self, index: u32, value: u32) -> Result<(), InitError> {
        self.csr_wait()?;
        self.regs.write(reg::MAC_CSR_DATA, value);
        self.regs.write(reg::MAC_CSR_CMD, CSR_BUSY | index);
        self.csr_wait()
    }

    fn csr_read(&self, index: u32) -> Result<u32, InitError> {
        self.csr_wait()?;
        self.regs
            .write(reg::MAC_CSR_CMD, CSR_BUSY | CSR_READ | index);
        self.csr_wait()?;
        Ok(self.regs.read(reg::MAC_CSR_DATA))
    }

    /// Reads PHY register `index` of the internal PHY (address 1) over MII.
    pub fn phy_read(&self, index: u32) -> Result<u16, InitError> {
        let acc = (1 << 11) | ((index & 0x1f) << 6) | MII_BUSY;
        self.csr_write(mac_csr::MII_ACC, acc)?;
        for _ in 0..BUSY_POLLS {
            if self.csr_read(mac_csr::MII_ACC)? & MII_BUSY == 0 {
                let data = self.csr_read(mac_csr::MII_DATA)?;
                return Ok((data & 0xffff) as u16);
            }
        }
        Err(InitError::CsrTimeout)
    }

    /// Frames waiting in the RX status FIFO; notes how full the data FIFO
    /// is (the same register read).
    fn rx_frames_waiting(&mut self) -> u32 {
        let inf = self.regs.read(reg::RX_FIFO_INF);
        let used = inf & 0xffff;
        if used > self.counters.rx_fifo_max {
            self.counters.rx_fifo_max = used;
            RX_FIFO_MAX.fetch_max(used, Ordering::Relaxed);
        }
        (inf >> 16) & 0xff
    }

    /// Takes the next frame out of the RX FIFOs into `self.rx`; its length
    /// without the CRC, or `None` when none is waiting. Frames that cannot
    /// be Ethernet are read out and counted.
    fn pop_frame(&mut self) -> Option<usize> {
        while self.rx_frames_waiting() > 0 {
            let status = self.regs.read(reg::RX_STATUS_FIFO);
            let len = ((status >> 16) & 0x3fff) as usize;
            let error = status & (1 << 15) != 0;
            let words = len.div_ceil(4);
            if error || !(14 + 4..=RX_BUF).contains(&len) {
                for _ in 0..words {
                    self.regs.read(reg::RX_DATA_FIFO);
                }
                self.counters.rx_discarded = self.counters.rx_discarded.wrapping_add(1);
                continue;
            }
            for chunk in self.rx.chunks_exact_mut(4).take(words) {
                chunk.copy_from_slice(&self.regs.read(reg::RX_DATA_FIFO).to_le_bytes());
            }
            self.counters.rx_frames = self.counters.rx_frames.wrapping_add(1);
            RX_FRAMES.fetch_add(1, Ordering::Relaxed);
            return Some(len - 4);
        }
        None
    }

    /// Drops TX status words (QEMU keeps at most 512 and then loses them).
    fn drain_tx_status(&self) {
        let mut used = (self.regs.read(reg::TX_FIFO_INF) >> 16) & 0xff;
        while used > 0 {
            self.regs.read(reg::TX_STATUS_FIFO);
            used -= 1;
        }
    }

    fn tx_free(&self) -> usize {
        (self.regs.read(reg::TX_FIFO_INF) & 0xffff) as usize
    }
}

/// A received frame, borrowed from the driver's RX buffer.
pub struct RxToken<'a> {
    frame: &'a mut [u8],
}

/// A frame to send, written into the driver's TX buffer and then pushed
/// into the chip's TX FIFO.
pub struct TxToken<'a, R: Registers> {
    regs: &'a R,
    buf: &'a mut [u8; MTU],
    sent: &'a mut u32,
}

impl embassy_net_driver::RxToken for RxToken<'_> {
    fn consume<T, F: FnOnce(&mut [u8]) -> T>(self, f: F) -> T {
        f(self.frame)
    }
}

impl<R: Registers> embassy_net_driver::TxToken for TxToken<'_, R> {
    fn consume<T, F: FnOnce(&mut [u8]) -> T>(self, len: usize, f: F) -> T {
        let len = len.min(MTU);
        let (frame, _) = self.buf.split_at_mut(len);
        let result = f(frame);
        // One buffer per frame: no data offset, 4-byte end alignment.
        self.regs
            .write(reg::TX_DATA_FIFO, TX_CMD_A_FIRST_LAST | len as u32);
        self.regs.write(reg::TX_DATA_FIFO, len as u32);
        for chunk in frame.chunks(4) {
            let mut word = [0u8; 4];
            for (w, b) in word.iter_mut().zip(chunk) {
                *w = *b;
            }
            self.regs.write(reg::TX_DATA_FIFO, u32::from_le_bytes(word));
        }
        *self.sent = self.sent.wrapping_add(1);
        result
    }
}

impl<R: Registers> embassy_net_driver::Driver for Lan9118<R> {
    type RxToken<'a>
        = RxToken<'a>
    where
        Self: 'a;
    type TxToken<'a>
        = TxToken<'a, R>
    where
        Self: 'a;

    fn receive(&mut self, cx: &mut Context) -> Option<(Self::RxToken<'_>, Self::TxToken<'_>)> {
        // Register first: a frame that arrives after the check still wakes.
        RX_WAKER.register(cx.waker());
        let len = self.pop_frame()?;
        self.drain_tx_status();
        let Lan9118 {
            regs,
            rx,
            tx,
            counters,
            ..
        } = self;
        let (frame, _) = rx.split_at_mut(len);
        Some((
            RxToken { frame },
            TxToken {
                regs,
                buf: tx,
                sent: &mut counters.tx_frames,
            },
        ))
    }

    fn transmit(&mut self, cx: &mut Context) -> Option<Self::TxToken<'_>> {
        self.drain_tx_status();
        if self.tx_free() < MTU + 8 {
            // Only a real chip ever fills up; its TX interrupt is not used,
            // so look again on the next RX or timer poll.
            cx.waker().wake_by_ref();
            return None;
        }
        Some(TxToken {
            regs: &self.regs,
            buf: &mut self.tx,
            sent: &mut self.counters.tx_frames,
        })
    }

    fn link_state(&mut self, _cx: &mut Context) -> LinkState {
        self.link_age += 1;
        if self.link_age >= LINK_POLL_EVERY {
            self.link_age = 0;
            self.link_up = self
                .phy_read(PHY_BMSR)
                .is_ok_and(|bmsr| u32::from(bmsr) & BMSR_LINK != 0);
            LINK_UP.store(self.link_up, Ordering::Relaxed);
        }
        if self.link_up {
            LinkState::Up
        } else {
            LinkState::Down
        }
    }

    fn capabilities(&self) -> Capabilities {
        let mut caps = Capabilities::default();
        caps.max_transmission_unit = MTU;
        caps
    }

    fn hardware_address(&self) -> HardwareAddress {
        HardwareAddress::Ethernet(self.mac)
    }
}

#[cfg(test)]
mod tests;
