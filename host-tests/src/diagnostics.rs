//! The device's diagnostics from the host tools (`cargo demo`, `cargo
//! hil`): its status page's address, `--device-status` (the simulator
//! reads `/status.json` before and after the counted run), `--browser`
//! (headless Chromium on the page during and after the run,
//! [`crate::browser`]), `--http-attack` (the hostile catalogue during the
//! run, [`crate::http_attack`]) and `--serve` (the device kept running
//! until Ctrl-C).

use crate::device::Device;
use crate::robot::report::Summary;
use crate::run_args::RunArgs;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

/// What a run does with the device's diagnostics.
pub struct Web {
    http: Option<SocketAddr>,
    device_status: bool,
    browser: Option<(PathBuf, PathBuf)>,
    attack: bool,
    /// `--update-catalogue`: the image its files are made from.
    update: Option<PathBuf>,
}

/// The threads that run during the counted run.
pub struct During {
    stop: Arc<AtomicBool>,
    loads: Option<JoinHandle<Vec<String>>>,
    attack: Option<JoinHandle<Result<Vec<String>, Vec<String>>>>,
    update: Option<JoinHandle<Result<Vec<String>, Vec<String>>>>,
}

impl Web {
    /// From the run's options; `http` is where the device's diagnostics
    /// answer (`None`: the tool cannot reach them).
    pub fn new(args: &RunArgs, http: Option<SocketAddr>) -> Result<Web, String> {
        let wants = args.device_status
            || args.browser.is_some()
            || args.http_attack
            || args.update_catalogue
            || args.serve;
        if wants && http.is_none() {
            return Err(
                "--device-status, --browser, --http-attack and --serve need the device's diagnostics (RRI_HTTP_PORT), which this run cannot reach"
                    .into(),
            );
        }
        let browser = match &args.browser {
            Some(png) => Some((crate::browser::find()?, png.clone())),
            None => None,
        };
        let update = match (args.update_catalogue, &args.image) {
            (false, _) => None,
            (true, Some(elf)) => Some(elf.clone()),
            (true, None) => {
                return Err("--update-catalogue: only the QEMU board takes updates yet (`cargo demo` without --board)".into())
            }
        };
        Ok(Web {
            http,
            device_status: args.device_status,
            browser,
            attack: args.http_attack,
            update,
        })
    }

    /// The URL the simulator reads for `--device-status`.
    pub fn status_url(&self) -> Option<String> {
        self.http
            .filter(|_| self.device_status)
            .map(|a| format!("http://{a}/status.json"))
    }

    /// Starts what runs beside the counted run: page loads in the browser
    /// every few seconds, the HTTP catalogue.
    pub fn start(&self) -> During {
        let stop = Arc::new(AtomicBool::new(false));
        let loads = match (&self.browser, self.http) {
            (Some((browser, _)), Some(http)) => {
                let (browser, stop) = (browser.clone(), stop.clone());
                Some(std::thread::spawn(move || {
                    let url = format!("http://{http}/");
                    let mut seen = Vec::new();
                    while !stop.load(Ordering::Relaxed) {
                        match crate::browser::dump_dom(&browser, &url) {
                            Ok(r) => seen.push(format!(
                                "{} {} answered {}",
                                r.device,
                                r.state,
                                r.answered.map_or("?".into(), |n| n.to_string())
                            )),
                            Err(e) => seen.push(format!("load failed: {e}")),
                        }
                        // A browser start costs this shared host a core for
                        // a while: a load every few seconds is plenty.
                        for _ in 0..50 {
                            if stop.load(Ordering::Relaxed) {
                                break;
                            }
                            std::thread::sleep(Duration::from_millis(100));
                        }
                    }
                    seen
                }))
            }
            _ => None,
        };
        let attack = match (self.attack, self.http) {
            (true, Some(http)) => {
                println!("== HTTP catalogue against http://{http}/ while the robot runs");
                Some(std::thread::spawn(move || crate::http_attack::run(http)))
            }
            _ => None,
        };
        let update = match (&self.update, self.http) {
            (Some(elf), Some(http)) => {
                println!("== update catalogue against http://{http}/firmware while the robot runs");
                let elf = elf.clone();
                Some(std::thread::spawn(move || {
                    crate::update_catalogue::run(http, &elf)
                }))
            }
            _ => None,
        };
        During {
            stop,
            loads,
            attack,
            update,
        }
    }

    /// After the counted run (the device still running): the catalogue's
    /// and the browser's verdicts. `warm` is what the warm-up sent and had
    /// answered, `summary` the counted run's. Every failure, one line each.
    pub fn finish(
        &self,
        during: During,
        device: &str,
        warm: (u64, u64),
        summary: Option<&Summary>,
    ) -> Vec<String> {
        let mut failures = Vec::new();
        during.stop.store(true, Ordering::Relaxed);
        for (catalogue, prefix, what) in [
            (during.attack, "http", "HTTP"),
            (during.update, "update", "update"),
        ] {
            if let Some(thread) = catalogue {
                failures.extend(catalogue_verdict(thread, prefix, what));
            }
        }
        let mut seen_operating = false;
        if let Some(loads) = during.loads {
            let seen = loads.join().unwrap_or_default();
            println!(
                "browser: {} loads of the page during the run; the last: {}",
                seen.len(),
                seen.last().map_or("none", |s| s.as_str())
            );
            // The state while the robot ran is judged from the loads
            // during the run: after it, the device rightly leaves
            // OPERATING once TimeOut passes without a message (S1).
            let running = format!("{device} OPERATING ");
            let loaded = seen.iter().any(|s| !s.starts_with("load failed"));
            seen_operating = seen.iter().any(|s| s.starts_with(&running));
            if loaded && !seen_operating {
                failures.push(format!(
                    "{NEVER_OPERATING} {device} OPERATING during the run"
                ));
            }
            failures.extend(seen.into_iter().filter(|s| s.starts_with("load failed")));
        }
        if let (Some((browser, png)), Some(http), Some(s)) = (&self.browser, self.http, summary) {
            let url = format!("http://{http}/");
            // What the device answered is at least what reached the
            // simulator and at most every message it sent (a reply lost
            // on the way back is an answer all the same).
            let low = warm.1 + s.answered + s.duplicate_replies;
            let high = warm.0 + s.sent + s.injected.duplicated;
            // After the run: OPERATING, or, once the page showed
            // OPERATING during the run, the communication error S1 reports
            // when TimeOut passes without a message (a browser start on a
            // loaded host can take longer than TimeOut).
            let states: &[&str] = if seen_operating {
                &["OPERATING", "ERROR 112602"]
            } else {
                &["OPERATING"]
            };
            match crate::browser::dump_dom(browser, &url)
                .and_then(|r| crate::browser::check(&r, device, states, low, high).map(|()| r))
            {
                Ok(r) => println!(
                    "browser: the page shows {} {} answered {} (the simulator: {low} answered of {high} sent): right",
                    r.device,
                    r.state,
                    r.answered.unwrap_or(0)
                ),
                Err(e) => failures.push(e),
            }
            match crate::browser::screenshot(browser, &url, png) {
                Ok(()) => println!("browser: screenshot {}", png.display()),
                Err(e) => failures.push(format!("--browser {}: {e}", png.display())),
            }
        }
        failures
    }
}

/// Whether a failure of the browser's check is about the page's state
/// alone: it never showed OPERATING during the run, or after it showed
/// another state, with the device's name and count right. In a run the
/// host already failed (every reply right, only late or lost before the
/// firmware: the robot's supervision tripped) that is the host's too: a
/// starved Chromium renders no page in time, and a device whose
/// controller tripped rightly leaves OPERATING (S1). A wrong name or
/// count never is.
pub fn browser_state_only(failure: &str) -> bool {
    if failure.starts_with(NEVER_OPERATING) {
        return true;
    }
    let Some(rest) = failure.strip_prefix(crate::browser::CHECK_FAILED) else {
        return false;
    };
    let items = rest.split(" (DOM:").next().unwrap_or(rest);
    items.split("; ").all(|item| item.starts_with("state "))
}

/// How the browser's failure to see OPERATING during the run begins.
const NEVER_OPERATING: &str = "the page in the browser never showed";

/// A catalogue's lines, each printed after `prefix`; its failures (the
/// `FAIL` lines, or that it panicked).
fn catalogue_verdict(
    thread: JoinHandle<Result<Vec<String>, Vec<String>>>,
    prefix: &str,
    what: &str,
) -> Vec<String> {
    let (lines, failed) = match thread.join() {
        Ok(Ok(lines)) => (lines, false),
        Ok(Err(lines)) => (lines, true),
        Err(_) => return vec![format!("the {what} catalogue panicked")],
    };
    for l in &lines {
        println!("{prefix}: {l}");
    }
    if failed {
        lines
            .into_iter()
            .filter(|l| l.starts_with("FAIL"))
            .collect()
    } else {
        Vec::new()
    }
}

/// `--serve`: keeps the device running, its log shown, until Ctrl-C.
pub fn serve_until_ctrl_c(dev: &mut dyn Device, http: Option<SocketAddr>) -> Result<(), String> {
    let stop = Arc::new(AtomicBool::new(false));
    let flag = stop.clone();
    ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed))
        .map_err(|e| format!("--serve: cannot install the Ctrl-C handler: {e}"))?;
    match http {
        Some(a) => println!("== serving: open http://{a}/ in a browser; Ctrl-C stops the device"),
        None => println!("== the device keeps running; Ctrl-C stops it"),
    }
    while !stop.load(Ordering::Relaxed) {
        for line in dev.take_new() {
            println!("device: {line}");
        }
        if let Some(why) = dev.stopped() {
            // The terminal sends Ctrl-C to QEMU too, which may exit before
            // the flag is seen here: that is the user's stop.
            std::thread::sleep(Duration::from_millis(300));
            if stop.load(Ordering::Relaxed) {
                break;
            }
            return Err(format!("the firmware stopped while serving ({why})"));
        }
        std::thread::sleep(Duration::from_millis(200));
    }
    println!("== Ctrl-C: the device stopped by the user");
    Ok(())
}

/// `cargo hil` with no probe (`--no-probe`): the device's own figures
/// from its `/status.json` instead of its log. The reply latency at the
/// driver (its power-of-two histogram: min, mean, max exact, the
/// percentiles as the band they fall in) and the stack's marks; fails
/// under the 25 % stack margin `cargo hil` requires of a probe's run.
pub fn figures_over_ethernet(http: SocketAddr) -> Result<(), String> {
    let url = format!("http://{http}/status.json");
    let r = crate::robot::device_status::get(&url, Duration::from_secs(5))?;
    if r.status != 200 {
        return Err(format!("{url}: HTTP {}", r.status));
    }
    let v: serde_json::Value =
        serde_json::from_slice(&r.body).map_err(|e| format!("{url}: not JSON: {e}"))?;
    let l = &v["latency"];
    let count = l["count"].as_u64().unwrap_or(0);
    let buckets: Vec<(Option<u64>, u64)> = l["buckets"]
        .as_array()
        .map(|b| {
            b.iter()
                .map(|x| (x["below_us"].as_u64(), x["count"].as_u64().unwrap_or(0)))
                .collect()
        })
        .unwrap_or_default();
    let band = |p: f64| -> String {
        let want = (count as f64 * p).ceil() as u64;
        let mut seen = 0;
        for (below, n) in &buckets {
            seen += n;
            if seen >= want.max(1) {
                return match below {
                    Some(b) => format!("< {b} µs"),
                    None => "≥ 32768 µs".into(),
                };
            }
        }
        "–".into()
    };
    println!(
        "device (its /status.json, latency measured at the {}): {count} replies, min {} µs, mean {} µs, median {}, p99 {}, max {} µs",
        l["source"].as_str().unwrap_or("?"),
        l["min_us"],
        l["mean_us"],
        band(0.5),
        band(0.99),
        l["max_us"]
    );
    let s = &v["stack"];
    match (
        s["boot_bytes"].as_u64(),
        s["running_bytes"].as_u64(),
        s["size_bytes"].as_u64(),
    ) {
        (Some(boot), Some(running), Some(size)) => {
            let margin = crate::qemu_bench::stack_margin_percent((boot, running, size));
            println!(
                "  stack: start-up {boot} bytes, running {running} bytes of {size}: {margin}% margin"
            );
            if margin < crate::qemu_bench::MIN_STACK_MARGIN_PERCENT {
                return Err(format!(
                    "stack margin {margin}% is under {}%",
                    crate::qemu_bench::MIN_STACK_MARGIN_PERCENT
                ));
            }
        }
        _ => return Err(format!("{url}: no stack figures")),
    }
    println!(
        "  last reset: {} (start {})",
        v["device"]["reset"]["cause"].as_str().unwrap_or("?"),
        v["device"]["reset"]["boots"]
    );
    Ok(())
}
