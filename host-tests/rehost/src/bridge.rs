//! The host's side of the device's wire, as QEMU's user networking is for
//! the QEMU board: a virtual host on the device's subnet (the gateway
//! address, `.1`, or `.2` when the device is `.1`) that forwards the
//! robot's channel from a 127.0.0.1 port to the device and the replies
//! back, and TCP connections (the TCP channel, the status page) from
//! 127.0.0.1 ports to the device's ports. Not libslirp: the bridge lives
//! in the machine's own loop and virtual time, so a deterministic run
//! stays deterministic (libslirp keeps its own wall-clock timers).
//!
//! UDP is framed here, fragments included (RFC 791: fragments of 1,480
//! payload bytes, reassembly by identification); TCP and ARP are
//! smoltcp's.

use crate::bridge_phy::Queues;

#[path = "bridge_udp.rs"]
mod udp;
use crate::link::Link;
use smoltcp::iface::{Config, Interface, SocketHandle, SocketSet};
use smoltcp::socket::tcp;
use smoltcp::time::{Duration, Instant};
use smoltcp::wire::{
    ArpOperation, ArpPacket, EthernetAddress, EthernetFrame, EthernetProtocol, HardwareAddress,
    IpAddress, IpCidr, IpProtocol, Ipv4Address, Ipv4Packet,
};
use std::collections::{HashMap, VecDeque};
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream, UdpSocket};

/// The bridge's own MAC (locally administered).
const GATEWAY_MAC: [u8; 6] = [0x02, 0x00, 0x00, 0x00, 0x00, 0x01];
/// The UDP port the robot's messages come from on the device's side.
pub const ROBOT_PORT: u16 = 6510;
const MTU: usize = 1500;
/// A forwarded connection idle this long (virtual time) sends a keep-alive
/// probe: a device that reset under it answers with a reset (RFC 9293
/// 3.5.2), which closes both sides. Without it a request the device took
/// before its reset waits for its reply for good, and its host connection
/// with it (seen: 13 to 24 open files in a minute of rollbacks).
const HOST_KEEP_ALIVE: Duration = Duration::from_secs(5);
/// A forwarded connection whose device has sent nothing this long (a
/// device in its bootloader's swap answers nothing at all) is aborted.
/// Far above a flash erase's stall (the largest sector's datasheet
/// maximum is 4 s) and the device's own timeouts.
const HOST_TIMEOUT: Duration = Duration::from_secs(30);

/// A TCP forward: a 127.0.0.1 listener and the device port it reaches.
struct TcpForward {
    listener: TcpListener,
    device_port: u16,
    conns: Vec<TcpConn>,
}

struct TcpConn {
    host: TcpStream,
    socket: SocketHandle,
    /// Bytes from the host not yet taken by the device's window.
    to_device: Vec<u8>,
    host_closed: bool,
}

/// Counts for the run's summary.
#[derive(Clone, Copy, Debug, Default)]
pub struct Counts {
    pub udp_to_device: u64,
    pub udp_from_device: u64,
    pub frames_to_device: u64,
    pub frames_from_device: u64,
}

pub struct Bridge {
    iface: Interface,
    sockets: SocketSet<'static>,
    gateway: Ipv4Address,
    device: Ipv4Address,
    device_mac: Option<EthernetAddress>,
    udp: Option<(UdpSocket, u16)>,
    client: Option<SocketAddr>,
    /// Datagrams for the device waiting for its MAC.
    waiting: VecDeque<Vec<u8>>,
    tcp: Vec<TcpForward>,
    next_port: u16,
    ip_id: u16,
    reassembly: HashMap<u16, Vec<(usize, Vec<u8>, bool)>>,
    /// The machine's own robot (deterministic runs): its replies over UDP,
    /// and its TCP connection with what the device sent on it.
    pub internal: bool,
    pub replies: VecDeque<Vec<u8>>,
    internal_tcp: Option<(SocketHandle, Vec<u8>)>,
    pub tcp_received: Vec<u8>,
    /// smoltcp's share of the device's frames, and its frames out.
    rx: VecDeque<Vec<u8>>,
    tx: VecDeque<Vec<u8>>,
    pub counts: Counts,
}

/// The bridge's address on the device's /24: `.1`, or `.2` when the
/// device is `.1` (as the QEMU board's user networking does).
pub fn gateway_for(device: [u8; 4]) -> [u8; 4] {
    let [a, b, c, d] = device;
    [a, b, c, if d == 1 { 2 } else { 1 }]
}

impl Bridge {
    pub fn new(device: [u8; 4]) -> Bridge {
        let gateway = gateway_for(device);
        let mut q = Queues {
            rx: VecDeque::new(),
            tx: VecDeque::new(),
        };
        let config = Config::new(HardwareAddress::Ethernet(EthernetAddress(GATEWAY_MAC)));
        let mut iface = Interface::new(config, &mut q, Instant::ZERO);
        let [a, b, c, d] = gateway;
        iface.update_ip_addrs(|addrs| {
            let _ = addrs.push(IpCidr::new(IpAddress::v4(a, b, c, d), 24));
        });
        Bridge {
            iface,
            sockets: SocketSet::new(vec![]),
            gateway: Ipv4Address::from_octets(gateway),
            device: Ipv4Address::from_octets(device),
            device_mac: None,
            udp: None,
            client: None,
            waiting: VecDeque::new(),
            tcp: Vec::new(),
            next_port: 49152,
            ip_id: 1,
            reassembly: HashMap::new(),
            internal: false,
            replies: VecDeque::new(),
            internal_tcp: None,
            tcp_received: Vec::new(),
            rx: VecDeque::new(),
            tx: VecDeque::new(),
            counts: Counts::default(),
        }
    }

    /// Forwards UDP datagrams arriving at `listen` to the device's
    /// `device_port`, and the device's replies back to their sender.
    pub fn forward_udp(
        &mut self,
        listen: SocketAddr,
        device_port: u16,
    ) -> Result<SocketAddr, String> {
        let s = UdpSocket::bind(listen).map_err(|e| format!("udp {listen}: {e}"))?;
        s.set_nonblocking(true).map_err(|e| e.to_string())?;
        let local = s.local_addr().map_err(|e| e.to_string())?;
        self.udp = Some((s, device_port));
        Ok(local)
    }

    /// Forwards TCP connections to `listen` to the device's `device_port`.
    pub fn forward_tcp(
        &mut self,
        listen: SocketAddr,
        device_port: u16,
    ) -> Result<SocketAddr, String> {
        let l = TcpListener::bind(listen).map_err(|e| format!("tcp {listen}: {e}"))?;
        l.set_nonblocking(true).map_err(|e| e.to_string())?;
        let local = l.local_addr().map_err(|e| e.to_string())?;
        self.tcp.push(TcpForward {
            listener: l,
            device_port,
            conns: Vec::new(),
        });
        Ok(local)
    }

    /// One round: the device's frames in, the host's sockets read, smoltcp
    /// polled, frames for the device queued on the wire.
    pub fn poll(&mut self, link: &mut Link, now_us: u64) {
        while let Some(frame) = link.from_device.pop_front() {
            self.counts.frames_from_device += 1;
            self.frame_from_device(frame);
        }
        self.host_udp();
        self.host_tcp();
        let mut q = Queues {
            rx: std::mem::take(&mut self.rx),
            tx: std::mem::take(&mut self.tx),
        };
        let now = Instant::from_micros(now_us as i64);
        self.internal_tcp_io();
        self.iface.poll(now, &mut q, &mut self.sockets);
        self.tcp_replies();
        self.internal_tcp_io();
        self.iface.poll(now, &mut q, &mut self.sockets);
        self.rx = q.rx;
        self.tx = q.tx;
        while let Some(f) = self.tx.pop_front() {
            self.frame_to_device(link, f);
        }
        if self.device_mac.is_some() {
            while let Some(f) = self.waiting.pop_front() {
                self.frame_to_device(link, f);
            }
        }
    }

    fn frame_to_device(&mut self, link: &mut Link, mut frame: Vec<u8>) {
        if frame.len() >= 14 && frame[..6] == [0; 6] {
            // A datagram framed before the device's MAC was known.
            match self.device_mac {
                Some(mac) => frame[..6].copy_from_slice(mac.as_bytes()),
                None => {
                    self.waiting.push_back(frame);
                    return;
                }
            }
        }
        self.counts.frames_to_device += 1;
        link.to_device.push_back(frame);
    }

    fn frame_from_device(&mut self, frame: Vec<u8>) {
        let Ok(eth) = EthernetFrame::new_checked(&frame[..]) else {
            return;
        };
        match eth.ethertype() {
            EthernetProtocol::Arp => {
                if let Ok(arp) = ArpPacket::new_checked(eth.payload()) {
                    if arp.source_protocol_addr() == self.device.octets()
                        && arp.operation() != ArpOperation::Unknown(0)
                    {
                        self.device_mac = Some(eth.src_addr());
                    }
                }
                self.rx.push_back(frame);
            }
            EthernetProtocol::Ipv4 => {
                let Ok(ip) = Ipv4Packet::new_checked(eth.payload()) else {
                    return;
                };
                if ip.src_addr() == self.device {
                    self.device_mac = Some(eth.src_addr());
                }
                if ip.next_header() == IpProtocol::Udp && ip.src_addr() == self.device {
                    let more = ip.more_frags();
                    let offset = ip.frag_offset() as usize;
                    let id = ip.ident();
                    let payload = ip.payload().to_vec();
                    self.udp_fragment(id, offset, payload, more);
                } else {
                    self.rx.push_back(frame);
                }
            }
            _ => {}
        }
    }

    fn host_udp(&mut self) {
        let mut buf = vec![0u8; 65536];
        loop {
            let Some((sock, port)) = &self.udp else {
                return;
            };
            let port = *port;
            match sock.recv_from(&mut buf) {
                Ok((n, from)) => {
                    self.client = Some(from);
                    self.counts.udp_to_device += 1;
                    let payload = buf[..n].to_vec();
                    self.udp_to_device(&payload, port);
                }
                Err(_) => return,
            }
        }
    }

    /// The machine's own robot sends a datagram to the device's `port`;
    /// the replies gather in [`Bridge::replies`].
    pub fn send_udp(&mut self, payload: &[u8], port: u16) {
        self.internal = true;
        self.counts.udp_to_device += 1;
        self.udp_to_device(payload, port);
    }

    /// The machine's own robot opens a TCP connection to the device's
    /// `port` (at most one); what the device sends gathers in
    /// [`Bridge::tcp_received`].
    pub fn open_tcp(&mut self, port: u16) -> Result<(), String> {
        self.internal = true;
        let mut s = tcp::Socket::new(
            tcp::SocketBuffer::new(vec![0; 65536]),
            tcp::SocketBuffer::new(vec![0; 65536]),
        );
        s.connect(
            self.iface.context(),
            (IpAddress::Ipv4(self.device), port),
            40000,
        )
        .map_err(|e| format!("bridge: TCP connect: {e:?}"))?;
        let h = self.sockets.add(s);
        self.internal_tcp = Some((h, Vec::new()));
        Ok(())
    }

    /// Whether the machine's own TCP connection is established.
    pub fn tcp_ready(&self) -> bool {
        self.internal_tcp.as_ref().is_some_and(|(h, _)| {
            self.sockets.get::<tcp::Socket>(*h).state() == tcp::State::Established
        })
    }

    /// Queues bytes on the machine's own TCP connection.
    pub fn send_tcp(&mut self, bytes: &[u8]) {
        if let Some((_, q)) = &mut self.internal_tcp {
            q.extend_from_slice(bytes);
        }
    }

    fn internal_tcp_io(&mut self) {
        let Some((h, q)) = &mut self.internal_tcp else {
            return;
        };
        let s = self.sockets.get_mut::<tcp::Socket>(*h);
        if s.can_send() && !q.is_empty() {
            if let Ok(n) = s.send_slice(q) {
                q.drain(..n);
            }
        }
        let mut buf = [0u8; 4096];
        while s.can_recv() {
            match s.recv_slice(&mut buf) {
                Ok(n) if n > 0 => self.tcp_received.extend_from_slice(&buf[..n]),
                _ => break,
            }
        }
    }

    fn host_tcp(&mut self) {
        for f in &mut self.tcp {
            while let Ok((host, _)) = f.listener.accept() {
                let _ = host.set_nonblocking(true);
                let _ = host.set_nodelay(true);
                let mut s = tcp::Socket::new(
                    tcp::SocketBuffer::new(vec![0; 16384]),
                    tcp::SocketBuffer::new(vec![0; 16384]),
                );
                s.set_keep_alive(Some(HOST_KEEP_ALIVE));
                s.set_timeout(Some(HOST_TIMEOUT));
                let port = self.next_port;
                self.next_port = if port == 65535 { 49152 } else { port + 1 };
                if s.connect(
                    self.iface.context(),
                    (IpAddress::Ipv4(self.device), f.device_port),
                    port,
                )
                .is_err()
                {
                    continue;
                }
                let socket = self.sockets.add(s);
                f.conns.push(TcpConn {
                    host,
                    socket,
                    to_device: Vec::new(),
                    host_closed: false,
                });
            }
            let mut buf = [0u8; 4096];
            for c in &mut f.conns {
                if !c.host_closed && c.to_device.len() < 65536 {
                    match c.host.read(&mut buf) {
                        Ok(0) => c.host_closed = true,
                        Ok(n) => c.to_device.extend_from_slice(&buf[..n]),
                        Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {}
                        Err(_) => c.host_closed = true,
                    }
                }
                let s = self.sockets.get_mut::<tcp::Socket>(c.socket);
                if s.can_send() && !c.to_device.is_empty() {
                    if let Ok(n) = s.send_slice(&c.to_device) {
                        c.to_device.drain(..n);
                    }
                }
                if c.host_closed && c.to_device.is_empty() {
                    s.close();
                }
            }
        }
    }

    fn tcp_replies(&mut self) {
        for f in &mut self.tcp {
            let mut buf = [0u8; 4096];
            f.conns.retain_mut(|c| {
                let s = self.sockets.get_mut::<tcp::Socket>(c.socket);
                while s.can_recv() {
                    match s.recv_slice(&mut buf) {
                        Ok(n) if n > 0 => {
                            let _ = c.host.set_nonblocking(false);
                            let _ = c.host.write_all(&buf[..n]);
                            let _ = c.host.set_nonblocking(true);
                        }
                        _ => break,
                    }
                }
                let done = !s.is_open()
                    || (!s.may_recv()
                        && c.host_closed
                        && c.to_device.is_empty()
                        && s.send_queue() == 0);
                if done {
                    let _ = c.host.shutdown(std::net::Shutdown::Both);
                    if !s.is_open() {
                        self.sockets.remove(c.socket);
                        return false;
                    }
                } else if !s.may_recv() && s.state() != tcp::State::SynSent {
                    // The device closed its side: so does the host's.
                    let _ = c.host.shutdown(std::net::Shutdown::Write);
                }
                true
            });
        }
    }
}

#[cfg(test)]
#[path = "bridge_tests.rs"]
mod tests;
