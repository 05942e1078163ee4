//! A running firmware and its log, as a run needs it (`cargo demo`, `cargo
//! hil`, `--serve`): QEMU's board, a probe's, the rehosting engine's, or
//! one this computer cannot read.

use crate::qemu::Qemu;
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// The last `n` of a log's `lines`, each on a line of its own indented
/// under a failure's message.
pub fn tail<'a>(lines: impl DoubleEndedIterator<Item = &'a str>, n: usize) -> String {
    let last: Vec<&str> = lines.rev().take(n).collect();
    last.into_iter().rev().collect::<Vec<_>>().join("\n  ")
}

/// A running firmware and its log, as the run needs it.
pub trait Device {
    /// Waits until a logged line contains `needle`.
    fn wait_for(&mut self, needle: &str, timeout: Duration) -> Result<(), String>;
    /// Lines logged since the last call ([`crate::qemu::shown_live`] ones).
    fn take_new(&self) -> Vec<String>;
    /// Where new lines arrive, for the simulator to show them live.
    fn live_lines(&self) -> Arc<Mutex<Vec<String>>>;
    /// Every line logged so far.
    fn log(&self) -> Vec<String>;
    /// Why the firmware stopped, if it has.
    fn stopped(&mut self) -> Option<String>;
    /// Stops it and returns the whole log.
    fn stop(self: Box<Self>) -> Vec<String>;
}

impl Device for Qemu {
    fn wait_for(&mut self, needle: &str, timeout: Duration) -> Result<(), String> {
        Qemu::wait_for(self, needle, timeout)
    }
    fn take_new(&self) -> Vec<String> {
        Qemu::take_new(self)
    }
    fn live_lines(&self) -> Arc<Mutex<Vec<String>>> {
        self.new_lines.clone()
    }
    fn log(&self) -> Vec<String> {
        Qemu::log(self)
    }
    fn stopped(&mut self) -> Option<String> {
        self.exited().map(|status| format!("QEMU {status}"))
    }
    fn stop(self: Box<Self>) -> Vec<String> {
        Qemu::stop(*self)
    }
}

/// A device whose log this computer cannot read (a board running without
/// a probe, `cargo hil -- --no-probe`): the run relies on the network
/// alone.
pub struct Unlogged;

impl Device for Unlogged {
    fn wait_for(&mut self, _needle: &str, _timeout: Duration) -> Result<(), String> {
        Ok(())
    }
    fn take_new(&self) -> Vec<String> {
        Vec::new()
    }
    fn live_lines(&self) -> Arc<Mutex<Vec<String>>> {
        Arc::new(Mutex::new(Vec::new()))
    }
    fn log(&self) -> Vec<String> {
        Vec::new()
    }
    fn stopped(&mut self) -> Option<String> {
        None
    }
    fn stop(self: Box<Self>) -> Vec<String> {
        Vec::new()
    }
}
