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

/// The network link and the chip's own receive counters: the board's
/// types, as the board reads them (the host sensor fills them in too).
pub use hal_board::{LinkInfo, NicCounters};

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
    /// All zero: what [`super::LastBad`] holds before the first.
    pub const ZERO: BadMessage = BadMessage {
        at: Instant(0),
        from: Endpoint::new([0; 4], 0),
        kind: DecodeErrorKind::TooLong,
        offset: 0,
        len: 0,
        head: [0; BAD_MESSAGE_BYTES],
    };

    /// The bytes kept.
    pub fn bytes(&self) -> &[u8] {
        let n = (self.len as usize).min(BAD_MESSAGE_BYTES);
        self.head.get(..n).unwrap_or(&[])
    }
}

/// Why the device last started and, for a crash, where it happened
/// (kept across the reset in RAM that start-up does not clear): the
/// board's own report (`hal_board::reset`), named for what it is here.
pub use hal_board::reset::{
    Cause as ResetCause, Report as ResetInfo, FILE_BYTES as PANIC_FILE_BYTES,
};

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
    pub link: LinkInfo,
    /// The network chip's counters, where the board reads them.
    pub nic: Option<NicCounters>,
    /// The stack's high-water mark, where the board paints it.
    pub stack: Option<StackFigures>,
    /// The reply latency.
    pub latency: Latency,
    /// The last bad robot message.
    pub bad: Option<BadMessage>,
    /// The last events.
    pub events: EventLog,
    /// Why the device last started (`None`: the host sensor, which has no
    /// resets).
    pub reset: Option<ResetInfo>,
    /// Updates, where the firmware takes them (`None`: built without).
    pub update: Option<crate::update::Update>,
}
