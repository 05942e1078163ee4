//! The driver against a fake LAN9118 register file that behaves as QEMU's
//! model does: FIFOs of whole words, the CRC at the end of RX frames, MAC
//! CSRs behind the command/data pair, W1C interrupt status.

use super::*;
use embassy_net_driver::{Driver, RxToken as _, TxToken as _};
use std::cell::RefCell;
use std::collections::VecDeque;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::task::{Wake, Waker};

/// The driver's receive waker is one static ([`RX_WAKER`]), as on the
/// board: tests that register a waker or raise the interrupt take turns,
/// or one test's interrupt wakes another's waker.
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn one_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner())
}

#[derive(Default)]
struct Chip {
    byte_test: u32,
    rx_status: VecDeque<u32>,
    rx_data: VecDeque<u32>,
    tx_words: Vec<u32>,
    tx_frames: Vec<Vec<u8>>,
    tx_status: u32,
    csr: [u32; 16],
    csr_data: u32,
    int_sts: u32,
    int_en: u32,
    /// Frames the chip dropped since `RX_DROP` was last read.
    rx_drop: u32,
    irq_cfg: u32,
    resets: u32,
    /// Every register write, in order.
    writes: Vec<(usize, u32)>,
}

struct Fake(RefCell<Chip>);

impl Fake {
    fn new() -> Self {
        Fake(RefCell::new(Chip {
            byte_test: BYTE_TEST_VALUE,
            ..Chip::default()
        }))
    }

    /// A frame arrives: status word (length with CRC), then the words.
    fn arrive(&self, frame: &[u8], error: bool) {
        let mut c = self.0.borrow_mut();
        let mut bytes = frame.to_vec();
        bytes.extend_from_slice(&[0xde, 0xad, 0xbe, 0xef]); // the CRC
        let status = ((bytes.len() as u32) << 16) | if error { 1 << 15 } else { 0 };
        c.rx_status.push_back(status);
        for chunk in bytes.chunks(4) {
            let mut w = [0u8; 4];
            w[..chunk.len()].copy_from_slice(chunk);
            c.rx_data.push_back(u32::from_le_bytes(w));
        }
        c.int_sts |= INT_RSFL;
    }

    /// Cuts the TX FIFO words into frames as the chip does.
    fn parse_tx(c: &mut Chip) {
        while c.tx_words.len() >= 2 {
            let a = c.tx_words[0];
            let len = (a & 0x7ff) as usize;
            let words = len.div_ceil(4);
            if c.tx_words.len() < 2 + words {
                return;
            }
            assert_eq!(
                a & TX_CMD_A_FIRST_LAST,
                TX_CMD_A_FIRST_LAST,
                "one buffer per frame"
            );
            assert_eq!(
                c.tx_words[1] & 0x7ff,
                len as u32,
                "command B carries the length"
            );
            let mut frame: Vec<u8> = c.tx_words[2..2 + words]
                .iter()
                .flat_map(|w| w.to_le_bytes())
                .collect();
            frame.truncate(len);
            c.tx_frames.push(frame);
            c.tx_words.drain(..2 + words);
            c.tx_status += 1;
        }
    }
}

impl Registers for Fake {
    fn read(&self, offset: usize) -> u32 {
        let mut c = self.0.borrow_mut();
        match offset {
            reg::RX_DATA_FIFO => c.rx_data.pop_front().expect("driver read past the RX data"),
            reg::RX_STATUS_FIFO => c
                .rx_status
                .pop_front()
                .expect("driver popped an empty status FIFO"),
            reg::TX_STATUS_FIFO => {
                assert!(c.tx_status > 0, "driver popped an empty TX status FIFO");
                c.tx_status -= 1;
                0
            }
            reg::BYTE_TEST => c.byte_test,
            reg::HW_CFG => 0,
            reg::PMT_CTRL => 1,
            reg::INT_STS => c.int_sts,
            reg::RX_DROP => std::mem::take(&mut c.rx_drop),
            reg::RX_FIFO_INF => (c.rx_status.len() as u32) << 16 | (c.rx_data.len() as u32 * 4),
            reg::TX_FIFO_INF => c.tx_status << 16 | 4608,
            reg::MAC_CSR_CMD => 0,
            reg::MAC_CSR_DATA => c.csr_data,
            other => panic!("read of unexpected register {other:#x}"),
        }
    }

    fn write(&self, offset: usize, value: u32) {
        let mut c = self.0.borrow_mut();
        c.writes.push((offset, value));
        match offset {
            reg::TX_DATA_FIFO => {
                c.tx_words.push(value);
                Fake::parse_tx(&mut c);
            }
            reg::HW_CFG if value & HW_CFG_SRST != 0 => c.resets += 1,
            reg::INT_STS => c.int_sts &= !value,
            reg::INT_EN => c.int_en = value,
            reg::IRQ_CFG => c.irq_cfg = value,
            reg::MAC_CSR_DATA => c.csr_data = value,
            reg::MAC_CSR_CMD => {
                let index = (value & 0xf) as usize;
                if value & CSR_READ != 0 {
                    c.csr_data = match index as u32 {
                        // BMSR with the link up, read through MII_DATA.
                        mac_csr::MII_DATA => 0x782d,
                        _ => c.csr[index],
                    };
                } else if index as u32 == mac_csr::MII_ACC {
                    // The PHY access completes at once.
                    c.csr[index] = c.csr_data & !MII_BUSY;
                } else {
                    c.csr[index] = c.csr_data;
                }
            }
            reg::FIFO_INT | reg::TX_CFG => {}
            other => panic!("write of unexpected register {other:#x}"),
        }
    }
}

struct CountWakes(AtomicUsize);

impl Wake for CountWakes {
    fn wake(self: Arc<Self>) {
        self.0.fetch_add(1, Ordering::SeqCst);
    }
}

fn context() -> (Arc<CountWakes>, Waker) {
    let w = Arc::new(CountWakes(AtomicUsize::new(0)));
    (w.clone(), Waker::from(w))
}

const MAC: [u8; 6] = [0x02, 0x11, 0x22, 0x33, 0x44, 0x55];

fn frame(len: usize, seed: u8) -> Vec<u8> {
    (0..len)
        .map(|i| (i as u8).wrapping_mul(7).wrapping_add(seed))
        .collect()
}

#[test]
fn init_resets_programs_the_mac_and_enables_the_interrupt_active_high() {
    let _turn = one_at_a_time();
    let nic = Lan9118::new(Fake::new(), MAC).expect("init");
    let c = nic.registers().0.borrow();
    assert_eq!(c.resets, 1);
    assert_eq!(c.csr[mac_csr::ADDRL as usize], 0x3322_1102);
    assert_eq!(c.csr[mac_csr::ADDRH as usize], 0x5544);
    let mac_cr = c.csr[mac_csr::MAC_CR as usize];
    assert_ne!(mac_cr & MAC_CR_RXEN, 0, "RX on");
    assert_ne!(mac_cr & MAC_CR_TXEN, 0, "TX on");
    assert_eq!(mac_cr & (1 << 18), 0, "not promiscuous");
    // QEMU's line is active-low until IRQ_CFG says otherwise.
    assert_eq!(c.irq_cfg, 0x111);
    assert_eq!(c.int_en, INT_RSFL);
    let irq_cfg_at = c.writes.iter().position(|w| w.0 == reg::IRQ_CFG).unwrap();
    let int_en_at = c.writes.iter().rposition(|w| w.0 == reg::INT_EN).unwrap();
    assert!(
        irq_cfg_at < int_en_at,
        "polarity set before the interrupt is enabled"
    );
}

#[test]
fn init_without_a_chip_is_a_typed_error() {
    let _turn = one_at_a_time();
    let fake = Fake::new();
    fake.0.borrow_mut().byte_test = 0xffff_ffff;
    assert_eq!(
        Lan9118::new(fake, MAC).err(),
        Some(InitError::NoChip(0xffff_ffff))
    );
}

#[test]
fn frames_of_every_length_come_out_whole_without_the_crc() {
    let _turn = one_at_a_time();
    let mut nic = Lan9118::new(Fake::new(), MAC).unwrap();
    let (_, waker) = context();
    let mut cx = Context::from_waker(&waker);
    // Lengths around every word alignment, the minimum and the maximum.
    let lengths = [60, 61, 62, 63, 64, 590, 1513, 1514];
    for (i, len) in lengths.iter().enumerate() {
        nic.registers().arrive(&frame(*len, i as u8), false);
    }
    for (i, len) in lengths.iter().enumerate() {
        let (rx, _tx) = nic.receive(&mut cx).expect("a frame is waiting");
        let got = rx.consume(|f| f.to_vec());
        assert_eq!(got, frame(*len, i as u8), "frame {i} of {len} bytes");
    }
    assert!(nic.receive(&mut cx).is_none());
    assert!(
        nic.registers().0.borrow().rx_data.is_empty(),
        "no word left behind"
    );
    assert_eq!(nic.counters().rx_frames, lengths.len() as u32);
}

#[test]
fn bad_frames_are_read_out_counted_and_skipped() {
    let _turn = one_at_a_time();
    let mut nic = Lan9118::new(Fake::new(), MAC).unwrap();
    let (_, waker) = context();
    let mut cx = Context::from_waker(&waker);
    nic.registers().arrive(&frame(100, 1), true); // error bit
    nic.registers().arrive(&frame(8, 2), false); // shorter than a header
    nic.registers().arrive(&frame(1600, 3), false); // longer than our buffer
    nic.registers().arrive(&frame(70, 4), false);
    let (rx, _) = nic.receive(&mut cx).expect("the good frame");
    assert_eq!(rx.consume(|f| f.to_vec()), frame(70, 4));
    assert_eq!(nic.counters().rx_discarded, 3);
    assert!(nic.registers().0.borrow().rx_data.is_empty());
}

#[test]
fn nothing_waiting_registers_the_waker_and_the_interrupt_wakes_it() {
    let _turn = one_at_a_time();
    let mut nic = Lan9118::new(Fake::new(), MAC).unwrap();
    let (count, waker) = context();
    let mut cx = Context::from_waker(&waker);
    assert!(nic.receive(&mut cx).is_none());
    nic.registers().arrive(&frame(60, 9), false);
    on_interrupt(nic.registers());
    assert_eq!(count.0.load(Ordering::SeqCst), 1, "woken by the interrupt");
    assert_eq!(nic.registers().0.borrow().int_sts, 0, "status acknowledged");
    assert!(nic.receive(&mut cx).is_some());
}

#[test]
fn sent_frames_arrive_byte_for_byte_and_tx_status_is_drained() {
    let _turn = one_at_a_time();
    let mut nic = Lan9118::new(Fake::new(), MAC).unwrap();
    let (_, waker) = context();
    let mut cx = Context::from_waker(&waker);
    for (i, len) in [42usize, 61, 62, 63, 1514].into_iter().enumerate() {
        let tx = nic.transmit(&mut cx).expect("room to send");
        let data = frame(len, i as u8);
        tx.consume(len, |buf| buf.copy_from_slice(&data));
    }
    // The next transmit drains the five status words.
    let _ = nic.transmit(&mut cx).expect("room to send");
    let c = nic.registers().0.borrow();
    assert_eq!(c.tx_status, 0);
    assert!(c.tx_words.is_empty(), "exactly ceil(len/4) words per frame");
    let lens: Vec<usize> = c.tx_frames.iter().map(Vec::len).collect();
    assert_eq!(lens, [42, 61, 62, 63, 1514]);
    for (i, f) in c.tx_frames.iter().enumerate() {
        assert_eq!(*f, frame(f.len(), i as u8));
    }
}

#[test]
fn link_comes_from_the_phy() {
    let _turn = one_at_a_time();
    let mut nic = Lan9118::new(Fake::new(), MAC).unwrap();
    let (_, waker) = context();
    let mut cx = Context::from_waker(&waker);
    assert!(matches!(nic.link_state(&mut cx), LinkState::Up));
    assert_eq!(nic.capabilities().max_transmission_unit, MTU);
    assert!(matches!(nic.hardware_address(), HardwareAddress::Ethernet(m) if m == MAC));
}

#[test]
fn the_chips_dropped_frames_full_fifo_and_fill_reach_the_counters() {
    let _turn = one_at_a_time();
    let mut nic = Lan9118::new(Fake::new(), MAC).unwrap();
    let (_, waker) = context();
    let mut cx = Context::from_waker(&waker);
    let before = nic_counters(nic.registers());
    // Three full frames wait: the driver sees the data FIFO 3 × 380 words full.
    for i in 0..3 {
        nic.registers().arrive(&frame(1514, i), false);
    }
    for _ in 0..3 {
        nic.receive(&mut cx).expect("a frame").0.consume(|_| ());
    }
    assert_eq!(nic.counters().rx_fifo_max, 3 * 380 * 4);
    // The chip dropped five frames and says so in INT_STS; two more are
    // counted by the time the counters are read. RX_DROP clears on read.
    {
        let mut c = nic.registers().0.borrow_mut();
        c.rx_drop = 5;
        c.int_sts |= INT_RXDF | INT_RSFF;
    }
    on_interrupt(nic.registers());
    nic.registers().0.borrow_mut().rx_drop = 2;
    let after = nic_counters(nic.registers());
    assert_eq!(after.rx_dropped - before.rx_dropped, 7);
    assert_eq!(after.status_full - before.status_full, 1);
    assert!(after.rx_frames - before.rx_frames >= 3);
    assert!(after.fifo_max >= 3 * 380 * 4);
    assert_eq!(nic.registers().0.borrow().rx_drop, 0, "read to clear");
}
