//! How the forms say the same things: endpoints, protocols, periods and
//! event names, written once.

use super::events::EventKind;
use super::out::Out;
use rri_firmware::engine::{Config, Endpoint, Pinned};
use rri_firmware::schema::Protocol;

/// `a.b.c.d:port`.
pub fn endpoint(o: &mut dyn Out, e: Endpoint) {
    o.ipv4(e.ip);
    o.str(":");
    o.u32(e.port.into());
}

/// The pinned controller: `a.b.c.d` or `a.b.c.d:port`.
pub fn pinned(o: &mut dyn Out, p: Pinned) {
    o.ipv4(p.ip);
    if let Some(port) = p.port {
        o.str(":");
        o.u32(port.into());
    }
}

/// The channel's protocol as Description.xml spells it.
pub const fn protocol(p: Protocol) -> &'static str {
    match p {
        Protocol::Udp => "UDP",
        Protocol::Tcp => "TCP",
        Protocol::HpUdp => "HpUdp",
    }
}

/// How often device property `index` is sent on its own schedule (ms; 0:
/// only as the reply, or never).
pub fn period_ms(c: &Config, index: usize) -> u32 {
    if index == c.reply && c.send_period_ms > 0 {
        return c.send_period_ms;
    }
    c.periodic
        .iter()
        .find(|p| p.property == index)
        .map_or(0, |p| p.period_ms)
}

/// A machine name for an event's kind.
pub const fn event_name(k: &EventKind) -> &'static str {
    match k {
        EventKind::Started(_) => "started",
        EventKind::State(..) => "state",
        EventKind::TimeOut => "timeout",
        EventKind::MaxLost => "max_lost",
        EventKind::LinkUp(..) => "link_up",
        EventKind::LinkDown => "link_down",
        EventKind::Peer(_) => "peer",
    }
}
