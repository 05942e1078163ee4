//! How deep the stack has ever grown, by painting (every board).
//!
//! Everything runs on the one main stack (MSP): thread-mode tasks, and on
//! top of them whatever interrupt preempts them (the urgent executor with
//! the network stack and the cycle, the NIC, SysTick). [`paint`] fills the
//! free part of the stack with a pattern at boot; [`high_water`] finds the
//! lowest word that no longer holds it, so the figure includes the deepest
//! nesting of interrupts that ever happened, not an estimate.
//!
//! Two figures: start-up (`boot`) and the running firmware (`running`).
//! Building embassy-net's stack is the deepest point of all (smoltcp's
//! `Interface` is built on the stack and moved into its static home, ~40 KB
//! on Thumb-2 at opt-level "z"); once the network is up, [`repaint`] paints
//! again, so the cycle's own depth (receive → decode → engine → encode →
//! send, with the interrupts on top) is measured apart from it.
//!
//! Where the stack is: cortex-m-rt's `_stack_start` (top) and `_stack_end`
//! (the lowest address it may reach). Under flip-link (the default link,
//! see `.cargo/flip-link-or-lld`) that is the bottom of RAM, below the
//! statics; with plain rust-lld it is the end of the statics. Either way
//! the lowest bytes are the stack guard's ([`crate::stack_guard`]), which
//! faults on a write: painting and measuring start above it.
#![allow(unsafe_code)]

use core::ptr::{self, addr_of};
use core::sync::atomic::{AtomicUsize, Ordering};

/// The stack the firmware is designed to live in: painting and the margin
/// are measured against this (or the whole stack region, when smaller).
/// The region itself is bigger (all RAM the statics leave: ~450 KiB on the
/// NUCLEO-F767ZI), but a design that needed it would leave no room to
/// grow; `cargo qemu-bench` fails when less than 25 % of this is left.
pub const STACK_BUDGET: usize = 96 * 1024;

/// The paint: what an untouched stack word holds.
const PAINT: u32 = 0xCCCC_CCCC;
/// Bytes below the painting function's own stack pointer left unpainted.
const GUARD: usize = 256;

/// The start-up depth, kept by [`repaint`] (0 until then).
static BOOT: AtomicUsize = AtomicUsize::new(0);

extern "C" {
    // cortex-m-rt's linker script (moved by flip-link): the initial stack
    // pointer and the stack's lowest address.
    static _stack_start: u32;
}

/// The stack's budgeted size and the deepest it has been, in bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct StackUse {
    /// During start-up (until [`repaint`]).
    pub boot: usize,
    /// Since [`repaint`] (everything, before it is called).
    pub running: usize,
    pub size: usize,
}

impl StackUse {
    /// Percent of the budget never touched, at the deeper of the two.
    pub fn margin_percent(&self) -> usize {
        let used = self.boot.max(self.running).min(self.size);
        (self.size - used) * 100 / self.size.max(1)
    }
}

/// (lowest, highest) address of the budgeted stack.
fn bounds() -> (usize, usize) {
    let top = addr_of!(_stack_start) as usize;
    // Above the guard (`crate::stack_guard`): painting it would fault.
    let bottom = crate::stack_guard::end();
    let bottom = bottom.max(top.saturating_sub(STACK_BUDGET));
    (bottom.next_multiple_of(4), top)
}

/// Paints from the stack's bottom to [`GUARD`] bytes below this function's
/// frame.
#[inline(never)]
fn paint_below_here() {
    let (bottom, _) = bounds();
    let sp = cortex_m::register::msp::read() as usize;
    let end = sp.saturating_sub(GUARD) & !3;
    let mut p = bottom;
    while p < end {
        // SAFETY: [bottom, sp - GUARD) is stack no frame uses (this is the
        // deepest frame and the callers keep interrupts away), word
        // aligned.
        unsafe { ptr::write_volatile(p as *mut u32, PAINT) };
        p += 4;
    }
}

/// Paints the stack below the caller. Call it first in `main`, before
/// interrupts are enabled.
pub fn paint() {
    paint_below_here();
}

/// Keeps the depth so far as the start-up figure and paints again below
/// the caller, with interrupts masked meanwhile (an interrupt would push
/// its frame into the area being painted). Costs one write per free word
/// of the budget (~25k on the QEMU board): call it once, when start-up is
/// over.
pub fn repaint() {
    let boot = scan();
    cortex_m::interrupt::free(|_| paint_below_here());
    BOOT.store(boot, Ordering::Relaxed);
}

/// Bytes from the top down to the lowest word that lost the paint.
fn scan() -> usize {
    let (bottom, top) = bounds();
    let mut p = bottom;
    // SAFETY: reads of word-aligned stack addresses; a word in use by a
    // frame right now reads as whatever it holds (at worst it counts as
    // used).
    while p < top && unsafe { ptr::read_volatile(p as *const u32) } == PAINT {
        p += 4;
    }
    top - p
}

/// The deepest the stack has been: at start-up and since. Costs one read
/// per never-used word (call it from thread mode: it is for the logs).
pub fn high_water() -> StackUse {
    let (bottom, top) = bounds();
    StackUse {
        boot: BOOT.load(Ordering::Relaxed),
        running: scan(),
        size: top - bottom,
    }
}
