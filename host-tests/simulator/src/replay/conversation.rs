//! The controller ↔ device conversation of a capture: the UDP datagrams or
//! the TCP streams (rebuilt in sequence order, M10 framing) between one
//! controller address and the device's address and channel port, as
//! messages in capture order.

use super::capture::{Capture, Segment, Transport};
use crate::wire;
use std::collections::BTreeMap;
use std::net::{Ipv4Addr, SocketAddrV4};

/// Which way a message went.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// Controller → device: a robot message.
    ToDevice,
    /// Device → controller: a reply or a periodic message.
    ToController,
}

/// One RRI message of the conversation.
#[derive(Clone, Debug)]
pub struct Message {
    /// The packet that completed it (Wireshark's number).
    pub number: usize,
    /// When that packet was captured, µs since the Unix epoch.
    pub at_us: u64,
    pub direction: Direction,
    pub payload: Vec<u8>,
}

/// The conversation to replay.
#[derive(Debug)]
pub struct Conversation {
    pub controller: Ipv4Addr,
    pub device: SocketAddrV4,
    pub tcp: bool,
    pub messages: Vec<Message>,
    /// Messages completed by a packet with no timestamp of its own (a
    /// pcapng simple packet block): the first's packet, and how many.
    pub untimed: Option<(usize, usize)>,
}

/// A conversation seen in the file, for the list when the choice is not
/// clear.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Seen {
    pub device: SocketAddrV4,
    pub controller: Ipv4Addr,
    pub tcp: bool,
    pub to_device: usize,
    pub to_controller: usize,
    pub first_us: u64,
    pub last_us: u64,
}

impl std::fmt::Display for Seen {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} ↔ {} over {}: {} packets to {}, {} back, {:.3} s to {:.3} s",
            self.controller,
            self.device,
            if self.tcp { "TCP" } else { "UDP" },
            self.to_device,
            self.device,
            self.to_controller,
            self.first_us as f64 / 1e6,
            self.last_us as f64 / 1e6,
        )
    }
}

/// The conversations between one address and one endpoint in the file
/// (either side may be the device: the one with `port`, or `pick`).
fn conversations(capture: &Capture, port: u16, pick: Option<SocketAddrV4>) -> Vec<Seen> {
    let mut seen: Vec<Seen> = Vec::new();
    for s in &capture.segments {
        let tcp = matches!(s.transport, Transport::Tcp { .. });
        let (device, controller, to_device) = match pick {
            Some(d) if s.to == d => (s.to, *s.from.ip(), true),
            Some(d) if s.from == d => (s.from, *s.to.ip(), false),
            Some(_) => continue,
            None if s.to.port() == port => (s.to, *s.from.ip(), true),
            None if s.from.port() == port => (s.from, *s.to.ip(), false),
            None => continue,
        };
        let i = match seen
            .iter()
            .position(|c| c.device == device && c.controller == controller && c.tcp == tcp)
        {
            Some(i) => i,
            None => {
                seen.push(Seen {
                    device,
                    controller,
                    tcp,
                    to_device: 0,
                    to_controller: 0,
                    first_us: s.at_us,
                    last_us: s.at_us,
                });
                seen.len() - 1
            }
        };
        let c = &mut seen[i];
        if to_device {
            c.to_device += 1;
        } else {
            c.to_controller += 1;
        }
        c.first_us = c.first_us.min(s.at_us);
        c.last_us = c.last_us.max(s.at_us);
    }
    seen
}

/// Every UDP or TCP flow of the file, as "a:p → b:p (n packets)", for an
/// error that names what is there instead.
fn flows(capture: &Capture) -> Vec<String> {
    let mut count: BTreeMap<(SocketAddrV4, SocketAddrV4, bool), usize> = BTreeMap::new();
    for s in &capture.segments {
        let tcp = matches!(s.transport, Transport::Tcp { .. });
        *count.entry((s.from, s.to, tcp)).or_default() += 1;
    }
    count
        .into_iter()
        .map(|((a, b, tcp), n)| {
            format!(
                "{a} → {b} over {} ({n} packets)",
                if tcp { "TCP" } else { "UDP" }
            )
        })
        .collect()
}

/// The conversation to replay: the one on `port` (the GSI folder's channel
/// port), or the one whose device endpoint is `pick`; the reason in one
/// paragraph when there is none, several, or one that cannot be replayed
/// (a packet cut short, a gap in a TCP stream).
pub fn find(
    capture: &Capture,
    port: u16,
    pick: Option<SocketAddrV4>,
) -> Result<Conversation, String> {
    let seen = conversations(capture, port, pick);
    let chosen = match seen.as_slice() {
        [] => {
            let what = match pick {
                Some(p) => format!("no conversation with {p}"),
                None => format!("no conversation on port {port} (the GSI folder's channel port)"),
            };
            let there = flows(capture);
            // Its packets may all be there, cut by the snapshot length.
            let on_port = |c: &&super::capture::Cut| {
                c.ends.is_some_and(|(a, b)| match pick {
                    Some(p) => a == p || b == p,
                    None => a.port() == port || b.port() == port,
                })
            };
            let cut_here: Vec<usize> = capture
                .cut
                .iter()
                .filter(on_port)
                .map(|c| c.number)
                .collect();
            return Err(if let Some(first) = cut_here.first() {
                format!(
                    "{what} whole: its {} packets were cut by the capture's snapshot length (the first: packet {first}); capture again with the whole packets (tcpdump -s 0, tshark -s 0)",
                    cut_here.len()
                )
            } else if let (true, Some(c)) = (there.is_empty(), capture.cut.first()) {
                format!(
                    "{what}: the file holds no whole UDP or TCP packet over IPv4: {} packets were cut by the capture's snapshot length (the first: packet {}); capture again with the whole packets (tcpdump -s 0, tshark -s 0)",
                    capture.cut.len(),
                    c.number
                )
            } else if there.is_empty() {
                format!("{what}: the file holds no UDP or TCP over IPv4 at all")
            } else {
                format!(
                    "{what}; what the file holds (give the device's end with --conversation ADDR:PORT if it is one of these, or build for its port):\n  {}",
                    there.into_iter().take(20).collect::<Vec<_>>().join("\n  ")
                )
            });
        }
        [one] => one.clone(),
        several => {
            return Err(format!(
                "{} conversations on port {port}; choose one with --conversation ADDR:PORT (the device's end):\n  {}",
                several.len(),
                several
                    .iter()
                    .map(Seen::to_string)
                    .collect::<Vec<_>>()
                    .join("\n  ")
            ))
        }
    };
    let ours = |s: &Segment| {
        let tcp = matches!(s.transport, Transport::Tcp { .. });
        tcp == chosen.tcp
            && ((s.to == chosen.device && *s.from.ip() == chosen.controller)
                || (s.from == chosen.device && *s.to.ip() == chosen.controller))
    };
    // A cut packet between the two hosts (its ports unread: a fragment, or
    // cut inside its transport header) may be the conversation's too.
    let between = |c: &&super::capture::Cut| match (c.ends, c.hosts) {
        (Some((a, b)), _) => {
            (a == chosen.device && *b.ip() == chosen.controller)
                || (b == chosen.device && *a.ip() == chosen.controller)
        }
        (None, Some((a, b))) => {
            (a == *chosen.device.ip() && b == chosen.controller)
                || (b == *chosen.device.ip() && a == chosen.controller)
        }
        (None, None) => false,
    };
    if let Some(cut) = capture.cut.iter().find(between) {
        return Err(format!(
            "packet {} of the conversation was cut by the capture's snapshot length: capture again with the whole packets (tcpdump -s 0, tshark -s 0)",
            cut.number
        ));
    }
    let direction = |s: &Segment| {
        if s.to == chosen.device {
            Direction::ToDevice
        } else {
            Direction::ToController
        }
    };
    let mut messages: Vec<Message> = Vec::new();
    if chosen.tcp {
        // One stream per connection and direction.
        let mut streams: BTreeMap<(SocketAddrV4, SocketAddrV4), Vec<&Segment>> = BTreeMap::new();
        for s in capture.segments.iter().filter(|s| ours(s)) {
            streams.entry((s.from, s.to)).or_default().push(s);
        }
        for ((from, to), segments) in streams {
            let d = direction(segments[0]);
            for (number, at_us, payload) in
                super::tcp::messages(&segments).map_err(|e| format!("TCP {from} → {to}: {e}"))?
            {
                messages.push(Message {
                    number,
                    at_us,
                    direction: d,
                    payload,
                });
            }
        }
        messages.sort_by_key(|m| (m.number, m.at_us));
    } else {
        for s in capture.segments.iter().filter(|s| ours(s)) {
            messages.push(Message {
                number: s.number,
                at_us: s.at_us,
                direction: direction(s),
                payload: s.payload.clone(),
            });
        }
    }
    let untimed: Vec<usize> = messages
        .iter()
        .map(|m| m.number)
        .filter(|n| capture.untimed.binary_search(n).is_ok())
        .collect();
    Ok(Conversation {
        controller: chosen.controller,
        device: chosen.device,
        tcp: chosen.tcp,
        messages,
        untimed: untimed.first().map(|&f| (f, untimed.len())),
    })
}

/// A robot message's `Id` (its root's attribute), if it has one.
pub fn message_id(bytes: &[u8]) -> Option<u32> {
    let text = std::str::from_utf8(bytes).ok()?;
    let root = wire::tree(text).ok()?;
    root.attrs
        .iter()
        .find(|(k, _)| k == "Id")
        .and_then(|(_, v)| v.trim().parse().ok())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn udp(number: usize, from: ([u8; 4], u16), to: ([u8; 4], u16), payload: &str) -> Segment {
        Segment {
            number,
            at_us: number as u64 * 4_000,
            from: SocketAddrV4::new(from.0.into(), from.1),
            to: SocketAddrV4::new(to.0.into(), to.1),
            transport: Transport::Udp,
            payload: payload.as_bytes().to_vec(),
        }
    }

    fn capture(segments: Vec<Segment>) -> Capture {
        Capture {
            packets: segments.len(),
            segments,
            ..Capture::default()
        }
    }

    const ROBOT: ([u8; 4], u16) = ([10, 0, 0, 1], 40_000);
    const DEVICE: ([u8; 4], u16) = ([10, 0, 0, 2], 3002);

    #[test]
    fn the_conversation_on_the_channel_port_is_found_among_other_traffic() {
        let c = capture(vec![
            udp(1, ([10, 0, 0, 9], 53), ([10, 0, 0, 1], 5353), "dns"),
            udp(2, ROBOT, DEVICE, "<RobData Id=\"1\"/>"),
            udp(3, DEVICE, ROBOT, "<SensData Id=\"1\"/>"),
        ]);
        let conv = find(&c, 3002, None).unwrap();
        assert_eq!(conv.device, SocketAddrV4::new([10, 0, 0, 2].into(), 3002));
        assert_eq!(
            conv.messages
                .iter()
                .map(|m| (m.number, m.direction))
                .collect::<Vec<_>>(),
            vec![(2, Direction::ToDevice), (3, Direction::ToController)]
        );
    }

    #[test]
    fn several_conversations_are_listed_and_one_is_chosen_by_its_device_end() {
        let c = capture(vec![
            udp(1, ROBOT, DEVICE, "a"),
            udp(2, ([10, 0, 1, 1], 40_000), ([10, 0, 1, 2], 3002), "b"),
        ]);
        let e = find(&c, 3002, None).unwrap_err();
        assert!(
            e.contains("2 conversations on port 3002") && e.contains("--conversation"),
            "{e}"
        );
        assert!(
            e.contains("10.0.1.1 ↔ 10.0.1.2:3002 over UDP: 1 packets"),
            "{e}"
        );
        let pick = SocketAddrV4::new([10, 0, 1, 2].into(), 3002);
        assert_eq!(find(&c, 3002, Some(pick)).unwrap().messages[0].number, 2);
    }

    #[test]
    fn none_on_the_port_names_what_is_there() {
        let c = capture(vec![udp(1, ROBOT, ([10, 0, 0, 2], 4000), "x")]);
        let e = find(&c, 3002, None).unwrap_err();
        assert!(
            e.contains("no conversation on port 3002") && e.contains("10.0.0.2:4000"),
            "{e}"
        );
        let empty = find(&capture(Vec::new()), 3002, None).unwrap_err();
        assert!(empty.contains("no UDP or TCP over IPv4 at all"), "{empty}");
    }

    #[test]
    fn a_packet_of_the_conversation_cut_short_is_named() {
        let mut c = capture(vec![udp(1, ROBOT, DEVICE, "a")]);
        c.cut.push(super::super::capture::Cut {
            number: 7,
            ends: Some((
                SocketAddrV4::new(ROBOT.0.into(), ROBOT.1),
                SocketAddrV4::new(DEVICE.0.into(), DEVICE.1),
            )),
            hosts: Some((ROBOT.0.into(), DEVICE.0.into())),
        });
        let e = find(&c, 3002, None).unwrap_err();
        assert!(
            e.contains("packet 7") && e.contains("snapshot length"),
            "{e}"
        );
    }
}
