//! The cycle engine (S1–S3, M8): what happens to each robot message, and
//! how the device tracks the health of the link exactly as the controller
//! does. No board, no socket, no heap: the transport hands in
//! `(source, bytes, receive time)` and gets back the reply's length in its
//! own buffer and where to send it, or a counted reason for silence.
//!
//! One cycle: peer check → decode (the property the root names, into a
//! copy of its last good value) → Id accounting and supervision → the
//! application → encode the reply property (the robot's `Id`, `Ts` from the
//! device clock) → back to the transport. Every property the controller
//! sends is answered the same way (M11).

mod config;
mod ids;
mod peer;
mod periodic;
mod state;
mod stats;
mod time;

pub use config::{Config, Periodic};
pub use ids::{ChannelIds, IdEvent, IdTracker};
pub use peer::{Admit, Endpoint, PeerChange, PeerFilter, Pinned};
pub use state::{ErrorCode, SensorState};
pub use stats::{DropReason, FragmentStats, Histogram, Stats};
pub use time::{Clock, Instant, RobotClock};

use crate::properties::{DeviceSet, RobotSet, MAX_PROPERTIES};
use crate::value::Time;
use stats::{add, bump};

/// What the application sees each cycle besides the data.
#[derive(Clone, Copy, Debug)]
pub struct CycleInfo<'a> {
    /// The S2 state as of this call (for an answer, after its Id
    /// accounting).
    pub state: SensorState,
    /// Device time when the application is called.
    pub now: Instant,
    /// The robot message's `Id`; `None` for a periodic send.
    pub robot_id: Option<u32>,
    /// The robot's `Ts` of the last message (T2: its own clock).
    pub robot_ts: Option<Time>,
    /// Device time this robot message arrived; `None` for a periodic send.
    pub received: Option<Instant>,
    /// The last robot message's `Ts` with the device time it arrived: maps
    /// the robot's timestamps (feedback, planned; T2) to device time, where
    /// the samples are. `None` until a message with a `Ts` arrived.
    pub robot_clock: Option<RobotClock>,
    /// The robot property this message carried (its index, see the
    /// generated `RobotProperty`); `None` for a periodic send.
    pub arrived: Option<usize>,
    /// The device property about to be sent (see `DeviceProperty`).
    pub sending: usize,
    /// Every counter so far (this message's reply not yet counted).
    pub stats: &'a Stats,
}

/// The user's sensor code. Called once per sent message with every robot
/// property's last good value and every device property to fill (they
/// keep their values between calls); `info` says which robot property just
/// arrived and which device property goes out. It must return well within
/// the cycle: the engine never waits for anything else, and the sampling
/// itself runs elsewhere (see [`crate::sample`]).
pub trait Application<R, D> {
    /// Fills `device` for the message about to go out, from `robot` and
    /// `info`; whatever it leaves there is encoded as is.
    fn cycle(&mut self, robot: &R, device: &mut D, info: &CycleInfo<'_>);
}

/// An application that leaves the reply as it is (tests, bring-up).
impl<R, D> Application<R, D> for () {
    fn cycle(&mut self, _: &R, _: &mut D, _: &CycleInfo<'_>) {}
}

/// The result of one message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Send the first `len` bytes of the buffer to `to`.
    Reply {
        /// The sender of the robot message (M8: the answer goes back).
        to: Endpoint,
        /// Bytes of the reply at the start of the buffer.
        len: usize,
    },
    /// No answer, for this (counted) reason.
    Dropped(DropReason),
}

/// The engine for a device whose controller sends the properties of `R`
/// and which sends those of `D` (generated as `layout::DeviceEngine`).
pub struct Engine<R: RobotSet, D: DeviceSet> {
    config: Config,
    state: SensorState,
    error: Option<ErrorCode>,
    peers: PeerFilter,
    ids: ChannelIds<MAX_PROPERTIES>,
    stats: Stats,
    /// The last good value of every robot property: a field a message
    /// leaves out keeps this value (M2).
    robot: R,
    /// Decoding target, so a rejected message changes nothing.
    work: R,
    device: D,
    last_rx: Option<Instant>,
    robot_ts: Option<Time>,
    robot_clock: Option<RobotClock>,
    /// When each schedule's next periodic send is due: slot 0 is the reply
    /// property's (`send_period_ms`), slot `k` is `periodic[k - 1]`.
    next_send: [Option<Instant>; SCHEDULES],
    own_id: u32,
    /// When a source other than the peer was last let through to the
    /// decoder ([`STRANGER_INTERVAL_MS`]).
    stranger_at: Option<Instant>,
    /// Per robot property: messages decoded, and when the last came.
    seen: [(PropertySeen, Option<Instant>); MAX_PROPERTIES],
    /// The last decode error, for the diagnostics' "last bad message".
    last_decode_error: Option<crate::codec::DecodeError>,
}

/// What the engine saw of one robot property (M11): how many of its
/// messages decoded, and the time between its last two (the rate the
/// controller's `SiSetCyclic` asked for, as it arrives).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PropertySeen {
    /// Messages of this property decoded.
    pub messages: u32,
    /// Microseconds between its last two messages (0 until two came).
    pub interval_us: u32,
}

/// Once a peer is locked, a message from any other admitted source (a
/// second port of the peer's address, or a new address after `TimeOut`) is
/// decoded at most once per this many ms; the others are dropped
/// ([`DropReason::Throttled`]) before decoding. Such a message may be a
/// controller that reconnected, and one of them is enough to take over;
/// a flood of them would otherwise cost a whole decode each (up to
/// `MAX_RECEIVE_LEN` bytes of the costliest input) and starve the peer's
/// cycle. One robot cycle: at most one stranger's decode per cycle.
pub const STRANGER_INTERVAL_MS: u64 = 4;

/// Periodic schedules: the reply property's and one per `periodic` entry.
const SCHEDULES: usize = MAX_PROPERTIES + 1;

impl<R: RobotSet, D: DeviceSet> Engine<R, D> {
    /// An engine in `UNDEFINED` (S2) until the transport calls
    /// [`Engine::listening`], with no peer and every counter at zero.
    pub fn new(config: Config) -> Self {
        Engine {
            config,
            state: SensorState::Undefined,
            error: None,
            peers: PeerFilter::new(config.controller, config.timeout_ms),
            ids: ChannelIds::new(),
            stats: Stats::default(),
            robot: R::default(),
            work: R::default(),
            device: D::default(),
            last_rx: None,
            robot_ts: None,
            robot_clock: None,
            next_send: [None; SCHEDULES],
            own_id: 0,
            stranger_at: None,
            seen: [(PropertySeen::default(), None); MAX_PROPERTIES],
            last_decode_error: None,
        }
    }

    /// The build-time settings it runs with.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The current S2 state.
    pub fn state(&self) -> SensorState {
        self.state
    }

    /// The error code while in [`SensorState::Error`].
    pub fn error_code(&self) -> Option<ErrorCode> {
        self.error
    }

    /// A copy of every counter.
    pub fn stats(&self) -> Stats {
        self.stats
    }

    /// Every counter, to copy once where it is wanted
    /// ([`crate::snapshot::Published::publish_of`]).
    pub fn stats_ref(&self) -> &Stats {
        &self.stats
    }

    /// The controller being answered (S4); `None` until one spoke.
    pub fn peer(&self) -> Option<Endpoint> {
        self.peers.peer()
    }

    /// Per robot property (by index): messages decoded and the interval
    /// between the last two.
    pub fn robot_seen(&self) -> [PropertySeen; MAX_PROPERTIES] {
        self.seen.map(|(seen, _)| seen)
    }

    /// When the last robot message that decoded arrived.
    pub fn last_message(&self) -> Option<Instant> {
        self.last_rx
    }

    /// The last robot message the decoder rejected: what and where (the
    /// transport keeps its bytes, see `diag`).
    pub fn last_decode_error(&self) -> Option<crate::codec::DecodeError> {
        self.last_decode_error
    }

    /// The last good value of every robot property.
    pub fn robot(&self) -> &R {
        &self.robot
    }

    /// The device properties as the application last left them.
    pub fn device(&self) -> &D {
        &self.device
    }

    /// `true` once the controller has been seen numbering each robot
    /// property on its own instead of in one sequence (M11).
    pub fn ids_per_property(&self) -> bool {
        self.ids.numbers_per_property()
    }

    fn set_state(&mut self, state: SensorState, error: Option<ErrorCode>) {
        if self.state != state || self.error != error {
            bump(&mut self.stats.state_changes);
        }
        self.state = state;
        self.error = error;
    }

    /// S2: the network is up and the device listens (UDP), or a TCP
    /// connection was accepted: `CONNECTED`.
    pub fn listening(&mut self) {
        self.set_state(SensorState::Connected, None);
    }

    /// S2: the transport could not be initialised: `ERROR` 112600.
    pub fn init_failed(&mut self) {
        self.set_state(SensorState::Error, Some(ErrorCode::InitFailed));
    }

    /// S2/M10: the TCP peer closed the connection: `CLOSED`. The next
    /// connection's first message is a reconnecting controller, never
    /// throttled (on TCP the engine only ever sees the served connection).
    pub fn peer_closed(&mut self) {
        self.stranger_at = None;
        bump(&mut self.stats.closed);
        self.set_state(SensorState::Closed, None);
    }

    /// M10: a TCP message longer than the receive buffer; the transport
    /// closes the connection (and then calls [`Engine::peer_closed`]).
    pub fn framing_error(&mut self) {
        bump(&mut self.stats.framing_errors);
    }

    /// The fragment guard's counters as of now (S5): the cycle copies
    /// them in after every turn, so [`Engine::stats`] has every counter.
    pub fn set_fragment_stats(&mut self, fragments: FragmentStats) {
        self.stats.fragments = fragments;
    }

    /// The transport could not send a reply (counted; the cycle goes on).
    pub fn send_failed(&mut self) {
        bump(&mut self.stats.send_errors);
    }

    /// The transport closed a stalled TCP connection (see
    /// [`crate::tcp::StallGuard`]); it then calls [`Engine::peer_closed`].
    pub fn stalled(&mut self) {
        bump(&mut self.stats.stalled_closed);
    }

    /// A datagram longer than the receive buffer arrived (the transport
    /// could not even read it whole): counted as a `TooLong` rejection.
    pub fn datagram_too_long(&mut self) {
        bump(&mut self.stats.received);
        self.stats
            .count_drop(DropReason::Decode(crate::codec::DecodeErrorKind::TooLong));
    }

    /// One robot message from `from`, received at `received`. The reply
    /// (if any) is written to the start of `out`, which should be
    /// `layout::MAX_SEND_LEN` bytes.
    pub fn on_message<A: Application<R, D>, C: Clock>(
        &mut self,
        app: &mut A,
        clock: &C,
        from: Endpoint,
        bytes: &[u8],
        received: Instant,
        out: &mut [u8],
    ) -> Outcome {
        bump(&mut self.stats.received);
        let answer = self
            .handle(from, bytes, received)
            .and_then(|send| self.respond(app, clock, send, out));
        match answer {
            Ok(len) => {
                bump(&mut self.stats.sent);
                bump(&mut self.stats.answered);
                let now = clock.now();
                self.stats
                    .latency
                    .record_at(now.micros_since(received), now.as_micros());
                Outcome::Reply { to: from, len }
            }
            Err(reason) => {
                self.stats.count_drop(reason);
                Outcome::Dropped(reason)
            }
        }
    }

    /// One robot message up to the application's turn: peer check, decode,
    /// Id accounting and supervision; what to answer it with (M8).
    fn handle(
        &mut self,
        from: Endpoint,
        bytes: &[u8],
        received: Instant,
    ) -> Result<Send, DropReason> {
        if !from.is_valid_source() {
            return Err(DropReason::InvalidSource);
        }
        if self.peers.admit(from, received) == Admit::Foreign {
            return Err(DropReason::ForeignSource);
        }
        if self.peers.peer().is_some_and(|peer| peer != from) {
            let interval_us = STRANGER_INTERVAL_MS * 1000;
            if self
                .stranger_at
                .is_some_and(|t| received.micros_since(t) < interval_us)
            {
                return Err(DropReason::Throttled);
            }
            self.stranger_at = Some(received);
        }
        let (property, decoded) = match self.robot.decode(&mut self.work, bytes) {
            Ok(d) => d,
            Err(e) => {
                self.last_decode_error = Some(e);
                return Err(DropReason::Decode(e.kind));
            }
        };
        self.stats.count_tally(&decoded.tally);

        match self.peers.accept(from, received) {
            PeerChange::None => {}
            PeerChange::Locked => {
                bump(&mut self.stats.peer_locked);
                self.ids.reset();
            }
            PeerChange::PortTakeover => {
                // A controller that reconnected starts a new Id sequence.
                bump(&mut self.stats.port_takeovers);
                self.ids.reset();
            }
            PeerChange::Takeover => {
                bump(&mut self.stats.peer_takeovers);
                self.ids.reset();
            }
        }
        self.last_rx = Some(received);
        if let Some((seen, last)) = self.seen.get_mut(property) {
            seen.messages = seen.messages.saturating_add(1);
            if let Some(last) = *last {
                seen.interval_us = u32::try_from(received.micros_since(last)).unwrap_or(u32::MAX);
            }
            *last = Some(received);
        }
        if let Some(ts) = decoded.ts {
            self.robot_ts = Some(ts);
            self.robot_clock = Some(RobotClock { ts, received });
        }
        self.account(property, decoded.id);
        Ok(Send {
            property: self.config.reply,
            id: decoded.id,
            arrived: Some(property),
            received: Some(received),
        })
    }

    /// The application's turn, then `send` (`Ts` now) into `out`: the
    /// common tail of an answer and a periodic send, and the only call
    /// into the application.
    fn respond<A: Application<R, D>, C: Clock>(
        &mut self,
        app: &mut A,
        clock: &C,
        send: Send,
        out: &mut [u8],
    ) -> Result<usize, DropReason> {
        let info = CycleInfo {
            state: self.state,
            now: clock.now(),
            robot_id: send.arrived.map(|_| send.id),
            robot_ts: self.robot_ts,
            received: send.received,
            robot_clock: self.robot_clock,
            arrived: send.arrived,
            sending: send.property,
            stats: &self.stats,
        };
        app.cycle(&self.robot, &mut self.device, &info);
        let e = self
            .device
            .encode(
                send.property,
                send.id,
                clock.now().as_time(),
                self.config.format,
                out,
            )
            .map_err(|_| DropReason::Encode)?;
        add(&mut self.stats.non_finite, e.non_finite.into());
        Ok(e.len)
    }

    /// S3 accounting (over all robot properties, M11) and the S2
    /// transitions a good message drives.
    fn account(&mut self, property: usize, id: u32) {
        let several = R::WIRE_NAMES.len() > 1;
        let burst = match self.ids.observe(several, property, id) {
            IdEvent::First => false,
            IdEvent::Next { wrapped } => {
                if wrapped {
                    bump(&mut self.stats.id_wraps);
                }
                false
            }
            IdEvent::Gap { lost, wrapped } => {
                if wrapped {
                    bump(&mut self.stats.id_wraps);
                }
                add(&mut self.stats.lost, u64::from(lost));
                lost > self.config.max_lost
            }
            IdEvent::Duplicate => {
                bump(&mut self.stats.duplicates);
                false
            }
            IdEvent::Reordered => {
                // A late arrival fills the gap it left: not lost after all.
                bump(&mut self.stats.reordered);
                self.stats.lost = self.stats.lost.saturating_sub(1);
                false
            }
        };
        if burst {
            bump(&mut self.stats.max_lost_exceeded);
        }
        if burst && !self.config.dry_run {
            // S1: more than MaxLost in a row went unanswered. The next good
            // message brings the state back (S2).
            self.set_state(SensorState::Error, Some(ErrorCode::Communication));
        } else {
            self.set_state(SensorState::Operating, None);
        }
    }
}

/// One message to send: which device property, with which `Id`, and the
/// robot property it answers (`None`: a periodic send).
#[derive(Clone, Copy, Debug)]
struct Send {
    property: usize,
    id: u32,
    arrived: Option<usize>,
    /// When the robot message arrived (device clock).
    received: Option<Instant>,
}
