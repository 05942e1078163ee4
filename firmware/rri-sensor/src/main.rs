//! The sensor firmware, the same on every board: the board (hal-board,
//! chosen by a cargo feature) supplies the network driver, the time driver,
//! LEDs, a sample source and a watchdog; everything here is written once.
//!
//! Tasks and priorities:
//! - urgent executor (an interrupt, above everything but the time and NIC
//!   interrupts): the network stack's runner and the cycle (receive →
//!   engine → reply). Nothing else can delay an answer.
//! - background (below the urgent executor: the board's
//!   `run_background`, thread mode or a low interrupt): the sensor's
//!   sampler (its own rate: `Sensor::SAMPLE_EVERY_US`), housekeeping
//!   (10 Hz: LEDs, the watchdog, state changes and a counter line per
//!   second in the log) and, in bench builds, the bench's record logger.
//!
//! The sensor is `rri_active_sensor::Active`, the file `RRI_SENSOR`
//! names: nothing here depends on its sample type.
//!
//! The watchers never hold the engine: the cycle publishes a
//! [`Snapshot`] after each turn and they read the latest one. So does the
//! diagnostics service (`diagnostics`: a status page, JSON and Prometheus
//! metrics over HTTP, cfg `rri_http`), whose connection tasks only move
//! bytes on the urgent executor while it parses and renders on the
//! background one.
#![no_std]
#![no_main]
// The bench's floor build (feature `bench-floor`) answers without the
// engine, so the cycle's items go unused there.
#![cfg_attr(feature = "bench-floor", allow(dead_code, unused_imports))]

use embassy_executor::{SendSpawner, Spawner};
use embassy_net::{Ipv4Address, Ipv4Cidr, Runner, Stack, StackResources, StaticConfigV4};
use embassy_time::{Duration, Ticker};
use hal_board::board;
use rri_active_sensor::Active;
use rri_firmware::engine::{Clock, DropReason, Engine, Outcome};
use rri_firmware::fragments::guard::FragmentGuard;
use rri_firmware::fragments::{self, Channel, Link, Reassembler};
use rri_firmware::layout::{self, DeviceEngine, DeviceProperties, RobotProperties};
use rri_firmware::net::{self, EmbassyClock, Monitor};
use rri_firmware::network;
use rri_firmware::sample::{SampleCell, SampleReader, SampleWriter};
use rri_firmware::schema::Protocol;
use rri_firmware::sensor::{Ring, Sampler, Sensor, SensorApp};
use rri_firmware::snapshot::Published;
use static_cell::{ConstStaticCell, StaticCell};

/// Spawns a task at start-up; a full task pool is a build mistake.
macro_rules! spawn {
    ($spawner:expr, $task:expr) => {
        match $task {
            Ok(token) => $spawner.spawn(token),
            Err(_) => defmt::panic!("task pool full: {}", stringify!($task)),
        }
    };
}

#[cfg(rri_http)]
mod diagnostics;
mod housekeeping;
#[cfg(rri_update)]
mod update;
mod update_key;
mod version;
use housekeeping::housekeeping;

/// The device's address: Description.xml's `Network Address`.
const ADDRESS: [u8; 4] = match layout::NETWORK_IPV4 {
    Some(ip) => ip,
    None => panic!("Description.xml's Network Address must be an IPv4 address for a board"),
};
const TCP: bool = matches!(layout::CHANNEL_PROTOCOL, Protocol::Tcp);
/// TCP socket buffers, each way, for each of the two sockets (the served
/// connection and the standby; M10): one message of either direction.
const TCP_SOCKET: usize = if layout::MAX_RECEIVE_LEN > layout::MAX_SEND_LEN {
    layout::MAX_RECEIVE_LEN
} else {
    layout::MAX_SEND_LEN
};
/// The network stack's sockets: the channel's (two for TCP: the served
/// connection and the standby) and the diagnostics service's.
#[cfg(rri_http)]
const SOCKETS: usize = 2 + rri_diag::serve::SLOTS;
#[cfg(not(rri_http))]
const SOCKETS: usize = 2;
/// The watchdog resets the board when the cycle stops turning this long
/// (the board's: the NUCLEO boards start it in `init`).
const WATCHDOG_MS: u32 = hal_board::WATCHDOG_MS;

/// The board's driver as the stack sees it: behind the fragment guard
/// (S5: robot messages longer than a frame are reassembled there, under
/// rules no other sender can use to lock the controller out; in bench
/// builds the guard also counts each frame's instructions per layer).
type Driver = board::Net;
type Nic = FragmentGuard<'static, Driver, REASSEMBLY_BUF>;

/// One reassembly buffer: the layout's longest robot message with its
/// headers.
const REASSEMBLY_BUF: usize = fragments::buffer_len(layout::MAX_RECEIVE_LEN);
/// Shared by the fragment guard and the cycle: who the controller is, and
/// the guard's counters.
static LINK: Link = Link::new();

/// The sensor's history of samples, as its sampler publishes it.
type Samples = <Active as Sensor>::History;

static SAMPLES: SampleCell<Samples> = SampleCell::new(<Samples as Ring<_>>::EMPTY);
static PUBLISHED: Published = Published::new();

#[cortex_m_rt::entry]
fn main() -> ! {
    // First, before any interrupt can use the stack: the high-water mark
    // housekeeping logs is measured against this paint.
    hal_board::stack::paint();
    let b = match board::init() {
        Ok(b) => b,
        Err(e) => defmt::panic!("{}: the network chip did not start: {}", board::NAME, e),
    };
    defmt::info!(
        "rri-sensor {} on {}: {} at {}.{}.{}.{}/{} port {} over {}",
        version::VERSION,
        board::NAME,
        layout::DEVICE_NAME,
        ADDRESS[0],
        ADDRESS[1],
        ADDRESS[2],
        ADDRESS[3],
        network::PREFIX_LEN,
        layout::CHANNEL_PORT,
        if TCP { "TCP" } else { "UDP" },
    );
    defmt::info!(
        "sensor: {=str} from {=str}",
        rri_active_sensor::active_name(),
        rri_active_sensor::ACTIVE_FILE
    );
    #[cfg(feature = "bench")]
    for (name, message) in rri_firmware::bench::CODEC_CORPUS {
        let c = rri_firmware::bench::compare_codecs(message, 20, board::cycle_counter);
        defmt::info!(
            "codec {=str} bytes={=usize} ours={=u32} tokenizer={=u32} baseline={=u32}",
            name,
            message.len(),
            c.ours,
            c.tokenizer,
            c.baseline
        );
    }
    #[cfg(feature = "bench")]
    defmt::info!(
        "copy bytes={=usize} alike={=u32} unlike={=u32}",
        rri_firmware::bench::COPY_LEN,
        rri_firmware::bench::copy_cost(2, 2, board::cycle_counter),
        rri_firmware::bench::copy_cost(2, 0, board::cycle_counter)
    );
    hal_board::fault::log_reset(&b.reset);
    #[cfg(rri_http)]
    diagnostics::started(b.reset);
    let mac = match embassy_net_driver::Driver::hardware_address(&b.net) {
        embassy_net_driver::HardwareAddress::Ethernet(mac) => Some(mac),
        #[allow(unreachable_patterns)]
        _ => None,
    };
    #[cfg(rri_http)]
    let mut http = match rri_diag::tasks::Parts::build(diagnostics::identity(mac)) {
        Some(parts) => parts,
        None => defmt::panic!("the diagnostics' parts were built twice"),
    };
    #[cfg(rri_http)]
    defmt::info!(
        "diagnostics: http://{}.{}.{}.{}:{}/ ({} connections at once; {} bytes of .diag_ram)",
        ADDRESS[0],
        ADDRESS[1],
        ADDRESS[2],
        ADDRESS[3],
        rri_firmware::network::HTTP_PORT,
        rri_diag::serve::SLOTS,
        hal_board::sections::diag_ram_bytes()
    );
    #[cfg(not(rri_http))]
    let _ = mac;
    #[cfg(rri_update)]
    update::install();
    let Some((writer, reader)) = SAMPLES.split() else {
        defmt::panic!("the sample cell was split twice")
    };
    #[cfg(feature = "bench")]
    rri_firmware::bench::count_with(board::cycle_counter);
    start_network(
        b.net,
        b.seed,
        reader,
        #[cfg(rri_http)]
        http.urgent(),
    );

    let (inputs, leds, watchdog) = (b.inputs, b.leds, b.watchdog);
    board::run_background(move |s| {
        spawn!(s, sampler(inputs, writer));
        spawn!(s, housekeeping(leds, watchdog));
        #[cfg(feature = "bench")]
        spawn!(s, bench_log());
        #[cfg(rri_http)]
        for token in http.services(diagnostics::status) {
            s.spawn(token);
        }
    })
}

/// Starts the urgent executor with the network task on it. A function of
/// its own, never inlined: `main` never returns, so whatever its frame
/// holds stays on the one stack under every interrupt for good, and moving
/// the driver into the task's storage takes kilobytes (3 KB of `main`'s
/// frame when it was inlined there).
#[inline(never)]
fn start_network(
    driver: Driver,
    seed: u64,
    reader: SampleReader<'static, Samples>,
    #[cfg(rri_http)] http: Option<rri_diag::tasks::Urgent>,
) {
    let urgent: SendSpawner = board::start_urgent_executor();
    spawn!(
        urgent,
        network(
            driver,
            seed,
            reader,
            #[cfg(rri_http)]
            http
        )
    );
}

/// Builds the network stack on the urgent executor (the stack is not
/// `Send`: it must live where it runs) and starts the runner and the cycle.
#[embassy_executor::task]
async fn network(
    driver: Driver,
    seed: u64,
    reader: SampleReader<'static, Samples>,
    #[cfg(rri_http)] http: Option<rri_diag::tasks::Urgent>,
) {
    // SAFETY: this task runs on the urgent executor and spawns onto it.
    let spawner = unsafe { Spawner::for_current_executor() }.await;
    // Here, not in `main` (see `start_network`): this task's frame is gone
    // once it ends; in `main` the guard's construction cost 5.7 KB of the
    // stack for good.
    // The reassembly buffers are the stack's largest: in place, in `.bss`.
    static REASSEMBLY: ConstStaticCell<Reassembler<REASSEMBLY_BUF>> =
        ConstStaticCell::new(Reassembler::new());
    let nic = FragmentGuard::new(
        driver,
        REASSEMBLY.take(),
        &LINK,
        Channel {
            device: ADDRESS,
            port: layout::CHANNEL_PORT,
        },
    );
    let [a, b, c, d] = ADDRESS;
    let config = embassy_net::Config::ipv4_static(StaticConfigV4 {
        address: Ipv4Cidr::new(Ipv4Address::new(a, b, c, d), network::PREFIX_LEN),
        gateway: network::GATEWAY.map(|[a, b, c, d]| Ipv4Address::new(a, b, c, d)),
        dns_servers: Default::default(),
    });
    // Sockets: one (UDP), or two (TCP: the served connection and the
    // standby), and one per diagnostics slot.
    static RESOURCES: StaticCell<StackResources<SOCKETS>> = StaticCell::new();
    let (stack, runner) =
        embassy_net::new(nic, config, RESOURCES.init(StackResources::new()), seed);
    spawn!(spawner, net_runner(runner));
    spawn!(spawner, cycle(stack, reader));
    #[cfg(rri_http)]
    for token in http
        .into_iter()
        .flat_map(|h| h.sockets(stack, rri_firmware::network::HTTP_PORT, &LINK))
    {
        spawner.spawn(token);
    }
}

#[embassy_executor::task]
async fn net_runner(mut runner: Runner<'static, Nic>) -> ! {
    // Passed over while the cycle works on a robot message (the guard's
    // hold): such a pass would only cost the message's full path.
    fragments::guard::run_gated(&LINK, runner.run()).await
}

/// The cycle: the engine and the sensor's cycle half over the configured
/// channel (UDP or TCP).
#[cfg(not(feature = "bench-floor"))]
#[embassy_executor::task]
async fn cycle(stack: Stack<'static>, reader: SampleReader<'static, Samples>) -> ! {
    static ENGINE: StaticCell<DeviceEngine> = StaticCell::new();
    let engine = ENGINE.init_with(|| Engine::new(layout::ENGINE_CONFIG));
    let mut app = SensorApp::<Active>::new(reader);
    let mut monitor = Publisher { heartbeat: 0 };
    stack.wait_config_up().await;
    // Start-up is over (the network stack is built: its construction is the
    // deepest the stack goes, see hal_board::stack); from here the cycle's
    // own depth is measured.
    hal_board::stack::repaint();
    let cycle = net::Cycle {
        stack,
        port: layout::CHANNEL_PORT,
        engine,
        app: &mut app,
        clock: &EmbassyClock,
        monitor: &mut monitor,
        link: &LINK,
    };
    if TCP {
        static BUFFERS: ConstStaticCell<
            net::TcpBuffers<TCP_SOCKET, { layout::MAX_RECEIVE_LEN }, { layout::MAX_SEND_LEN }>,
        > = ConstStaticCell::new(net::TcpBuffers::new());
        cycle.tcp(BUFFERS.take()).await
    } else {
        static BUFFERS: ConstStaticCell<
            net::UdpBuffers<{ layout::MAX_RECEIVE_LEN }, { layout::MAX_SEND_LEN }>,
        > = ConstStaticCell::new(net::UdpBuffers::new());
        cycle.udp(BUFFERS.take()).await
    }
}

/// The bench's floor (feature `bench-floor`, measured by `cargo
/// qemu-bench`): every datagram on the channel port answered with one fixed
/// reply (the reply property's defaults, encoded once), with no decoding
/// and no engine: what the driver, smoltcp and the executor cost on their
/// own, recorded like a cycle (frame in → reply frame out). UDP only.
#[cfg(feature = "bench-floor")]
#[embassy_executor::task]
async fn cycle(stack: Stack<'static>, _reader: SampleReader<'static, Samples>) -> ! {
    use embassy_futures::select::{select, Either};
    use embassy_net::udp::{PacketMetadata, UdpSocket};
    use embassy_time::Timer;
    use rri_firmware::properties::DeviceSet;
    const RX: usize = layout::MAX_RECEIVE_LEN;
    const TX: usize = layout::MAX_SEND_LEN;
    use net::AsInFrame;
    // Placed as the cycle's `net::UdpBuffers` are, so the floor's copies
    // cost what the cycle's do.
    type Bytes = (
        AsInFrame<[u8; RX * net::QUEUE]>,
        AsInFrame<[u8; TX * net::QUEUE]>,
        AsInFrame<[u8; RX]>,
    );
    static BYTES: ConstStaticCell<Bytes> = ConstStaticCell::new((
        AsInFrame::new([0; RX * net::QUEUE]),
        AsInFrame::new([0; TX * net::QUEUE]),
        AsInFrame::new([0; RX]),
    ));
    let (rx, tx, datagram) = BYTES.take();
    let (rx, tx, datagram) = (&mut rx.bytes, &mut tx.bytes, &mut datagram.bytes);
    let mut reply = AsInFrame::new([0u8; TX]);
    let reply = &mut reply.bytes;
    let device = DeviceProperties::default();
    let Ok(fixed) = device.encode(
        layout::REPLY.index(),
        0,
        Default::default(),
        layout::FORMAT,
        reply,
    ) else {
        defmt::panic!("the fixed reply does not fit MAX_SEND_LEN")
    };
    let mut rx_meta = [PacketMetadata::EMPTY; net::QUEUE];
    let mut tx_meta = [PacketMetadata::EMPTY; net::QUEUE];
    stack.wait_config_up().await;
    hal_board::stack::repaint();
    let mut socket = UdpSocket::new(stack, &mut rx_meta, rx, &mut tx_meta, tx);
    if socket.bind(layout::CHANNEL_PORT).is_err() {
        defmt::panic!("the floor cannot bind its port");
    }
    LINK.channel_open();
    // CONNECTED for the host tools, and a heartbeat for the watchdog.
    let mut turn = rri_firmware::snapshot::Snapshot {
        state: rri_firmware::engine::SensorState::Connected,
        ..rri_firmware::snapshot::Snapshot::default()
    };
    loop {
        turn.heartbeat = turn.heartbeat.wrapping_add(1);
        PUBLISHED.publish(&turn);
        let received = select(socket.recv_from(datagram), Timer::after(net::POLL_INTERVAL)).await;
        let Either::First(Ok((len, meta))) = received else {
            continue;
        };
        let before = board::cycle_counter();
        LINK.turn_done(true);
        let sent = socket
            .send_to(reply.get(..fixed.len).unwrap_or(&[]), meta.endpoint)
            .await;
        let after = board::cycle_counter();
        rri_firmware::bench::message(len, sent.ok().map(|()| meta.endpoint.port), (before, after));
    }
}

/// Publishes the engine's snapshot after every turn of the cycle loop.
struct Publisher {
    heartbeat: u32,
}

impl Publisher {
    fn publish(&mut self, engine: &DeviceEngine) {
        self.heartbeat = self.heartbeat.wrapping_add(1);
        PUBLISHED.publish_of(engine, self.heartbeat);
    }
}

impl Monitor<RobotProperties, DeviceProperties> for Publisher {
    #[cfg(feature = "bench")]
    fn count(&self) -> u32 {
        board::cycle_counter()
    }

    fn message(
        &mut self,
        engine: &DeviceEngine,
        message: &[u8],
        from: rri_firmware::engine::Endpoint,
        outcome: &Outcome,
        _counts: (u32, u32),
    ) {
        #[cfg(feature = "bench")]
        rri_firmware::bench::message(
            message.len(),
            match outcome {
                Outcome::Reply { to, .. } => Some(to.port),
                Outcome::Dropped(_) => None,
            },
            _counts,
        );
        if let (Outcome::Dropped(DropReason::Decode(_)), Some(error)) =
            (outcome, engine.last_decode_error())
        {
            #[cfg(rri_http)]
            diagnostics::LAST_BAD.record(diagnostics::now(), from, error, message);
            #[cfg(not(rri_http))]
            let _ = (from, error, message);
        }
        self.publish(engine);
    }

    fn polled(&mut self, engine: &DeviceEngine) {
        self.publish(engine);
    }
}

/// The sensor's sampling half, at its own rate: a sample from the board's
/// inputs (simulated where the board has none: QEMU), stamped with the
/// device time, and the history published for the cycle.
#[embassy_executor::task]
async fn sampler(mut inputs: board::Inputs, writer: SampleWriter<'static, Samples>) -> ! {
    let mut sampler = Sampler::<Active>::new(writer);
    let every = u64::from(<Active as Sensor>::SAMPLE_EVERY_US);
    let mut ticker = Ticker::every(Duration::from_micros(every));
    loop {
        sampler.step(&mut inputs, EmbassyClock.now());
        ticker.next().await;
    }
}

/// Bench builds: every cycle record, logged from thread mode.
#[cfg(feature = "bench")]
#[embassy_executor::task]
async fn bench_log() -> ! {
    use rri_firmware::bench::{LOST, RECORDS};
    loop {
        let r = RECORDS.receive().await;
        defmt::info!(
            "bench bytes={=u32} answered={=bool} compute={=u32} full={=u32} frames={=u32} read={=u32} driver={=u32} guard={=u32} smoltcp={=u32} before={=u32} held_in={=u32} held_out={=u32} lost={=u32}",
            r.bytes,
            r.answered,
            r.compute,
            r.full,
            r.frames,
            r.read,
            r.driver,
            r.guard,
            r.smoltcp,
            r.before,
            r.held_in,
            r.held_out,
            LOST.load(core::sync::atomic::Ordering::Relaxed)
        );
    }
}
