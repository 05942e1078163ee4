//! The link: the on-board LAN8742A read over MDIO from a background task
//! every [`LINK_POLL_MS`], and the state it found, cached, for the network
//! stack.
//!
//! embassy-net asks its driver for the link state at every poll of its
//! runner, on the urgent executor, and embassy-stm32's `GenericPhy`
//! answers with a blocking MDIO read (about 30 µs at the 2 MHz MDC), so
//! every cycle would pay 30 to 60 µs of latency and jitter at its own
//! priority. Here the driver's [`Phy`] is [`CachedLink`]: an atomic load,
//! no bus access. The MDIO reads happen in [`Monitor::poll`], on the
//! thread-mode executor below the cycle, which wakes the network stack
//! only when the state changes, and logs each change with its speed and
//! duplex.
#![allow(unsafe_code)]

use crate::lan8742::{Lan8742, Link, Mdio};
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use core::task::Context;
use embassy_stm32::eth::{Phy, Sma, StationManagement};
use embassy_stm32::peripherals::ETH_SMA;
use embassy_sync::waitqueue::AtomicWaker;

/// How often the PHY is read: a cable pulled shows within half a second.
pub const LINK_POLL_MS: u64 = 500;

static LINK_UP: AtomicBool = AtomicBool::new(false);
/// The last link the monitor read, for the diagnostics: 0 down, 1 up at
/// 100 Mbit/s full duplex, else `MISMATCH | mbit << 8 | full_duplex`.
static LINK_SEEN: AtomicU32 = AtomicU32::new(0);
const MISMATCH: u32 = 1 << 31;

/// The link as the monitor last read it.
pub fn link() -> crate::LinkInfo {
    match LINK_SEEN.load(Ordering::Relaxed) {
        0 => crate::LinkInfo::default(),
        1 => crate::LinkInfo {
            up: true,
            speed_mbps: Some(100),
            full_duplex: Some(true),
        },
        v => crate::LinkInfo {
            up: false,
            speed_mbps: Some((v >> 8) as u16),
            full_duplex: Some(v & 1 != 0),
        },
    }
}
static LINK_WAKER: AtomicWaker = AtomicWaker::new();

/// The PHY as embassy-stm32's Ethernet driver sees it: the cached link
/// state. Reset and set-up are the [`Monitor`]'s (bounded, logged),
/// not the driver's (which would wait forever for a PHY that never
/// answers).
pub struct CachedLink;

impl Phy for CachedLink {
    fn phy_reset(&mut self) {}

    fn phy_init(&mut self) {}

    fn poll_link(&mut self, cx: &mut Context) -> bool {
        LINK_WAKER.register(cx.waker());
        LINK_UP.load(Ordering::Acquire)
    }
}

/// The MAC's management interface.
struct Bus(Sma<'static, ETH_SMA>);

impl Mdio for Bus {
    fn read(&mut self, phy: u8, reg: u8) -> u16 {
        self.0.smi_read(phy, reg)
    }
    fn write(&mut self, phy: u8, reg: u8, value: u16) {
        self.0.smi_write(phy, reg, value)
    }
}

/// Milliseconds of busy wait, for the PHY's reset at start-up.
fn delay_ms(ms: u32) {
    cortex_m::asm::delay(ms.saturating_mul(super::SYSCLK_HZ / 1000));
}

/// The PHY as far as the monitor knows it.
enum State {
    Found(Lan8742<Bus>),
    /// Nothing answered yet: the bus, for the next try.
    Missing(Bus),
    /// Only while a retry holds the bus.
    Retrying,
}

/// Owns the management bus; reads the PHY when polled.
pub struct Monitor {
    state: State,
    link: Link,
}

impl Monitor {
    /// Finds the PHY, resets it and makes it advertise 100BASE-TX full
    /// duplex only (`lan8742`'s module doc says why); logs what failed.
    /// At most half a second (the reset), at start-up.
    pub fn start(sma: Sma<'static, ETH_SMA>) -> Self {
        Monitor {
            state: set_up(Bus(sma), true),
            link: Link::Down,
        }
    }

    /// Reads the link (and retries a PHY that did not answer before);
    /// publishes a change to the network stack and logs it.
    pub fn poll(&mut self) {
        if matches!(self.state, State::Missing(_)) {
            if let State::Missing(bus) = core::mem::replace(&mut self.state, State::Retrying) {
                self.state = set_up(bus, false);
            }
        }
        let link = match &mut self.state {
            State::Found(phy) => phy.poll(),
            State::Missing(_) | State::Retrying => Link::Down,
        };
        if link == self.link {
            return;
        }
        self.link = link;
        match link {
            Link::Up => defmt::info!("link up: 100 Mbit/s full duplex"),
            Link::Down => defmt::warn!("link down"),
            Link::Mismatch { mbit, full_duplex } => defmt::warn!(
                "link at {=u16} Mbit/s {=str} duplex: the MAC runs 100 Mbit/s full duplex only, so the link is used as down (let the other end auto-negotiate)",
                mbit,
                if full_duplex { "full" } else { "half" }
            ),
        }
        LINK_SEEN.store(
            match link {
                Link::Down => 0,
                Link::Up => 1,
                Link::Mismatch { mbit, full_duplex } => {
                    MISMATCH | u32::from(mbit) << 8 | u32::from(full_duplex)
                }
            },
            Ordering::Relaxed,
        );
        LINK_UP.store(link.is_up(), Ordering::Release);
        LINK_WAKER.wake();
    }
}

/// Find, reset, advertise; on failure the bus comes back for a retry
/// (logged only when `first`).
fn set_up(bus: Bus, first: bool) -> State {
    let mut phy = match Lan8742::find(bus) {
        Ok(phy) => phy,
        Err((bus, e)) => {
            if first {
                defmt::error!(
                    "Ethernet PHY: {}: nothing answered on MDIO (PA2/PC1); retrying every {=u64} ms",
                    e,
                    LINK_POLL_MS
                );
            }
            return State::Missing(bus);
        }
    };
    if let Err(e) = phy.reset(delay_ms) {
        // Keep going: a PHY that did not finish its reset may still link.
        defmt::error!("Ethernet PHY at {=u8}: {}", phy.address(), e);
    }
    phy.advertise_100_full_duplex();
    defmt::info!(
        "Ethernet PHY at {=u8}: id {=u16:04x}:{=u16:04x}, advertising 100BASE-TX full duplex only",
        phy.address(),
        phy.id.0,
        phy.id.1
    );
    State::Found(phy)
}

/// Polls the PHY every [`LINK_POLL_MS`] (thread mode).
#[embassy_executor::task]
pub async fn monitor(mut m: Monitor) -> ! {
    let mut ticker = embassy_time::Ticker::every(embassy_time::Duration::from_millis(LINK_POLL_MS));
    loop {
        m.poll();
        ticker.next().await;
    }
}
