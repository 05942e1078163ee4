//! End to end in one process: an embassy-net (smoltcp) stack over an
//! in-memory Ethernet driver, the boards' own UDP cycle task
//! (`rri_firmware::net::Cycle::udp`) with the demo application, and a
//! simulated robot that exchanges real Ethernet/ARP/IPv4/UDP frames with it:
//! 1,000 cycles, every reply checked (M8 Id echo, root, decodable fields).
//!
//! Time is embassy-time's mock clock, advanced by the test: deterministic.
//! TCP (`Cycle::tcp`) has its own file, `net_tcp.rs`.

mod memnet;

use embassy_net::StackResources;
use embassy_time::{Duration, MockDriver};
use host_tests::layouts::anydevice::{self as layout, SensDataMessage};
use rri_firmware::codec::decode;
use rri_firmware::engine::{Clock, Engine, SensorState};
use rri_firmware::net::{Cycle, EmbassyClock, UdpBuffers};
use rri_firmware::sample::SampleCell;
use rri_firmware::sensor::{Ring, Sampler, SensorApp, Simulated};
use rri_firmware::sensors::distance::Distance;
use smoltcp::wire::{
    ArpOperation, ArpPacket, ArpRepr, EthernetAddress, EthernetFrame, EthernetProtocol,
    EthernetRepr, IpProtocol, Ipv4Address, Ipv4Packet, Ipv4Repr, UdpPacket, UdpRepr,
};
use std::pin::pin;
use std::rc::Rc;

use memnet::{net_config, poll_once, Frames, MemDriver, DEVICE_MAC, ROBOT_IP, ROBOT_MAC};

const ROBOT_PORT: u16 = 6510;

/// A UDP datagram from the robot to the device, as a whole Ethernet frame.
fn robot_frame(device_ip: [u8; 4], payload: &[u8]) -> Vec<u8> {
    let udp = UdpRepr {
        src_port: ROBOT_PORT,
        dst_port: layout::CHANNEL_PORT,
    };
    let ip = Ipv4Repr {
        src_addr: Ipv4Address::from(ROBOT_IP),
        dst_addr: Ipv4Address::from(device_ip),
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

/// The robot's side of a frame from the device: answers ARP, returns UDP
/// payloads addressed to the robot (checked on every layer).
fn robot_receive(frame: &[u8], device_ip: [u8; 4], to_device: &Frames) -> Option<Vec<u8>> {
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
        EthernetProtocol::Ipv4 => {
            assert_eq!(eth.dst_addr(), EthernetAddress(ROBOT_MAC));
            let ip = Ipv4Packet::new_checked(eth.payload()).expect("IPv4");
            assert!(ip.verify_checksum(), "IPv4 checksum");
            assert_eq!(ip.src_addr(), Ipv4Address::from(device_ip));
            assert_eq!(ip.dst_addr(), Ipv4Address::from(ROBOT_IP));
            assert_eq!(ip.next_header(), IpProtocol::Udp);
            let udp = UdpPacket::new_checked(ip.payload()).expect("UDP");
            assert!(
                udp.verify_checksum(&ip.src_addr().into(), &ip.dst_addr().into()),
                "UDP checksum"
            );
            assert_eq!(udp.src_port(), layout::CHANNEL_PORT);
            assert_eq!(udp.dst_port(), ROBOT_PORT);
            Some(udp.payload().to_vec())
        }
        other => panic!("unexpected frame type {other:?}"),
    }
}

/// The boards' UDP cycle task (`Cycle::udp`) with `engine` and `app` on an
/// embassy-net stack over a fresh in-memory Ethernet (the mock clock
/// reset), with the link up and the socket bound. `body` gets `step(n)`,
/// which polls the stack and the task `n` times, 10 µs of mock time each,
/// and the frames to the device and from it.
fn with_udp_device<A>(
    engine: &mut Engine<layout::RobotProperties, layout::DeviceProperties>,
    app: &mut A,
    body: impl FnOnce(&mut dyn FnMut(usize), &Frames, &Frames),
) where
    A: rri_firmware::engine::Application<layout::RobotProperties, layout::DeviceProperties>,
{
    let _clock = memnet::mock_clock();
    MockDriver::get().reset();
    let to_device: Frames = Rc::default();
    let from_device: Frames = Rc::default();
    let driver = MemDriver {
        to_device: to_device.clone(),
        from_device: from_device.clone(),
        mac: DEVICE_MAC,
    };
    let device_ip = layout::NETWORK_IPV4.expect("the example's address is IPv4");
    let mut resources = StackResources::<2>::new();
    let (stack, mut runner) =
        embassy_net::new(driver, net_config(device_ip), &mut resources, 0x5eed);
    let mut buffers = UdpBuffers::<{ layout::MAX_RECEIVE_LEN }, { layout::MAX_SEND_LEN }>::new();
    let mut monitor = ();
    let mut net = pin!(runner.run());
    let cycle = Cycle {
        stack,
        port: layout::CHANNEL_PORT,
        engine,
        app,
        clock: &EmbassyClock,
        monitor: &mut monitor,
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
    body(&mut step, &to_device, &from_device);
}

#[test]
fn thousand_cycles_over_embassy_net_with_real_frames() {
    let device_ip = layout::NETWORK_IPV4.expect("the example's address is IPv4");
    let cell = SampleCell::new(Ring::EMPTY);
    let (writer, reader) = cell.split().expect("split");
    type Robot = layout::RobotProperties;
    type Device = layout::DeviceProperties;
    let mut sampler = Sampler::<Distance, Robot, Device>::new(writer);
    let mut app = SensorApp::<Distance, Robot, Device>::new(reader);
    let mut engine: Engine<layout::RobotProperties, layout::DeviceProperties> =
        Engine::new(layout::ENGINE_CONFIG);
    let clock = EmbassyClock;
    with_udp_device(&mut engine, &mut app, |step, to_device, from_device| {
        let mut replies = 0;
        for cycle in 0..1000u32 {
            // The sampler takes a sample, then the robot's message arrives.
            sampler.step(&mut Simulated, clock.now());
            let id = 1_000 + cycle;
            let x = 400.0 + cycle as f32 * 0.5;
            let request = format!(
                r#"<RobData Id="{id}" Ts="{}.{:03}"><RobMode>Auto</RobMode><P_act X="{x}" Y="0" Z="300" Rx="180" Ry="0" Rz="0"/></RobData>"#,
                cycle * 4 / 1000,
                cycle * 4 % 1000
            );
            to_device
                .borrow_mut()
                .push_back(robot_frame(device_ip, request.as_bytes()));
            let mut reply = None;
            for _ in 0..400 {
                step(1);
                let frames: Vec<Vec<u8>> = from_device.borrow_mut().drain(..).collect();
                for f in frames {
                    if let Some(payload) = robot_receive(&f, device_ip, to_device) {
                        assert!(reply.is_none(), "one reply per message");
                        reply = Some(payload);
                    }
                }
                if reply.is_some() {
                    break;
                }
            }
            let payload = reply.unwrap_or_else(|| panic!("no reply to cycle {cycle}"));
            assert!(payload.len() <= layout::MAX_SEND_LEN);
            let mut data = layout::SensorData::default();
            let d = decode::<SensDataMessage>(&payload, &mut data)
                .unwrap_or_else(|e| panic!("reply {cycle} does not decode: {e:?}"));
            assert_eq!(d.id, id, "M8: the reply carries the robot's Id");
            assert_eq!(
                d.tally,
                Default::default(),
                "every field present and well-formed"
            );
            assert_eq!(data.error_string.as_str(), "OK");
            // The demo projects the reading along the tool axis: Rx=180
            // points down, so z = 300 - distance.
            let distance = data.application_data[0];
            assert!((129.0..=171.0).contains(&distance), "distance {distance}");
            assert!(
                (data.application_data[1] - x).abs() < 0.01,
                "x {}",
                data.application_data[1]
            );
            assert!((data.application_data[3] - (300.0 - distance)).abs() < 0.05);
            replies += 1;
            // The rest of the 4 ms cycle.
            MockDriver::get().advance(Duration::from_micros(3000));
        }
        assert_eq!(replies, 1000);
    });
    let s = engine.stats();
    assert_eq!(
        (
            s.received,
            s.answered,
            s.lost,
            s.duplicates,
            s.dropped_decode
        ),
        (1000, 1000, 0, 0, 0)
    );
    assert_eq!(engine.state(), SensorState::Operating);
    assert_eq!(s.latency.count, 1000);
    println!(
        "e2e: 1000 cycles, latency (mock µs) min {} max {} mean {:.1}",
        s.latency.min_us,
        s.latency.max_us,
        s.latency.total_us as f64 / 1000.0
    );
}

/// Fills the reply with its widest values. The manual's reply can reach
/// 1,473 bytes only with a negative `Ts`, which a device clock never has:
/// with a real clock its longest reply is 1,472 bytes, one frame of UDP
/// payload, so replies of this layout never need fragmenting (smoltcp's
/// fragmentation is on, and sized by `net::UdpBuffers`, for layouts whose
/// replies do).
struct WidestReply;

impl rri_firmware::engine::Application<layout::RobotProperties, layout::DeviceProperties>
    for WidestReply
{
    fn cycle(
        &mut self,
        _: &layout::RobotProperties,
        device: &mut layout::DeviceProperties,
        _: &rri_firmware::engine::CycleInfo<'_>,
    ) {
        let reply = &mut device.sens_data;
        reply.error_string.clear();
        while reply.error_string.push('"').is_ok() {}
        reply.application_data = [-f32::MAX; 18];
    }
}

/// A UDP datagram from the robot cut into IPv4 fragments of at most
/// `fragment` payload bytes (a multiple of 8), as whole Ethernet frames.
fn robot_fragments(
    device_ip: [u8; 4],
    payload: &[u8],
    fragment: usize,
    ident: u16,
) -> Vec<Vec<u8>> {
    // The whole datagram first (checksums included), then cut its IP payload.
    let whole = robot_frame(device_ip, payload);
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

/// Puts IPv4 fragments from the device back together: the UDP payload
/// once the last fragment is in, and how many frames it took.
#[derive(Default)]
struct Reassembly {
    parts: Vec<(usize, Vec<u8>)>,
    total: Option<usize>,
}

impl Reassembly {
    fn add(&mut self, frame: &[u8], device_ip: [u8; 4]) -> Option<(Vec<u8>, usize)> {
        let eth = EthernetFrame::new_checked(frame).expect("Ethernet");
        if eth.ethertype() != EthernetProtocol::Ipv4 {
            return None;
        }
        let ip = Ipv4Packet::new_checked(eth.payload()).expect("IPv4");
        assert!(ip.verify_checksum(), "IPv4 checksum of every fragment");
        assert_eq!(ip.src_addr(), Ipv4Address::from(device_ip));
        let offset = ip.frag_offset() as usize;
        if !ip.more_frags() {
            self.total = Some(offset + ip.payload().len());
        }
        self.parts.push((offset, ip.payload().to_vec()));
        let total = self.total?;
        if self.parts.iter().map(|p| p.1.len()).sum::<usize>() < total {
            return None;
        }
        self.parts.sort_by_key(|p| p.0);
        let udp_bytes: Vec<u8> = self.parts.iter().flat_map(|p| p.1.clone()).collect();
        let udp = UdpPacket::new_checked(&udp_bytes[..]).expect("UDP");
        assert!(
            udp.verify_checksum(
                &Ipv4Address::from(device_ip).into(),
                &Ipv4Address::from(ROBOT_IP).into()
            ),
            "UDP checksum over the reassembled datagram"
        );
        Some((udp.payload().to_vec(), self.parts.len()))
    }
}

#[test]
fn robot_datagrams_longer_than_a_frame_arrive_in_ipv4_fragments_and_are_answered() {
    let device_ip = layout::NETWORK_IPV4.expect("the example's address is IPv4");
    let mut app = WidestReply;
    let mut engine: Engine<layout::RobotProperties, layout::DeviceProperties> =
        Engine::new(layout::ENGINE_CONFIG);
    with_udp_device(&mut engine, &mut app, |step, to_device, from_device| {
        for (round, id) in [41u32, 42, 43].into_iter().enumerate() {
            // The manual's message padded to the layout's receive bound
            // (3,557 bytes): three fragments of at most 1,480 bytes.
            let head = format!(
                r#"<RobData Id="{id}" Ts="1.202"><RobMode>Auto</RobMode><P_act X="1620.0" Y="0" Z="300" Rx="180" Ry="0" Rz="0"/>"#
            );
            let tail = "</RobData>";
            let pad = layout::MAX_RECEIVE_LEN - head.len() - tail.len();
            let request = format!("{head}{}{tail}", " ".repeat(pad));
            assert_eq!(request.len(), layout::MAX_RECEIVE_LEN);
            let fragments =
                robot_fragments(device_ip, request.as_bytes(), 1480, 0x4200 + round as u16);
            assert_eq!(fragments.len(), 3);
            // Out of order, as a switch may deliver them.
            for i in [2, 0, 1] {
                to_device.borrow_mut().push_back(fragments[i].clone());
            }
            let mut reassembly = Reassembly::default();
            let mut reply = None;
            for _ in 0..400 {
                step(1);
                let frames: Vec<Vec<u8>> = from_device.borrow_mut().drain(..).collect();
                for f in frames {
                    if EthernetFrame::new_checked(&f[..]).unwrap().ethertype()
                        == EthernetProtocol::Arp
                    {
                        let _ = robot_receive(&f, device_ip, to_device);
                    } else if let Some(done) = reassembly.add(&f, device_ip) {
                        reply = Some(done);
                    }
                }
                if reply.is_some() {
                    break;
                }
            }
            let (payload, frames) =
                reply.unwrap_or_else(|| panic!("no reply to the fragmented message {id}"));
            assert!(payload.len() <= 1472, "{} bytes", payload.len());
            assert_eq!(frames, 1, "the widest reply of this layout fits one frame");
            let mut data = layout::SensorData::default();
            let d = decode::<SensDataMessage>(&payload, &mut data)
                .expect("the reassembled reply decodes");
            assert_eq!(d.id, id, "M8 across fragments");
            assert_eq!(data.application_data, [-f32::MAX; 18]);
            MockDriver::get().advance(Duration::from_micros(3000));
        }
    });
    let s = engine.stats();
    assert_eq!((s.received, s.answered, s.dropped_decode), (3, 3, 0));
}
