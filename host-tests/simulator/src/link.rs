//! The transport to the sensor: a UDP socket (and a second one for the
//! second-port fault) or a TCP stream, with receiver threads that stamp
//! each reply the moment it arrives.

use std::io::{ErrorKind, Read};
use std::net::{SocketAddr, TcpStream, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};

/// What the receiver threads hand over: a reply and when it arrived.
pub(crate) enum Event {
    Data(Vec<u8>, SocketAddr, Instant),
    Closed,
}

/// The transport to the sensor. Receiving runs on threads that block on
/// their socket and timestamp each reply the moment it arrives; the main
/// loop waits on a channel with precise timeouts (a socket's own receive
/// timeout is only as fine as the kernel tick).
pub(crate) struct Link {
    pub(crate) udp: Option<(UdpSocket, Option<UdpSocket>)>,
    pub(crate) tcp: Option<TcpStream>,
    pub(crate) events: mpsc::Receiver<Event>,
    pub(crate) stop: Arc<AtomicBool>,
    pub(crate) threads: Vec<std::thread::JoinHandle<()>>,
    pub(crate) closed: bool,
}

impl Link {
    pub(crate) fn udp(to: SocketAddr, second_port: bool) -> std::io::Result<Link> {
        let (tx, events) = mpsc::channel();
        let stop = Arc::new(AtomicBool::new(false));
        let main = UdpSocket::bind(local_for(to))?;
        let second = if second_port {
            Some(UdpSocket::bind(local_for(to))?)
        } else {
            None
        };
        let mut threads = Vec::new();
        for sock in std::iter::once(&main).chain(second.as_ref()) {
            let sock = sock.try_clone()?;
            sock.set_read_timeout(Some(Duration::from_millis(20)))?;
            let local = sock.local_addr()?;
            let (tx, stop) = (tx.clone(), stop.clone());
            threads.push(std::thread::spawn(move || {
                let mut buf = vec![0u8; 65_536];
                while !stop.load(Ordering::Relaxed) {
                    if let Ok((n, _)) = sock.recv_from(&mut buf) {
                        let at = Instant::now();
                        if tx.send(Event::Data(buf[..n].to_vec(), local, at)).is_err() {
                            return;
                        }
                    }
                }
            }));
        }
        Ok(Link {
            udp: Some((main, second)),
            tcp: None,
            events,
            stop,
            threads,
            closed: false,
        })
    }

    pub(crate) fn tcp(to: SocketAddr) -> std::io::Result<Link> {
        let (tx, events) = mpsc::channel();
        let stop = Arc::new(AtomicBool::new(false));
        let stream = TcpStream::connect_timeout(&to, Duration::from_secs(2))?;
        stream.set_nodelay(true)?;
        let mut reader = stream.try_clone()?;
        reader.set_read_timeout(Some(Duration::from_millis(20)))?;
        let local = stream.local_addr()?;
        let flag = stop.clone();
        let thread = std::thread::spawn(move || {
            let mut framer = Box::new(rri_framing::Framer::<65_536>::new());
            let mut chunk = [0u8; 8192];
            while !flag.load(Ordering::Relaxed) {
                match reader.read(&mut chunk) {
                    Ok(0) => {
                        let _ = tx.send(Event::Closed);
                        return;
                    }
                    Ok(n) => {
                        let at = Instant::now();
                        let _ = framer.push(&chunk[..n], |m| {
                            let _ = tx.send(Event::Data(m.to_vec(), local, at));
                        });
                    }
                    Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
                    Err(_) => {
                        let _ = tx.send(Event::Closed);
                        return;
                    }
                }
            }
        });
        Ok(Link {
            udp: None,
            tcp: Some(stream),
            events,
            stop,
            threads: vec![thread],
            closed: false,
        })
    }
}

impl Drop for Link {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

pub(crate) fn local_for(to: SocketAddr) -> SocketAddr {
    if to.ip().is_loopback() {
        SocketAddr::from(([127, 0, 0, 1], 0))
    } else {
        SocketAddr::from(([0, 0, 0, 0], 0))
    }
}
