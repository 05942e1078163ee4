//! The in-memory Ethernet the network tests share (`mod memnet;` in each
//! test file): a driver whose frames go to `VecDeque`s, the static IPv4
//! configuration, and the TCP rig (the boards' `Cycle::tcp` on one
//! embassy-net stack, a robot on another, one cable between them).
#![allow(dead_code)] // each test file uses its part

pub mod udp;

use embassy_net::{Ipv4Cidr, Stack, StackResources, StaticConfigV4};
use embassy_net_driver::{Capabilities, Driver, HardwareAddress, LinkState, RxToken, TxToken};
use embassy_time::{Duration, MockDriver};
use host_tests::layouts::anydevice as layout;
use rri_firmware::engine::{Application, Engine};
use rri_firmware::net::{Cycle, EmbassyClock, TcpBuffers};
use smoltcp::wire::Ipv4Address;
use std::cell::RefCell;
use std::collections::VecDeque;
use std::future::Future;
use std::pin::pin;
use std::rc::Rc;
use std::task::{Context, Poll, Waker};

pub const DEVICE_MAC: [u8; 6] = [0x02, 0, 0, 0, 0, 0x01];
pub const ROBOT_MAC: [u8; 6] = [0x02, 0, 0, 0, 0, 0x02];
pub const ROBOT_IP: [u8; 4] = [10, 49, 65, 1];
pub type Frames = Rc<RefCell<VecDeque<Vec<u8>>>>;

/// An Ethernet "cable" in memory: frames to the device and from it.
pub struct MemDriver {
    pub to_device: Frames,
    pub from_device: Frames,
    pub mac: [u8; 6],
}

impl MemDriver {
    /// The two ends of one cable, on a fresh network: the device's (MAC
    /// [`DEVICE_MAC`]) and the peer's ([`ROBOT_MAC`]), and the frame
    /// queues (to the device, from it) for tests that watch the wire.
    pub fn pair() -> (MemDriver, MemDriver, Frames, Frames) {
        let a: Frames = Rc::default();
        let b: Frames = Rc::default();
        let device = MemDriver {
            to_device: a.clone(),
            from_device: b.clone(),
            mac: DEVICE_MAC,
        };
        let peer = MemDriver {
            to_device: b.clone(),
            from_device: a.clone(),
            mac: ROBOT_MAC,
        };
        (device, peer, a, b)
    }
}

pub struct MemRx(Vec<u8>);
pub struct MemTx(Frames);

impl RxToken for MemRx {
    fn consume<R, F: FnOnce(&mut [u8]) -> R>(mut self, f: F) -> R {
        f(&mut self.0)
    }
}

impl TxToken for MemTx {
    fn consume<R, F: FnOnce(&mut [u8]) -> R>(self, len: usize, f: F) -> R {
        let mut frame = vec![0; len];
        let r = f(&mut frame);
        self.0.borrow_mut().push_back(frame);
        r
    }
}

impl Driver for MemDriver {
    type RxToken<'a> = MemRx;
    type TxToken<'a> = MemTx;

    fn receive(&mut self, _: &mut Context) -> Option<(MemRx, MemTx)> {
        let frame = self.to_device.borrow_mut().pop_front()?;
        Some((MemRx(frame), MemTx(self.from_device.clone())))
    }

    fn transmit(&mut self, _: &mut Context) -> Option<MemTx> {
        Some(MemTx(self.from_device.clone()))
    }

    fn link_state(&mut self, _: &mut Context) -> LinkState {
        LinkState::Up
    }

    fn capabilities(&self) -> Capabilities {
        let mut c = Capabilities::default();
        c.max_transmission_unit = 1514;
        c
    }

    fn hardware_address(&self) -> HardwareAddress {
        HardwareAddress::Ethernet(self.mac)
    }
}

/// A static IPv4 configuration on a /24.
pub fn net_config(ip: [u8; 4]) -> embassy_net::Config {
    embassy_net::Config::ipv4_static(StaticConfigV4 {
        address: Ipv4Cidr::new(Ipv4Address::from(ip), 24),
        gateway: None,
        dns_servers: Default::default(),
    })
}

pub fn poll_once<F: Future>(f: std::pin::Pin<&mut F>) -> Poll<F::Output> {
    f.poll(&mut Context::from_waker(Waker::noop()))
}

/// The boards' TCP cycle task (`Cycle::tcp`, socket buffers of 4 KiB) with
/// `engine` and `app` on one stack, and the robot future `robot` makes
/// from a second stack, over a fresh in-memory Ethernet (mock clock
/// reset). Polls all of them, 50 µs of mock time per step, until the robot
/// is done or `max_steps` have passed, then 100 steps more so the device
/// sees the end. Returns whether the robot finished.
/// embassy-time's mock clock is one per process, and cargo runs a test
/// file's tests on parallel threads: a test that advanced or reset it under
/// another made that one's time jump (a TCP test once saw a connection
/// served "after 364 ms" in CI). Every test that drives the mock clock
/// holds this for its whole run.
pub fn mock_clock() -> std::sync::MutexGuard<'static, ()> {
    static CLOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
    // A test that failed while holding it leaves it poisoned; the clock is
    // reset by the next holder anyway.
    CLOCK
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

pub fn with_tcp_device<A, F>(
    engine: &mut Engine<layout::RobotProperties, layout::DeviceProperties>,
    app: &mut A,
    robot: impl FnOnce(Stack<'static>) -> F,
    max_steps: usize,
) -> bool
where
    A: Application<layout::RobotProperties, layout::DeviceProperties>,
    F: Future<Output = ()>,
{
    let _clock = mock_clock();
    let device_ip = layout::NETWORK_IPV4.expect("IPv4");
    MockDriver::get().reset();
    let (device_driver, robot_driver, _, _) = MemDriver::pair();
    // Leaked (a few KiB per test) so the robot's future may hold its stack.
    let device_res = Box::leak(Box::new(StackResources::<2>::new()));
    let robot_res = Box::leak(Box::new(StackResources::<3>::new()));
    let (device_stack, mut device_runner) =
        embassy_net::new(device_driver, net_config(device_ip), device_res, 1);
    let (robot_stack, mut robot_runner) =
        embassy_net::new(robot_driver, net_config(ROBOT_IP), robot_res, 2);
    let mut buffers =
        TcpBuffers::<4096, { layout::MAX_RECEIVE_LEN }, { layout::MAX_SEND_LEN }>::new();
    let mut monitor = ();
    let link = rri_firmware::fragments::Link::new();
    let mut device_net = pin!(device_runner.run());
    let mut robot_net = pin!(robot_runner.run());
    let cycle = Cycle {
        stack: device_stack,
        port: layout::CHANNEL_PORT,
        engine,
        app,
        clock: &EmbassyClock,
        monitor: &mut monitor,
        link: &link,
    };
    let mut task = pin!(cycle.tcp(&mut buffers));
    let mut robot = pin!(robot(robot_stack));
    let mut done = false;
    for _ in 0..max_steps {
        assert!(poll_once(device_net.as_mut()).is_pending());
        assert!(poll_once(robot_net.as_mut()).is_pending());
        assert!(poll_once(task.as_mut()).is_pending());
        if poll_once(robot.as_mut()).is_ready() {
            done = true;
            break;
        }
        MockDriver::get().advance(Duration::from_micros(50));
    }
    for _ in 0..100 {
        let _ = poll_once(device_net.as_mut());
        let _ = poll_once(robot_net.as_mut());
        let _ = poll_once(task.as_mut());
        MockDriver::get().advance(Duration::from_micros(50));
    }
    done
}
