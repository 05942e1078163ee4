//! What the diagnostics show: [`Identity`] (fixed at start-up: who the
//! device is and how it is configured) and [`Status`] (a consistent copy
//! of everything that moves, taken once per response).
//!
//! Nothing here is read from the engine while the cycle runs: the
//! engine's part is the [`Snapshot`] the cycle already publishes after
//! every turn, the rest comes from cells the cycle, the fragment guard
//! and housekeeping write into (the bad message, the
//! reply latency at the driver, the events) and from the board.

use super::events::EventLog;
use rri_firmware::codec::DecodeErrorKind;
use rri_firmware::engine::{Config, Endpoint, Histogram, Instant};
use rri_firmware::schema::{PropertyInfo, Protocol};
use rri_firmware::snapshot::Snapshot;

/// Who the device is and how it is configured: fixed for a run.
#[derive(Clone, Copy, Debug)]
pub struct Identity {
    /// Description.xml's `Name`.
    pub device: &'static str,
    /// Description.xml's `Type`.
    pub device_type: &'static str,
    /// Description.xml's `Class`.
    pub device_class: &'static str,
    /// The firmware's version (the crate's).
    pub version: &'static str,
    /// The commit it was built from (`git describe`, or `unknown`).
    pub commit: &'static str,
    /// The board (`hal_board::board::NAME`, or `host` for the host sensor).
    pub board: &'static str,
    /// The sensor's type (`RRI_SENSOR`).
    pub sensor: &'static str,
    /// The file the sensor came from.
    pub sensor_file: &'static str,
    /// The MAC address (`None` on the host).
    pub mac: Option<[u8; 6]>,
    /// The device's address and prefix length.
    pub ip: [u8; 4],
    /// Prefix length of its network.
    pub prefix: u8,
    /// The gateway, if any.
    pub gateway: Option<[u8; 4]>,
    /// The channel's protocol (Description.xml).
    pub protocol: Protocol,
    /// The channel's port.
    pub port: u16,
    /// The port this service answers on.
    pub http_port: u16,
    /// The engine's settings (supervision, pinned controller, reply,
    /// periodic sends).
    pub config: Config,
    /// The properties the controller sends (`layout::RECEIVED_INFO`).
    pub received: &'static [PropertyInfo],
    /// The properties the device sends (`layout::SENT_INFO`).
    pub sent: &'static [PropertyInfo],
}

/// Where the reply latency was measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LatencySource {
    /// On a board: the driver handing over the robot message's last frame
    /// → the driver taking the reply's first frame (the fragment guard's
    /// clock, `rri_firmware::fragments::Link`).
    Driver,
    /// On the host sensor: the socket's receive → the reply handed to the
    /// socket (the engine's own figure).
    Socket,
}

impl LatencySource {
    /// As the page and the JSON name it.
    pub const fn name(self) -> &'static str {
        match self {
            LatencySource::Driver => "driver",
            LatencySource::Socket => "socket",
        }
    }
}

/// The network link as the board sees it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LinkStatus {
    /// Up (carrier and, on the NUCLEO boards, 100 Mbit/s full duplex).
    pub up: bool,
    /// Negotiated speed in Mbit/s, where the board knows it.
    pub speed_mbps: Option<u16>,
    /// Full duplex, where the board knows it.
    pub full_duplex: Option<bool>,
}

/// The network chip's own receive counters (`hal_board::NicCounters`),
/// as the diagnostics show them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NicFigures {
    /// Frames the driver took from the chip.
    pub rx_frames: u32,
    /// Frames the chip dropped, by its own count (LAN9118 `RX_DROP`;
    /// STM32 the Ethernet DMA's and MTL's missed-frame counters).
    pub rx_dropped: u32,
    /// Times the receive status FIFO was full (LAN9118 only).
    pub status_full: u32,
    /// The most bytes the receive FIFO held (LAN9118 only).
    pub fifo_max: u32,
    /// Whether `rx_frames`, `status_full` and `fifo_max` are read (not on
    /// the STM32 boards: only `rx_dropped` is).
    pub fifo: bool,
}

/// The stack's painted high-water mark (`hal_board::stack`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StackFigures {
    /// Deepest during start-up, bytes.
    pub boot: u32,
    /// Deepest since, bytes.
    pub running: u32,
    /// The stack's budget, bytes.
    pub size: u32,
}

impl StackFigures {
    /// Percent of the budget left at the deeper of the two marks (the
    /// boards' own rule).
    pub fn margin_percent(&self) -> u32 {
        let used = self.boot.max(self.running).min(self.size);
        (self.size - used)
            .saturating_mul(100)
            .checked_div(self.size)
            .unwrap_or(0)
    }
}

/// Bytes of a bad robot message kept for the page.
pub const BAD_MESSAGE_BYTES: usize = 256;

/// The last robot message the decoder rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BadMessage {
    /// When it arrived (device time).
    pub at: Instant,
    /// Who sent it.
    pub from: Endpoint,
    /// Why it was rejected.
    pub kind: DecodeErrorKind,
    /// Where in the message.
    pub offset: u32,
    /// Its whole length.
    pub len: u32,
    /// Its first bytes (`len.min(BAD_MESSAGE_BYTES)` of them).
    pub head: [u8; BAD_MESSAGE_BYTES],
}

impl BadMessage {
    /// The bytes kept.
    pub fn bytes(&self) -> &[u8] {
        let n = (self.len as usize).min(BAD_MESSAGE_BYTES);
        self.head.get(..n).unwrap_or(&[])
    }
}

/// Why the device last started.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResetCause {
    /// Power was applied (or nothing says otherwise).
    PowerOn,
    /// The reset pin (the NUCLEO's button, or the debug probe).
    Pin,
    /// The supply dipped.
    BrownOut,
    /// The watchdog: the cycle stopped turning.
    Watchdog,
    /// Software asked for it.
    Software,
    /// A HardFault: the handler logged it and reset.
    HardFault,
    /// A panic: the handler logged it and reset.
    Panic,
    /// The host sensor has no resets.
    NotApplicable,
}

impl ResetCause {
    /// As the page and the JSON name it.
    pub const fn name(self) -> &'static str {
        match self {
            ResetCause::PowerOn => "power-on",
            ResetCause::Pin => "reset pin",
            ResetCause::BrownOut => "brown-out",
            ResetCause::Watchdog => "watchdog",
            ResetCause::Software => "software",
            ResetCause::HardFault => "HardFault",
            ResetCause::Panic => "panic",
            ResetCause::NotApplicable => "n/a",
        }
    }
}

/// Longest panic file name kept across a reset.
pub const PANIC_FILE_BYTES: usize = hal_board::reset::FILE_BYTES;

/// Why the device last started and, for a crash, where it happened: kept
/// across the reset in RAM that start-up does not clear.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ResetInfo {
    /// The cause.
    pub cause: ResetCause,
    /// A HardFault's program counter (and link register).
    pub pc: Option<(u32, u32)>,
    /// A panic's file (its last [`PANIC_FILE_BYTES`] bytes) and line.
    pub panic: Option<([u8; PANIC_FILE_BYTES], u8, u32)>,
    /// Starts since power-on (1 for the first).
    pub boots: u32,
}

impl ResetInfo {
    /// What the board found at start-up (`hal_board::reset`).
    pub fn from_board(r: hal_board::reset::Report) -> Self {
        use hal_board::reset::Cause;
        ResetInfo {
            cause: match r.cause {
                Cause::PowerOn => ResetCause::PowerOn,
                Cause::Pin => ResetCause::Pin,
                Cause::BrownOut => ResetCause::BrownOut,
                Cause::Watchdog => ResetCause::Watchdog,
                Cause::Software => ResetCause::Software,
                Cause::HardFault => ResetCause::HardFault,
                Cause::Panic => ResetCause::Panic,
            },
            pc: r.pc,
            panic: r.panic,
            boots: r.boots,
        }
    }

    /// The host sensor's: no resets.
    pub const HOST: ResetInfo = ResetInfo {
        cause: ResetCause::NotApplicable,
        pc: None,
        panic: None,
        boots: 1,
    };

    /// The panic's file name, if it was a panic.
    pub fn panic_file(&self) -> Option<(&[u8], u32)> {
        let (file, len, line) = self.panic.as_ref()?;
        Some((file.get(..usize::from(*len)).unwrap_or(&[]), *line))
    }
}

/// The reply latency, with where it was measured and when its maximum
/// happened.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Latency {
    /// Where it was measured.
    pub source: LatencySource,
    /// Power-of-two buckets in µs, min, max (and when), sum, count.
    pub histogram: Histogram,
}

/// Everything that moves, copied once per response so that every pass
/// over it renders the same bytes.
#[derive(Clone, Copy, Debug)]
pub struct Status {
    /// The cycle's last published turn.
    pub snapshot: Snapshot,
    /// Device time of the copy (the uptime).
    pub now: Instant,
    /// The link.
    pub link: LinkStatus,
    /// The network chip's counters, where the board reads them.
    pub nic: Option<NicFigures>,
    /// The stack's high-water mark, where the board paints it.
    pub stack: Option<StackFigures>,
    /// The reply latency.
    pub latency: Latency,
    /// The last bad robot message.
    pub bad: Option<BadMessage>,
    /// The last events.
    pub events: EventLog,
    /// Why the device last started.
    pub reset: ResetInfo,
}
