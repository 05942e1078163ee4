//! The scrape run's client: what a plant's monitoring and a browser do to
//! the device's diagnostics while the cycle is measured. `/metrics` ten
//! times a second (a Prometheus scrape interval far shorter than any
//! plant uses), the page once a second, and every second eight
//! connections at once (`/status.json`): more than the service's slots,
//! so some are turned away. Counts what it got.

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// What the scraper got.
#[derive(Debug, Default)]
pub struct Scraped {
    /// Whole 200 responses.
    pub ok: AtomicU64,
    /// Connections turned away (reset or closed without a response) or
    /// answered with another status.
    pub refused: AtomicU64,
    /// Bytes of 200 responses.
    pub bytes: AtomicU64,
}

impl Scraped {
    pub fn line(&self) -> String {
        format!(
            "{} responses ({} KB), {} connections turned away",
            self.ok.load(Ordering::Relaxed),
            self.bytes.load(Ordering::Relaxed) / 1000,
            self.refused.load(Ordering::Relaxed)
        )
    }
}

/// The scraper's threads.
pub struct Scraper {
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
    pub got: Arc<Scraped>,
}

fn get(to: SocketAddr, path: &str, got: &Scraped) {
    let outcome = (|| -> std::io::Result<Vec<u8>> {
        let mut s = TcpStream::connect_timeout(&to, Duration::from_secs(2))?;
        s.set_read_timeout(Some(Duration::from_secs(10)))?;
        write!(
            s,
            "GET {path} HTTP/1.1\r\nAccept-Encoding: gzip\r\nConnection: close\r\n\r\n"
        )?;
        let mut body = Vec::new();
        s.read_to_end(&mut body)?;
        Ok(body)
    })();
    match outcome {
        Ok(r) if r.starts_with(b"HTTP/1.1 200") => {
            got.ok.fetch_add(1, Ordering::Relaxed);
            got.bytes.fetch_add(r.len() as u64, Ordering::Relaxed);
        }
        _ => {
            got.refused.fetch_add(1, Ordering::Relaxed);
        }
    }
}

impl Scraper {
    /// Starts scraping the diagnostics at `to`.
    pub fn start(to: SocketAddr) -> Scraper {
        let stop = Arc::new(AtomicBool::new(false));
        let got = Arc::new(Scraped::default());
        let every = |period: Duration, job: Box<dyn Fn() + Send>| {
            let stop = stop.clone();
            std::thread::spawn(move || {
                let mut next = Instant::now();
                while !stop.load(Ordering::Relaxed) {
                    job();
                    next += period;
                    if let Some(wait) = next.checked_duration_since(Instant::now()) {
                        std::thread::sleep(wait);
                    }
                }
            })
        };
        let g = got.clone();
        let metrics = every(
            Duration::from_millis(100),
            Box::new(move || get(to, "/metrics", &g)),
        );
        let g = got.clone();
        let page = every(Duration::from_secs(1), Box::new(move || get(to, "/", &g)));
        let g = got.clone();
        let burst = every(
            Duration::from_secs(1),
            Box::new(move || {
                let all: Vec<_> = (0..8)
                    .map(|_| {
                        let g = g.clone();
                        std::thread::spawn(move || get(to, "/status.json", &g))
                    })
                    .collect();
                for t in all {
                    let _ = t.join();
                }
            }),
        );
        Scraper {
            stop,
            threads: vec![metrics, page, burst],
            got,
        }
    }

    /// Stops scraping; what it got.
    pub fn stop(self) -> Arc<Scraped> {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads {
            let _ = t.join();
        }
        self.got
    }
}
