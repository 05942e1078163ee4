//! The UDP side of the in-memory Ethernet: the boards' UDP cycle task
//! behind the fragment guard they all run (S5), real Ethernet/ARP/IPv4/UDP
//! frames from any sender, IPv4 fragments of them, and the robot's side of
//! the device's frames.

use super::{net_config, poll_once, Frames, MemDriver, DEVICE_MAC, ROBOT_IP, ROBOT_MAC};
use embassy_net::StackResources;
use embassy_time::{Duration, MockDriver};
use host_tests::layouts::anydevice as layout;
use rri_firmware::engine::{Application, Engine};
use rri_firmware::fragments::guard::FragmentGuard;
use rri_firmware::fragments::{buffer_len, Channel, Link, Reassembler};
use rri_firmware::net::{Cycle, EmbassyClock, UdpBuffers};
use smoltcp::wire::{
    ArpOperation, ArpPacket, ArpRepr, EthernetAddress, EthernetFrame, EthernetProtocol,
    EthernetRepr, IpProtocol, Ipv4Address, Ipv4Packet, Ipv4Repr, UdpPacket, UdpRepr,
};
use std::pin::pin;

/// The robot simulator's source port.
pub const ROBOT_PORT: u16 = 6510;
/// The reassembly buffers of the manual's layout.
pub const BUF: usize = buffer_len(layout::MAX_RECEIVE_LEN);

pub fn device_ip() -> [u8; 4] {
    layout::NETWORK_IPV4.expect("the example's address is IPv4")
}

/// A UDP datagram from `from` (address, port) to the device's channel
/// port, as a whole Ethernet frame (checksums included).
pub fn udp_frame(from: ([u8; 4], u16), payload: &[u8]) -> Vec<u8> {
    let udp = UdpRepr {
        src_port: from.1,
        dst_port: layout::CHANNEL_PORT,
    };
    let ip = Ipv4Repr {
        src_addr: Ipv4Address::from(from.0),
        dst_addr: Ipv4Address::from(device_ip()),
        next_header: IpProtocol::Udp,
        payload_len: udp.header_len() + payload.len(),
        hop_limit: 64,
    };
    let eth = EthernetRepr {
        src_addr: EthernetAddress(ROBOT_MAC),
        dst_addr: EthernetAddress(DEVICE_MAC),
        ethertype: EthernetProtocol::Ipv4,
    };
    let mut frame = vec![0; eth.buffer_len() + ip.buffer_len() + udp.header_len() + payload.len()];
    let mut e = EthernetFrame::new_unchecked(&mut frame);
    eth.emit(&mut e);
    let mut p = Ipv4Packet::new_unchecked(e.payload_mut());
    ip.emit(&mut p, &smoltcp::phy::ChecksumCapabilities::default());
    let mut u = UdpPacket::new_unchecked(p.payload_mut());
    udp.emit(
        &mut u,
        &ip.src_addr.into(),
        &ip.dst_addr.into(),
        payload.len(),
        |buf| buf.copy_from_slice(payload),
        &smoltcp::phy::ChecksumCapabilities::default(),
    );
    frame
}

/// A robot datagram as a whole frame.
pub fn robot_frame(payload: &[u8]) -> Vec<u8> {
    udp_frame((ROBOT_IP, ROBOT_PORT), payload)
}

/// A UDP datagram from `from` cut into IPv4 fragments of at most
/// `fragment` payload bytes (a multiple of 8), as whole Ethernet frames,
/// first fragment first.
pub fn udp_fragments(
    from: ([u8; 4], u16),
    payload: &[u8],
    fragment: usize,
    ident: u16,
) -> Vec<Vec<u8>> {
    // The whole datagram first (checksums included), then cut its IP payload.
    let whole = udp_frame(from, payload);
    let eth = EthernetFrame::new_checked(&whole[..]).unwrap();
    let ip = Ipv4Packet::new_checked(eth.payload()).unwrap();
    let udp_bytes = ip.payload().to_vec();
    let mut frames = Vec::new();
    for (i, chunk) in udp_bytes.chunks(fragment).enumerate() {
        let offset = i * fragment;
        let more = offset + chunk.len() < udp_bytes.len();
        let mut frame = vec![0u8; 14 + 20 + chunk.len()];
        frame[..14].copy_from_slice(&whole[..14]);
        frame[14..34].copy_from_slice(&whole[14..34]);
        let mut p = Ipv4Packet::new_unchecked(&mut frame[14..]);
        p.set_total_len((20 + chunk.len()) as u16);
        p.set_ident(ident);
        p.clear_flags();
        p.set_more_frags(more);
        p.set_frag_offset(offset as u16);
        p.payload_mut().copy_from_slice(chunk);
        p.fill_checksum();
        frames.push(frame);
    }
    frames
}

/// The robot's fragmented datagram.
pub fn robot_fragments(payload: &[u8], fragment: usize, ident: u16) -> Vec<Vec<u8>> {
    udp_fragments((ROBOT_IP, ROBOT_PORT), payload, fragment, ident)
}

/// The manual's robot message with Id `id`, padded with whitespace to
/// `len` bytes (3,557 = `MAX_RECEIVE_LEN`: three fragments).
pub fn padded_robdata(id: u32, len: usize) -> Vec<u8> {
    let head = format!(
        r#"<RobData Id="{id}" Ts="1.202"><RobMode>Auto</RobMode><P_act X="1620.0" Y="0" Z="300" Rx="180" Ry="0" Rz="0"/>"#
    );
    let tail = "</RobData>";
    let pad = len - head.len() - tail.len();
    format!("{head}{}{tail}", " ".repeat(pad)).into_bytes()
}

/// The robot's side of a frame from the device: answers ARP, returns UDP
/// payloads addressed to the robot (checked on every layer), whole or
/// reassembled through `reassembly`.
pub fn robot_receive(
    frame: &[u8],
    to_device: &Frames,
    reassembly: &mut Reassembly,
) -> Option<Vec<u8>> {
    let eth = EthernetFrame::new_checked(frame).expect("valid Ethernet frame");
    match eth.ethertype() {
        EthernetProtocol::Arp => {
            let arp = ArpRepr::parse(&ArpPacket::new_checked(eth.payload()).expect("ARP"))
                .expect("ARP repr");
            if let ArpRepr::EthernetIpv4 {
                operation: ArpOperation::Request,
                source_hardware_addr,
                source_protocol_addr,
                target_protocol_addr,
                ..
            } = arp
            {
                assert_eq!(target_protocol_addr, Ipv4Address::from(ROBOT_IP));
                let reply = ArpRepr::EthernetIpv4 {
                    operation: ArpOperation::Reply,
                    source_hardware_addr: EthernetAddress(ROBOT_MAC),
                    source_protocol_addr: Ipv4Address::from(ROBOT_IP),
                    target_hardware_addr: source_hardware_addr,
                    target_protocol_addr: source_protocol_addr,
                };
                let eth_repr = EthernetRepr {
                    src_addr: EthernetAddress(ROBOT_MAC),
                    dst_addr: source_hardware_addr,
                    ethertype: EthernetProtocol::Arp,
                };
                let mut out = vec![0; eth_repr.buffer_len() + reply.buffer_len()];
                let mut e = EthernetFrame::new_unchecked(&mut out);
                eth_repr.emit(&mut e);
                reply.emit(&mut ArpPacket::new_unchecked(e.payload_mut()));
                to_device.borrow_mut().push_back(out);
            }
            None
        }
        EthernetProtocol::Ipv4 => reassembly.add(frame).map(|(payload, _)| payload),
        other => panic!("unexpected frame type {other:?}"),
    }
}

/// Puts IPv4 fragments from the device back together: the UDP payload
/// once the last fragment is in, and how many frames it took (1 for a
/// datagram in one frame).
#[derive(Default)]
pub struct Reassembly {
    parts: Vec<(usize, Vec<u8>)>,
    total: Option<usize>,
}

impl Reassembly {
    pub fn add(&mut self, frame: &[u8]) -> Option<(Vec<u8>, usize)> {
        let eth = EthernetFrame::new_checked(frame).expect("Ethernet");
        assert_eq!(eth.dst_addr(), EthernetAddress(ROBOT_MAC));
        let ip = Ipv4Packet::new_checked(eth.payload()).expect("IPv4");
        assert!(ip.verify_checksum(), "IPv4 checksum of every fragment");
        assert_eq!(ip.src_addr(), Ipv4Address::from(device_ip()));
        assert_eq!(ip.dst_addr(), Ipv4Address::from(ROBOT_IP));
        assert_eq!(ip.next_header(), IpProtocol::Udp);
        let offset = ip.frag_offset() as usize;
        if !ip.more_frags() {
            self.total = Some(offset + ip.payload().len());
        }
        self.parts.push((offset, ip.payload().to_vec()));
        let total = self.total?;
        if self.parts.iter().map(|p| p.1.len()).sum::<usize>() < total {
            return None;
        }
        let mut parts = std::mem::take(&mut self.parts);
        self.total = None;
        parts.sort_by_key(|p| p.0);
        let udp_bytes: Vec<u8> = parts.iter().flat_map(|p| p.1.clone()).collect();
        let udp = UdpPacket::new_checked(&udp_bytes[..]).expect("UDP");
        assert!(
            udp.verify_checksum(
                &Ipv4Address::from(device_ip()).into(),
                &Ipv4Address::from(ROBOT_IP).into()
            ),
            "UDP checksum over the reassembled datagram"
        );
        assert_eq!(udp.src_port(), layout::CHANNEL_PORT);
        assert_eq!(udp.dst_port(), ROBOT_PORT);
        Some((udp.payload().to_vec(), parts.len()))
    }
}

/// The device as the boards run it: the UDP cycle task (`Cycle::udp`) with
/// `engine` and `app` on an embassy-net stack whose driver is the
/// in-memory Ethernet behind the fragment guard (S5), over a fresh network
/// (the mock clock reset), link up and socket bound. `body` gets `step(n)`,
/// which polls the stack and the task `n` times, 10 µs of mock time each,
/// the frames to the device and from it, and the link the guard and the
/// cycle share.
pub fn with_udp_device<A>(
    engine: &mut Engine<layout::RobotProperties, layout::DeviceProperties>,
    app: &mut A,
    body: impl FnOnce(&mut dyn FnMut(usize), &Frames, &Frames, &Link),
) where
    A: Application<layout::RobotProperties, layout::DeviceProperties>,
{
    let _clock = super::mock_clock();
    MockDriver::get().reset();
    let (driver, _, to_device, from_device) = MemDriver::pair();
    let link = Link::new();
    let mut reassembler = Box::new(Reassembler::<BUF>::new());
    let channel = Channel {
        device: device_ip(),
        port: layout::CHANNEL_PORT,
    };
    let guard = FragmentGuard::new(driver, &mut reassembler, &link, channel);
    let mut resources = StackResources::<2>::new();
    let (stack, mut runner) =
        embassy_net::new(guard, net_config(device_ip()), &mut resources, 0x5eed);
    let mut buffers = UdpBuffers::<{ layout::MAX_RECEIVE_LEN }, { layout::MAX_SEND_LEN }>::new();
    let mut monitor = ();
    // As the boards run it: passed over while the cycle works on a message.
    let mut net = pin!(rri_firmware::fragments::guard::run_gated(
        &link,
        runner.run()
    ));
    let cycle = Cycle {
        stack,
        port: layout::CHANNEL_PORT,
        engine,
        app,
        clock: &EmbassyClock,
        monitor: &mut monitor,
        link: &link,
    };
    let mut task = pin!(cycle.udp(&mut buffers));
    let mut step = |n: usize| {
        for _ in 0..n {
            assert!(poll_once(net.as_mut()).is_pending());
            assert!(poll_once(task.as_mut()).is_pending());
            MockDriver::get().advance(Duration::from_micros(10));
        }
    };
    step(50); // link up, socket bound
    body(&mut step, &to_device, &from_device, &link);
}

/// Steps the device until the robot has a reply (up to `max_steps` of
/// 10 µs), answering ARP; the reply's payload, how many frames it took and
/// the steps it took.
pub fn await_reply(
    step: &mut dyn FnMut(usize),
    to_device: &Frames,
    from_device: &Frames,
    max_steps: usize,
) -> Option<(Vec<u8>, usize, usize)> {
    let mut reassembly = Reassembly::default();
    for n in 1..=max_steps {
        step(1);
        let frames: Vec<Vec<u8>> = from_device.borrow_mut().drain(..).collect();
        let mut reply = None;
        for f in frames {
            let eth = EthernetFrame::new_checked(&f[..]).expect("Ethernet");
            if eth.ethertype() == EthernetProtocol::Arp {
                let _ = robot_receive(&f, to_device, &mut reassembly);
            } else if let Some((payload, frames)) = reassembly.add(&f) {
                assert!(reply.is_none(), "one reply per message");
                reply = Some((payload, frames, n));
            }
        }
        if reply.is_some() {
            return reply;
        }
    }
    None
}
