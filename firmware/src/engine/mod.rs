//! The cycle engine (S1–S3, M8): what happens to each robot message, and
//! how the device tracks the health of the link exactly as the controller
//! does. No board, no socket, no heap: the transport hands in
//! `(source, bytes, receive time)` and gets back the reply's length in its
//! own buffer and where to send it, or a counted reason for silence.
//!
//! One cycle: peer check → decode (into a copy of the last good record) →
//! Id accounting and supervision → the application → encode (the robot's
//! `Id`, `Ts` from the device clock) → back to the transport.

mod ids;
mod peer;
mod state;
mod stats;
mod time;

pub use ids::{IdEvent, IdTracker};
pub use peer::{Admit, Endpoint, PeerChange, PeerFilter, Pinned};
pub use state::{ErrorCode, SensorState};
pub use stats::{DropReason, Histogram, Stats};
pub use time::{Clock, Instant};

use crate::codec::{decode, encode};
use crate::schema::{Format, MessageCodec};
use crate::value::Time;
use stats::{add, bump};

/// Build-time settings of the engine (generated as `layout::ENGINE_CONFIG`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Config {
    /// S1 `TimeOut`, also how long a peer must be silent before another
    /// address may take over.
    pub timeout_ms: u32,
    /// S1 `MaxLost`: a gap of more lost ids than this is a communication
    /// error.
    pub max_lost: u32,
    /// S1 `DryRun`: neither `TimeOut` nor `MaxLost` is supervised.
    pub dry_run: bool,
    /// `RRI_CONTROLLER`: only this address is ever answered.
    pub controller: Option<Pinned>,
    /// `RRI_SEND_PERIOD_MS`: periodic sends for one-way streams (0 = off).
    pub send_period_ms: u32,
    pub format: Format,
}

/// What the application sees each cycle besides the data.
#[derive(Clone, Copy, Debug)]
pub struct CycleInfo<'a> {
    pub state: SensorState,
    /// Device time when the application is called.
    pub now: Instant,
    /// The robot message's `Id`; `None` for a periodic send.
    pub robot_id: Option<u32>,
    /// The robot's `Ts` of the last message (T2: its own clock).
    pub robot_ts: Option<Time>,
    pub stats: &'a Stats,
}

/// The user's sensor code. Called once per cycle with the decoded robot
/// data and the reply record to fill (it keeps last cycle's values). It
/// must return well within the cycle: the engine never waits for anything
/// else, and the sampling itself runs elsewhere (see [`crate::sample`]).
pub trait Application<R, T> {
    fn cycle(&mut self, robot: &R, reply: &mut T, info: &CycleInfo<'_>);
}

/// An application that leaves the reply as it is (tests, bring-up).
impl<R, T> Application<R, T> for () {
    fn cycle(&mut self, _: &R, _: &mut T, _: &CycleInfo<'_>) {}
}

/// The result of one message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Send the first `len` bytes of the buffer to `to`.
    Reply { to: Endpoint, len: usize },
    /// No answer, for this (counted) reason.
    Dropped(DropReason),
}

/// The engine for robot messages `Rx` answered with `Tx` (generated as
/// `layout::DeviceEngine`).
pub struct Engine<Rx: MessageCodec, Tx: MessageCodec> {
    config: Config,
    state: SensorState,
    error: Option<ErrorCode>,
    peers: PeerFilter,
    ids: IdTracker,
    stats: Stats,
    /// The last good robot record: a field a message leaves out keeps
    /// this value (M2).
    robot: Rx::Data,
    /// Decoding target, so a rejected message changes nothing.
    work: Rx::Data,
    reply: Tx::Data,
    last_rx: Option<Instant>,
    robot_ts: Option<Time>,
    next_send: Option<Instant>,
    own_id: u32,
    /// When a source other than the peer was last let through to the
    /// decoder ([`STRANGER_INTERVAL_MS`]).
    stranger_at: Option<Instant>,
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

impl<Rx, Tx> Engine<Rx, Tx>
where
    Rx: MessageCodec,
    Tx: MessageCodec,
    Rx::Data: Clone + Default,
    Tx::Data: Default,
{
    pub fn new(config: Config) -> Self {
        Engine {
            config,
            state: SensorState::Undefined,
            error: None,
            peers: PeerFilter::new(config.controller, config.timeout_ms),
            ids: IdTracker::default(),
            stats: Stats::default(),
            robot: Rx::Data::default(),
            work: Rx::Data::default(),
            reply: Tx::Data::default(),
            last_rx: None,
            robot_ts: None,
            next_send: None,
            own_id: 0,
            stranger_at: None,
        }
    }

    pub fn config(&self) -> &Config {
        &self.config
    }

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

    pub fn peer(&self) -> Option<Endpoint> {
        self.peers.peer()
    }

    /// The last good robot record.
    pub fn robot(&self) -> &Rx::Data {
        &self.robot
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
    pub fn on_message<A: Application<Rx::Data, Tx::Data>, C: Clock>(
        &mut self,
        app: &mut A,
        clock: &C,
        from: Endpoint,
        bytes: &[u8],
        received: Instant,
        out: &mut [u8],
    ) -> Outcome {
        bump(&mut self.stats.received);
        match self.handle(app, clock, from, bytes, received, out) {
            Ok(len) => {
                bump(&mut self.stats.sent);
                bump(&mut self.stats.answered);
                self.stats
                    .latency
                    .record(clock.now().micros_since(received));
                Outcome::Reply { to: from, len }
            }
            Err(reason) => {
                self.stats.count_drop(reason);
                Outcome::Dropped(reason)
            }
        }
    }

    fn handle<A: Application<Rx::Data, Tx::Data>, C: Clock>(
        &mut self,
        app: &mut A,
        clock: &C,
        from: Endpoint,
        bytes: &[u8],
        received: Instant,
        out: &mut [u8],
    ) -> Result<usize, DropReason> {
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
        self.work.clone_from(&self.robot);
        let decoded =
            decode::<Rx>(bytes, &mut self.work).map_err(|e| DropReason::Decode(e.kind))?;
        core::mem::swap(&mut self.work, &mut self.robot);
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
        if decoded.ts.is_some() {
            self.robot_ts = decoded.ts;
        }
        self.account(decoded.id);
        self.respond(app, clock, Some(decoded.id), decoded.id, out)
    }

    /// The application's turn, then the reply (Id `id`, `Ts` now) into
    /// `out`: the common tail of an answer and a periodic send.
    fn respond<A: Application<Rx::Data, Tx::Data>, C: Clock>(
        &mut self,
        app: &mut A,
        clock: &C,
        robot_id: Option<u32>,
        id: u32,
        out: &mut [u8],
    ) -> Result<usize, DropReason> {
        let info = CycleInfo {
            state: self.state,
            now: clock.now(),
            robot_id,
            robot_ts: self.robot_ts,
            stats: &self.stats,
        };
        app.cycle(&self.robot, &mut self.reply, &info);
        let e = encode::<Tx>(
            &self.reply,
            id,
            clock.now().as_time(),
            self.config.format,
            out,
        )
        .map_err(|_| DropReason::Encode)?;
        add(&mut self.stats.non_finite, e.non_finite.into());
        Ok(e.len)
    }

    /// S3 accounting and the S2 transitions a good message drives.
    fn account(&mut self, id: u32) {
        let burst = match self.ids.observe(id) {
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
                add(&mut self.stats.lost, lost);
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

    /// Time-driven work, to be called at least every few milliseconds:
    /// the `TimeOut` supervision (S1/S2) and, for one-way streams, the
    /// periodic send. Returns a message to send, if one is due.
    pub fn poll<A: Application<Rx::Data, Tx::Data>, C: Clock>(
        &mut self,
        app: &mut A,
        clock: &C,
        out: &mut [u8],
    ) -> Option<(Endpoint, usize)> {
        let now = clock.now();
        let timeout_us = u64::from(self.config.timeout_ms) * 1000;
        let silent = self
            .last_rx
            .is_some_and(|t| now.micros_since(t) > timeout_us);
        if !self.config.dry_run && self.state == SensorState::Operating && silent {
            bump(&mut self.stats.timeouts);
            self.set_state(SensorState::Error, Some(ErrorCode::Communication));
        }
        self.periodic(app, clock, now, out)
    }

    fn periodic<A: Application<Rx::Data, Tx::Data>, C: Clock>(
        &mut self,
        app: &mut A,
        clock: &C,
        now: Instant,
        out: &mut [u8],
    ) -> Option<(Endpoint, usize)> {
        let period_us = u64::from(self.config.send_period_ms) * 1000;
        if period_us == 0 || matches!(self.state, SensorState::Undefined | SensorState::Closed) {
            return None;
        }
        let to = self.peers.destination()?;
        let due = *self.next_send.get_or_insert(now);
        if now < due {
            return None;
        }
        // The next slot; after a stall, resume from now instead of bursting.
        let next = due.0.saturating_add(period_us);
        self.next_send = Some(Instant(if next <= now.0 {
            now.0 + period_us
        } else {
            next
        }));
        self.own_id = self.own_id.wrapping_add(1);
        match self.respond(app, clock, None, self.own_id, out) {
            Ok(len) => {
                bump(&mut self.stats.sent);
                bump(&mut self.stats.periodic_sent);
                Some((to, len))
            }
            Err(reason) => {
                self.stats.count_drop(reason);
                None
            }
        }
    }
}
