//! The device's own story, on the board: what the diagnostics service
//! (`rri_firmware::diag`) shows and the tasks that serve it.
//!
//! - The cycle keeps the last bad robot message ([`LAST_BAD`], after the
//!   message was dropped) and the fragment guard times the replies at
//!   the driver (`LINK`); housekeeping logs events ([`EVENTS`]) by
//!   comparing the snapshots the cycle publishes.
//! - With cfg `rri_http` (`RRI_HTTP_PORT`, default 80; 0 compiles this
//!   out) each connection slot is a task on the urgent executor that only
//!   moves bytes ([`diag::serve::connection`]) and a task on the
//!   background executor that parses and renders
//!   ([`diag::serve::service`]). The socket buffers and the rendering
//!   window live in `.diag_ram` (the NUCLEO boards' DMA SRAM, beside the
//!   Ethernet rings): they take nothing from the DTCM.

use crate::{board, LINK, PUBLISHED};
use rri_firmware::diag::events::{EventKind, Events};
use rri_firmware::diag::status::{
    Identity, LatencySource, LinkStatus, NicFigures, ResetInfo, StackFigures, Status,
};
use rri_firmware::diag::LastBad;
use rri_firmware::engine::Instant;
use rri_firmware::snapshot::Snapshot;

/// The last robot message the decoder rejected (the cycle writes it).
pub static LAST_BAD: LastBad = LastBad::new();
/// What happened (housekeeping writes it).
pub static EVENTS: Events = Events::new();

/// Why the board started, set once at start-up.
static RESET: critical_section::Mutex<core::cell::Cell<Option<ResetInfo>>> =
    critical_section::Mutex::new(core::cell::Cell::new(None));

/// Device time now.
pub fn now() -> Instant {
    Instant(embassy_time::Instant::now().as_micros())
}

/// At start-up: keeps why the board started and logs it as the first
/// event.
pub fn started(report: hal_board::reset::Report) {
    let info = ResetInfo::from_board(report);
    critical_section::with(|cs| RESET.borrow(cs).set(Some(info)));
    EVENTS.push(now(), EventKind::Started(info.cause));
    match info.pc {
        Some((pc, lr)) => defmt::warn!(
            "last reset: {=str} at PC {=u32:#010x} LR {=u32:#010x} (start {=u32})",
            info.cause.name(),
            pc,
            lr,
            info.boots
        ),
        None => defmt::info!(
            "last reset: {=str} (start {=u32})",
            info.cause.name(),
            info.boots
        ),
    }
}

/// Housekeeping, after each look at the cycle: the events between the
/// last snapshot and this one, and the link's changes.
pub fn note(last: &Snapshot, now_snap: &Snapshot, link: &mut hal_board::LinkInfo) {
    let at = now();
    if now_snap.state != last.state || now_snap.error != last.error {
        EVENTS.push(at, EventKind::State(now_snap.state, now_snap.error));
    }
    if now_snap.stats.timeouts > last.stats.timeouts {
        EVENTS.push(at, EventKind::TimeOut);
    }
    if now_snap.stats.max_lost_exceeded > last.stats.max_lost_exceeded {
        EVENTS.push(at, EventKind::MaxLost);
    }
    if let Some(peer) = now_snap.peer {
        if now_snap.peer != last.peer {
            EVENTS.push(at, EventKind::Peer(peer));
        }
    }
    let seen = board::link();
    if seen != *link {
        EVENTS.push(
            at,
            if seen.up {
                EventKind::LinkUp(seen.speed_mbps, seen.full_duplex)
            } else {
                EventKind::LinkDown
            },
        );
        *link = seen;
    }
}

/// Everything that moves, as of now (the service copies it once per
/// response).
pub fn status(out: &mut Option<Status>) {
    let link = board::link();
    let stack = hal_board::stack::high_water();
    let snapshot = PUBLISHED.latest();
    *out = Some(Status {
        snapshot,
        now: now(),
        link: LinkStatus {
            up: link.up,
            speed_mbps: link.speed_mbps,
            full_duplex: link.full_duplex,
        },
        nic: board::nic_counters().map(|n| NicFigures {
            rx_frames: n.rx_frames,
            rx_dropped: n.rx_dropped,
            status_full: n.status_full,
            fifo_max: n.fifo_max,
            fifo: n.fifo,
        }),
        stack: Some(StackFigures {
            boot: stack.boot as u32,
            running: stack.running as u32,
            size: stack.size as u32,
        }),
        latency: rri_firmware::diag::status::Latency {
            source: LatencySource::Driver,
            histogram: LINK.latency(),
        },
        bad: LAST_BAD.get(),
        events: EVENTS.copy(),
        reset: critical_section::with(|cs| RESET.borrow(cs).get()).unwrap_or(ResetInfo::HOST),
    });
}

/// Who the device is, for the service.
pub fn identity(mac: Option<[u8; 6]>) -> Identity {
    use rri_firmware::layout;
    Identity {
        device: layout::DEVICE_NAME,
        device_type: layout::DEVICE_TYPE,
        device_class: layout::DEVICE_CLASS,
        version: env!("CARGO_PKG_VERSION"),
        commit: rri_firmware::network::COMMIT,
        board: board::NAME,
        sensor: rri_firmware::sensors::active_name(),
        sensor_file: rri_firmware::sensors::ACTIVE_FILE,
        mac,
        ip: crate::ADDRESS,
        prefix: rri_firmware::network::PREFIX_LEN,
        gateway: rri_firmware::network::GATEWAY,
        protocol: layout::CHANNEL_PROTOCOL,
        port: layout::CHANNEL_PORT,
        http_port: rri_firmware::network::HTTP_PORT,
        config: layout::ENGINE_CONFIG,
        received: &layout::RECEIVED_INFO,
        sent: &layout::SENT_INFO,
    }
}

/// The HTTP service (cfg `rri_http`).
#[cfg(rri_http)]
pub mod http {
    use core::mem::MaybeUninit;
    use embassy_net::Stack;
    use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
    use embassy_sync::mutex::Mutex;
    use rri_firmware::diag::serve::{
        self, Renderer, ServiceHalf, ServiceStats, Slot, SocketHalf, SLOTS, SOCKET_RX, SOCKET_TX,
        WINDOW,
    };
    use rri_firmware::diag::Identity;
    use static_cell::ConstStaticCell;

    type Renderers = Mutex<CriticalSectionRawMutex, Renderer>;

    // Everything below lives in `.diag_ram`, which the board zeroes before
    // `main` uses it: byte buffers as they are (all zero is their start),
    // structures as `MaybeUninit` written in place once ([`Parts::build`]),
    // so no initial value is assumed of memory the start-up did not write.
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
    static STATS: ServiceStats = ServiceStats::new();

    /// The service's parts, built once: what the urgent executor's
    /// connection tasks take ([`Parts::start_urgent`]) and what the
    /// background's service tasks take ([`Parts::services`]).
    pub struct Parts {
        slots: &'static [Slot; SLOTS],
        sockets: Option<&'static mut [SocketHalf; SLOTS]>,
        services: Option<&'static mut [ServiceHalf; SLOTS]>,
        renderer: &'static Renderers,
        id: &'static Identity,
    }

    impl Parts {
        /// Builds everything in place (in `.diag_ram`). Once, in `main`,
        /// after the board's `init`.
        pub fn build(id: Identity) -> Parts {
            let slots: &'static [Slot; SLOTS] = SLOT.take().write([const { Slot::new() }; SLOTS]);
            let sockets = SOCKET_HALF
                .take()
                .write([const { SocketHalf::new() }; SLOTS]);
            let services = SERVICE_HALF
                .take()
                .write([const { ServiceHalf::new() }; SLOTS]);
            let renderer: &'static Renderers = RENDERER
                .take()
                .write(Mutex::new(Renderer::new(WINDOW_BYTES.take())));
            let id: &'static Identity = IDENTITY.take().write(id);
            defmt::info!(
                "diagnostics: http://{}.{}.{}.{}:{}/ ({} connections at once; {} bytes of .diag_ram)",
                id.ip[0],
                id.ip[1],
                id.ip[2],
                id.ip[3],
                id.http_port,
                SLOTS,
                hal_board::sections::diag_ram_bytes()
            );
            Parts {
                slots,
                sockets: Some(sockets),
                services: Some(services),
                renderer,
                id,
            }
        }

        /// The network halves' share: slots, their buffers.
        pub fn urgent(&mut self) -> Option<Urgent> {
            Some(Urgent {
                slots: self.slots,
                halves: self.sockets.take()?,
            })
        }

        /// The service halves, one per slot, for the background executor.
        pub fn services(
            &mut self,
        ) -> impl Iterator<
            Item = (
                &'static Slot,
                &'static mut ServiceHalf,
                &'static Renderers,
                &'static Identity,
            ),
        > + '_ {
            let (renderer, id) = (self.renderer, self.id);
            self.slots
                .iter()
                .zip(self.services.take().into_iter().flatten())
                .map(move |(slot, half)| (slot, half, renderer, id))
        }
    }

    /// What the urgent executor's connection tasks take.
    pub struct Urgent {
        slots: &'static [Slot; SLOTS],
        halves: &'static mut [SocketHalf; SLOTS],
    }

    /// Starts the network halves on the urgent executor (where the stack
    /// runs).
    pub fn start_urgent(spawner: embassy_executor::Spawner, stack: Stack<'static>, parts: Urgent) {
        let buffers = SOCKETS.take().iter_mut();
        for ((slot, half), (rx, tx)) in parts.slots.iter().zip(parts.halves.iter_mut()).zip(buffers)
        {
            spawn!(spawner, socket(stack, slot, half, rx, tx));
        }
    }

    #[embassy_executor::task(pool_size = SLOTS)]
    async fn socket(
        stack: Stack<'static>,
        slot: &'static Slot,
        half: &'static mut SocketHalf,
        rx: &'static mut [u8; SOCKET_RX],
        tx: &'static mut [u8; SOCKET_TX],
    ) -> ! {
        serve::connection(
            stack,
            rri_firmware::network::HTTP_PORT,
            slot,
            half,
            &STATS,
            rx,
            tx,
        )
        .await
    }

    /// A slot's service half (background executor).
    #[embassy_executor::task(pool_size = SLOTS)]
    pub async fn service(
        slot: &'static Slot,
        half: &'static mut ServiceHalf,
        renderer: &'static Renderers,
        id: &'static Identity,
    ) -> ! {
        serve::service(slot, half, renderer, id, super::status).await
    }
}
