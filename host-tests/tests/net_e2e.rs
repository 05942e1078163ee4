//! End to end in one process: an embassy-net (smoltcp) stack over an
//! in-memory Ethernet driver, the boards' own UDP cycle task
//! (`rri_firmware::net::Cycle::udp`) with the demo application, and a
//! simulated robot that exchanges real Ethernet/ARP/IPv4/UDP frames with it:
//! 1,000 cycles, every reply checked (M8 Id echo, root, decodable fields).
//!
//! Time is embassy-time's mock clock, advanced by the test: deterministic.
//! TCP (`Cycle::tcp`) has its own file, `net_tcp.rs`.

mod memnet;

use embassy_time::{Duration, MockDriver};
use host_tests::layouts::anydevice::{self as layout, SensDataMessage};
use memnet::udp::{await_reply, padded_robdata, robot_fragments, robot_frame, with_udp_device};
use rri_firmware::codec::decode;
use rri_firmware::engine::{Clock, Engine, SensorState};
use rri_firmware::net::EmbassyClock;
use rri_firmware::sample::SampleCell;
use rri_firmware::sensor::{Ring, Sampler, SensorApp, Simulated};
use rri_firmware::sensors::distance::Distance;

#[test]
fn thousand_cycles_over_embassy_net_with_real_frames() {
    let cell = SampleCell::new(Ring::EMPTY);
    let (writer, reader) = cell.split().expect("split");
    type Robot = layout::RobotProperties;
    type Device = layout::DeviceProperties;
    let mut sampler = Sampler::<Distance, Robot, Device>::new(writer);
    let mut app = SensorApp::<Distance, Robot, Device>::new(reader);
    let mut engine: Engine<layout::RobotProperties, layout::DeviceProperties> =
        Engine::new(layout::ENGINE_CONFIG);
    let clock = EmbassyClock;
    with_udp_device(&mut engine, &mut app, |step, to_device, from_device, _| {
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
                .push_back(robot_frame(request.as_bytes()));
            let reply = await_reply(step, to_device, from_device, 400).map(|r| r.0);
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

#[test]
fn robot_datagrams_longer_than_a_frame_arrive_in_ipv4_fragments_and_are_answered() {
    let mut app = WidestReply;
    let mut engine: Engine<layout::RobotProperties, layout::DeviceProperties> =
        Engine::new(layout::ENGINE_CONFIG);
    with_udp_device(&mut engine, &mut app, |step, to_device, from_device, _| {
        for (round, id) in [41u32, 42, 43].into_iter().enumerate() {
            // The manual's message padded to the layout's receive bound
            // (3,557 bytes): three fragments of at most 1,480 bytes.
            let request = padded_robdata(id, layout::MAX_RECEIVE_LEN);
            let fragments = robot_fragments(&request, 1480, 0x4200 + round as u16);
            assert_eq!(fragments.len(), 3);
            // Out of order, as a switch may deliver them.
            for i in [2, 0, 1] {
                to_device.borrow_mut().push_back(fragments[i].clone());
            }
            let reply = await_reply(step, to_device, from_device, 400).map(|r| (r.0, r.1));
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
    // Put together by the fragment guard (S5), which counted them.
    let f = s.fragments;
    assert_eq!(
        (
            f.fragments,
            f.reassembled,
            f.controller_datagrams,
            f.dropped()
        ),
        (9, 3, 3, 0)
    );
}
