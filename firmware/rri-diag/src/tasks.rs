//! The service's tasks on a board (feature `board`): everything a board
//! needs besides its own status (`fill`) and who it is ([`Identity`]).
//!
//! ```text
//! let mut parts = Parts::build(identity);          // once, in main
//! for t in parts.sockets(stack, port) { spawn(t) } // urgent executor
//! for t in parts.services(fill) { spawn(t) }       // background
//! ```
//!
//! Memory: every buffer and structure lives in `.diag_ram`, a `NOLOAD`
//! section every board's memory map places out of the DTCM (the NUCLEO
//! boards: in the DMA SRAM) and zeroes before `main` uses it. Byte
//! buffers are used as they are (all zero is their start); structures are
//! `MaybeUninit` written in place once ([`Parts::build`]), so nothing
//! assumes an initial value of memory the start-up did not write. What
//! stays in the DTCM is the tasks' futures (a few references each) and
//! the network stack's socket state.
//!
//! `link_section` is what `unsafe_code` flags here: the contract is the
//! memory maps' (a `NOLOAD` section the board zeroes in `init`) and the
//! types' (each static's all-zero bytes are a valid value: byte arrays,
//! `MaybeUninit`, and `ConstStaticCell`'s unset flag).
#![allow(unsafe_code)]

use super::serve::{
    self, Renderer, ServiceHalf, ServiceStats, Slot, SocketHalf, SLOTS, SOCKET_RX, SOCKET_TX,
    WINDOW,
};
use super::{Identity, Status};
use core::mem::MaybeUninit;
use embassy_executor::SpawnToken;
use embassy_net::Stack;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::mutex::Mutex;
use rri_firmware::fragments::Link;
use static_cell::ConstStaticCell;

type Renderers = Mutex<CriticalSectionRawMutex, Renderer>;

/// How a board fills in its status (called once per response, from the
/// background executor).
pub type Fill = fn(&mut Option<Status>);

#[link_section = ".diag_ram"]
static SLOT: ConstStaticCell<MaybeUninit<[Slot; SLOTS]>> =
    ConstStaticCell::new(MaybeUninit::uninit());
#[link_section = ".diag_ram"]
static SOCKET_HALF: ConstStaticCell<MaybeUninit<[SocketHalf; SLOTS]>> =
    ConstStaticCell::new(MaybeUninit::uninit());
#[link_section = ".diag_ram"]
static SERVICE_HALF: ConstStaticCell<MaybeUninit<[ServiceHalf; SLOTS]>> =
    ConstStaticCell::new(MaybeUninit::uninit());
#[link_section = ".diag_ram"]
static RENDERER: ConstStaticCell<MaybeUninit<Renderers>> =
    ConstStaticCell::new(MaybeUninit::uninit());
#[link_section = ".diag_ram"]
static IDENTITY: ConstStaticCell<MaybeUninit<Identity>> =
    ConstStaticCell::new(MaybeUninit::uninit());
#[link_section = ".diag_ram"]
static SOCKETS: ConstStaticCell<[([u8; SOCKET_RX], [u8; SOCKET_TX]); SLOTS]> =
    ConstStaticCell::new([([0; SOCKET_RX], [0; SOCKET_TX]); SLOTS]);
#[link_section = ".diag_ram"]
static WINDOW_BYTES: ConstStaticCell<[u8; WINDOW]> = ConstStaticCell::new([0; WINDOW]);

/// The service's counters (connections accepted, answered, aborted).
pub static STATS: ServiceStats = ServiceStats::new();

/// Where uploads go (issue 43): the board installs its receiver before it
/// spawns the services, or leaves the service read-only. Only where the
/// upload's path is built (cfg `rri_update`: a board with update
/// partitions).
#[cfg(rri_update)]
pub static DESK: serve::Desk = serve::Desk::new();

#[cfg(rri_update)]
const THE_DESK: Option<&serve::Desk> = Some(&DESK);
#[cfg(not(rri_update))]
const THE_DESK: Option<&serve::Desk> = None;

/// The service's parts, built once.
pub struct Parts {
    slots: &'static [Slot; SLOTS],
    sockets: Option<&'static mut [SocketHalf; SLOTS]>,
    services: Option<&'static mut [ServiceHalf; SLOTS]>,
    renderer: &'static Renderers,
    id: &'static Identity,
}

/// The network halves' share, for the urgent executor (it is `Send`; the
/// network stack is not, so the tasks are spawned where it runs).
pub struct Urgent {
    slots: &'static [Slot; SLOTS],
    halves: &'static mut [SocketHalf; SLOTS],
}

impl Parts {
    /// Builds everything in place, in `.diag_ram`. Once, in `main`, after
    /// the board's `init` zeroed the section; `None` the second time.
    #[inline(never)]
    pub fn build(id: Identity) -> Option<Parts> {
        let slots: &'static [Slot; SLOTS] = SLOT.try_take()?.write([const { Slot::new() }; SLOTS]);
        let sockets = SOCKET_HALF
            .try_take()?
            .write([const { SocketHalf::new() }; SLOTS]);
        let services = SERVICE_HALF
            .try_take()?
            .write([const { ServiceHalf::new() }; SLOTS]);
        let window = WINDOW_BYTES.try_take()?;
        let renderer: &'static Renderers = RENDERER
            .try_take()?
            .write(Mutex::new(Renderer::new(window)));
        let id: &'static Identity = IDENTITY.try_take()?.write(id);
        Some(Parts {
            slots,
            sockets: Some(sockets),
            services: Some(services),
            renderer,
            id,
        })
    }

    /// Who the device is, as the service shows it.
    pub fn identity(&self) -> &'static Identity {
        self.id
    }

    /// The network halves' share (once).
    pub fn urgent(&mut self) -> Option<Urgent> {
        Some(Urgent {
            slots: self.slots,
            halves: self.sockets.take()?,
        })
    }

    /// The service halves' tasks, one per slot, for the background
    /// executor (once; empty after).
    pub fn services(&mut self, fill: Fill) -> impl Iterator<Item = SpawnToken<impl Sized>> + '_ {
        let (renderer, id) = (self.renderer, self.id);
        self.slots
            .iter()
            .zip(self.services.take().into_iter().flatten())
            .filter_map(move |(slot, half)| service(slot, half, renderer, id, fill).ok())
    }
}

impl Urgent {
    /// The network halves' tasks, one per slot, serving `port` (once per
    /// `Urgent`).
    pub fn sockets(
        self,
        stack: Stack<'static>,
        port: u16,
        link: &'static Link,
    ) -> impl Iterator<Item = SpawnToken<impl Sized>> {
        let buffers = SOCKETS.try_take().into_iter().flat_map(|b| b.iter_mut());
        self.slots
            .iter()
            .zip(self.halves.iter_mut())
            .zip(buffers)
            .filter_map(move |((slot, half), (rx, tx))| {
                socket(stack, port, link, slot, half, rx, tx).ok()
            })
    }
}

#[embassy_executor::task(pool_size = SLOTS)]
async fn socket(
    stack: Stack<'static>,
    port: u16,
    link: &'static Link,
    slot: &'static Slot,
    half: &'static mut SocketHalf,
    rx: &'static mut [u8; SOCKET_RX],
    tx: &'static mut [u8; SOCKET_TX],
) -> ! {
    // The cycle's socket first: the runner serves sockets in the order
    // they were made, and a reply must not wait behind a response.
    while !link.is_channel_open() {
        embassy_time::Timer::after_millis(10).await;
    }
    let guest = serve::Guest {
        stats: &STATS,
        cycle: link,
    };
    serve::connection(stack, port, slot, half, guest, rx, tx).await
}

#[embassy_executor::task(pool_size = SLOTS)]
async fn service(
    slot: &'static Slot,
    half: &'static mut ServiceHalf,
    renderer: &'static Renderers,
    id: &'static Identity,
    fill: Fill,
) -> ! {
    serve::service(slot, half, renderer, id, fill, THE_DESK).await
}
