//! Who gets an answer: only the controller, so the device cannot be used
//! to reflect or amplify traffic.

use super::time::Instant;

/// An IPv4 address and port (RRI controllers speak IPv4).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Endpoint {
    /// IPv4 address, most significant byte first.
    pub ip: [u8; 4],
    /// UDP or TCP port.
    pub port: u16,
}

impl Endpoint {
    /// `ip:port`.
    pub const fn new(ip: [u8; 4], port: u16) -> Self {
        Endpoint { ip, port }
    }

    /// Whether a datagram from here can come from a controller at all: a
    /// unicast address (not `0.0.0.0/8`, multicast `224.0.0.0/4`, reserved
    /// `240.0.0.0/4` or the broadcast address) and a port other than 0.
    /// Anything else is spoofed or broken; answering it would send
    /// replies nowhere or to everyone (S4).
    pub const fn is_valid_source(&self) -> bool {
        self.port != 0 && self.ip[0] != 0 && self.ip[0] < 224
    }
}

/// A pinned controller (`RRI_CONTROLLER=ip[:port]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pinned {
    /// The only address ever admitted (S4).
    pub ip: [u8; 4],
    /// Where periodic sends go before the controller has spoken; its own
    /// messages then tell the port.
    pub port: Option<u16>,
}

/// The verdict on one datagram's source, before decoding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Admit {
    /// The current peer.
    Peer,
    /// No peer yet, or the old one was silent for `TimeOut`: may become the
    /// peer if the message is valid.
    Candidate,
    /// Drop it.
    Foreign,
}

/// What [`PeerFilter::accept`] changed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PeerChange {
    /// The peer again, from the same port.
    None,
    /// The first peer.
    Locked,
    /// Same address, new source port: a controller that reconnected.
    PortTakeover,
    /// A new address after the old peer was silent for `TimeOut`.
    Takeover,
}

/// The peer rule: by default the address of the first valid robot message
/// becomes the peer; a new source port from it takes over at once; other
/// addresses are dropped until the peer has been silent for `TimeOut`.
/// With a pinned controller only its address is ever admitted.
#[derive(Clone, Copy, Debug)]
pub struct PeerFilter {
    pinned: Option<Pinned>,
    timeout_us: u64,
    peer: Option<Endpoint>,
    last_heard: Option<Instant>,
}

impl PeerFilter {
    /// No peer yet; `pinned` restricts it to one address, `timeout_ms` is
    /// the S1 `TimeOut` after which another address may take over (S4).
    pub fn new(pinned: Option<Pinned>, timeout_ms: u32) -> Self {
        PeerFilter {
            pinned,
            timeout_us: u64::from(timeout_ms) * 1000,
            peer: None,
            last_heard: None,
        }
    }

    /// The controller being answered; `None` until a valid message
    /// arrived.
    pub fn peer(&self) -> Option<Endpoint> {
        self.peer
    }

    /// Where unsolicited (periodic) sends go: the peer, else a pinned
    /// controller with a port.
    pub fn destination(&self) -> Option<Endpoint> {
        self.peer.or_else(|| {
            self.pinned
                .and_then(|p| p.port.map(|port| Endpoint::new(p.ip, port)))
        })
    }

    fn silent(&self, now: Instant) -> bool {
        self.last_heard
            .is_none_or(|t| now.micros_since(t) >= self.timeout_us)
    }

    /// Checks a source before its datagram is decoded.
    pub fn admit(&self, from: Endpoint, now: Instant) -> Admit {
        if let Some(p) = self.pinned {
            if from.ip != p.ip {
                return Admit::Foreign;
            }
        }
        match self.peer {
            None => Admit::Candidate,
            Some(peer) if peer.ip == from.ip => Admit::Peer,
            Some(_) if self.silent(now) => Admit::Candidate,
            Some(_) => Admit::Foreign,
        }
    }

    /// Records a valid message from an admitted source.
    pub fn accept(&mut self, from: Endpoint, now: Instant) -> PeerChange {
        let change = match self.peer {
            None => PeerChange::Locked,
            Some(peer) if peer == from => PeerChange::None,
            Some(peer) if peer.ip == from.ip => PeerChange::PortTakeover,
            Some(_) => PeerChange::Takeover,
        };
        self.peer = Some(from);
        self.last_heard = Some(now);
        change
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const A: Endpoint = Endpoint::new([192, 168, 125, 1], 40000);
    const B: Endpoint = Endpoint::new([192, 168, 125, 9], 40000);

    fn ms(v: u64) -> Instant {
        Instant::from_millis(v)
    }

    #[test]
    fn first_valid_source_locks_then_foreigners_wait_for_timeout() {
        let mut f = PeerFilter::new(None, 100);
        assert_eq!(f.admit(A, ms(0)), Admit::Candidate);
        assert_eq!(f.accept(A, ms(0)), PeerChange::Locked);
        assert_eq!(f.admit(B, ms(50)), Admit::Foreign);
        assert_eq!(f.admit(B, ms(99)), Admit::Foreign);
        assert_eq!(f.admit(B, ms(100)), Admit::Candidate);
        assert_eq!(f.accept(B, ms(100)), PeerChange::Takeover);
        assert_eq!(f.admit(A, ms(101)), Admit::Foreign);
    }

    #[test]
    fn new_port_from_the_peer_takes_over_at_once() {
        let mut f = PeerFilter::new(None, 100);
        f.accept(A, ms(0));
        let a2 = Endpoint::new(A.ip, 40001);
        assert_eq!(f.admit(a2, ms(1)), Admit::Peer);
        assert_eq!(f.accept(a2, ms(1)), PeerChange::PortTakeover);
        assert_eq!(f.peer(), Some(a2));
    }

    #[test]
    fn pinned_controller_admits_nobody_else_ever() {
        let mut f = PeerFilter::new(
            Some(Pinned {
                ip: A.ip,
                port: Some(3000),
            }),
            100,
        );
        assert_eq!(f.destination(), Some(Endpoint::new(A.ip, 3000)));
        assert_eq!(f.admit(B, ms(0)), Admit::Foreign);
        assert_eq!(f.admit(B, ms(10_000)), Admit::Foreign);
        assert_eq!(f.admit(A, ms(0)), Admit::Candidate);
        f.accept(A, ms(0));
        assert_eq!(f.destination(), Some(A));
    }
}
