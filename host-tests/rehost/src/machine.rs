//! The machine: unicorn's Cortex-M7 with the chip's memories mapped, its
//! peripheral blocks and the core's system control space answered by the
//! models, the image loaded into flash, and virtual time counted in
//! retired instructions (one instruction a cycle of the core clock).
//!
//! Strict: the first access that nothing claims, a write into flash, or a
//! write a model refuses stops the run; [`Stop`] says where (the address,
//! the PC and the function the PC is in) and by which rule.

use crate::access::{bus_read, bus_write};
use crate::bus::{Bus, ResetCause, Shared};
use crate::chip::Chip;
use crate::clocks::Clocks;
use crate::exceptions;
use crate::fault::Fault;
use crate::image::Image;
use crate::scs::Scs;
use crate::state::Active;
pub use crate::state::State;
pub use crate::stop::Stop;
use std::rc::Rc;
use unicorn_engine::{Arch, ArmCpuModel, HookType, MemType, Mode, RegisterARM, Unicorn};

/// Where the peripherals are: one window for the chip's buses (APB, AHB,
/// and on the H7 the D3 domain) and the core's private peripheral bus.
const PERIPHERALS: (u64, u64) = (0x4000_0000, 0x2000_0000);
pub(crate) const PPB: (u64, u64) = (0xE000_0000, 0x10_0000);

/// The emulated chip with its image.
pub struct Machine {
    pub uc: Unicorn<'static, State>,
    /// The host's side of the wire, when the device is reached from
    /// outside.
    pub bridge: Option<crate::bridge::Bridge>,
    /// The image's defmt log.
    pub rtt: Option<crate::rtt::Rtt>,
    /// Log lines read and not yet taken by [`Machine::take_log`].
    pub log: Vec<String>,
    /// Virtual time and the wall clock ([`pace::Pace`]: deterministic by
    /// default).
    pub pace: pace::Pace,
    /// Virtual time in nanoseconds (cycles at the core clock of their
    /// time), and the cycle it was last brought up to.
    pub time_ns: u128,
    time_at: u64,
    /// Slices of 50 us instead of 1 ms (the machine's own robot: its
    /// latencies are measured at slice ends).
    pub fine_slices: bool,
    /// The chip's peripherals at their reset values, for a system reset;
    /// `None`: a reset stops the run.
    pub rebuild: Option<fn() -> (Bus, Clocks)>,
    /// System resets still allowed before a reset stops the run (a loop
    /// of resets is a defect worth stopping at).
    pub resets_left: u32,
    /// What the machine itself has to say (a reset and why), not yet
    /// taken by [`Machine::take_notes`].
    pub notes: Vec<String>,
}

impl Machine {
    /// Maps the chip, loads the image and resets the core.
    pub fn new(chip: Chip, image: Image, bus: Bus, clocks: Clocks) -> Result<Machine, String> {
        let image = Rc::new(image);
        let state = State {
            chip,
            image: image.clone(),
            bus,
            scs: Scs::new(),
            shared: crate::state::Lent::new(Shared {
                clocks,
                link: crate::link::Link::nucleo(),
                ..Shared::default()
            }),
            now: 0,
            accesses: 0,
            poll: crate::poll_watch::Watch::default(),
            deadline: u64::MAX,
            stop: None,
            block_sizes: rustc_hash::FxHashMap::default(),
            reached: false,
            active: Active::default(),
            exceptions_taken: 0,
            yield_at: None,
            exception_return: None,
            fault: None,
            mpu_denied: Vec::new(),
            mpu_pages: Vec::new(),
            mpu_seen: (0, [crate::scs::MpuRegion::default(); 16]),
            sleeping: None,
            event: false,
            slept: 0,
            slices: 0,
            recent: std::collections::VecDeque::new(),
            instruction_hooks: std::collections::BTreeMap::new(),
            torn_hook: None,
            code_changed: Vec::new(),
        };
        fn e(what: &'static str) -> impl Fn(unicorn_engine::uc_error) -> String {
            move |err| format!("unicorn: {what}: {err:?}")
        }
        let mut uc = Unicorn::new_with_data(Arch::ARM, Mode::THUMB, state).map_err(e("open"))?;
        // Not Mode::MCLASS: with it unicorn builds a Cortex-M33 whatever
        // model is asked for (its arm_cpu_init), which has no double-
        // precision FPU; the Cortex-M7 model is an M-profile core by
        // itself (tests/cpu.rs).
        uc.ctl_set_cpu_model(ArmCpuModel::CORTEX_M7 as i32)
            .map_err(e("Cortex-M7"))?;
        crate::memories::power_on(&mut uc, &image)?;

        uc.mmio_map(
            PERIPHERALS.0,
            PERIPHERALS.1,
            Some(|uc: &mut Unicorn<State>, offset, size| {
                bus_read(uc, PERIPHERALS.0 + offset, size)
            }),
            Some(|uc: &mut Unicorn<State>, offset, size, value| {
                bus_write(uc, PERIPHERALS.0 + offset, size, value)
            }),
        )
        .map_err(e("peripherals"))?;
        uc.mmio_map(
            PPB.0,
            PPB.1,
            Some(|uc: &mut Unicorn<State>, offset, size| bus_read(uc, PPB.0 + offset, size)),
            Some(|uc: &mut Unicorn<State>, offset, size, value| {
                bus_write(uc, PPB.0 + offset, size, value)
            }),
        )
        .map_err(e("private peripheral bus"))?;

        uc.add_mem_hook(
            HookType::MEM_UNMAPPED | HookType::MEM_PROT,
            1,
            0,
            |uc, kind, addr, size, _value| {
                let pc = uc.reg_read(RegisterARM::PC).unwrap_or(0);
                if kind == MemType::WRITE_PROT && crate::mpu_enforce::guarded_page(uc, addr) {
                    return crate::mpu_enforce::on_write(uc, addr, size, _value);
                }
                let flash = uc.get_data().chip.flash;
                if kind == MemType::WRITE_PROT
                    && addr >= u64::from(flash.0)
                    && addr + size as u64 <= u64::from(flash.0) + u64::from(flash.1)
                {
                    return crate::access::flash_store(uc, addr, size, _value);
                }
                let what = match kind {
                    MemType::WRITE_PROT => "a write into flash (read-only to the core)".to_string(),
                    MemType::FETCH_UNMAPPED | MemType::FETCH_PROT => {
                        "an instruction fetch where no memory is".to_string()
                    }
                    MemType::WRITE_UNMAPPED => {
                        format!("a {size}-byte write that no memory or model claims")
                    }
                    _ => format!("a {size}-byte read that no memory or model claims"),
                };
                uc.get_data_mut().refuse(what, Some(addr), pc);
                false
            },
        )
        .map_err(e("memory hook"))?;
        // Virtual time: every retired instruction is one core cycle,
        // counted a translated block at a time (a block hook per block,
        // not a code hook per instruction: 8x faster here).
        uc.add_block_hook(1, 0, |uc, addr, size| {
            let count = {
                let s = uc.get_data_mut();
                s.block_sizes.get(&addr).copied()
            };
            let count = match count {
                Some(c) => c,
                None => {
                    let mut bytes = vec![0; size as usize];
                    let _ = uc.mem_read(addr, &mut bytes);
                    let c = crate::hooks::thumb_instructions(&bytes);
                    uc.get_data_mut().block_sizes.insert(addr, c);
                    c
                }
            };
            let s = uc.get_data_mut();
            s.now += count;
            s.poll.entered(addr, size);
            if s.now >= s.deadline {
                let _ = uc.emu_stop();
            }
        })
        .map_err(e("block hook"))?;
        uc.add_intr_hook(|uc, intno| {
            let pc = uc.reg_read(RegisterARM::PC).unwrap_or(0);
            let s = uc.get_data_mut();
            match intno {
                // A branch to EXC_RETURN in handler mode: QEMU's
                // EXCP_EXCEPTION_EXIT (#8) when its translator knew the core
                // was in handler mode, else a prefetch abort (#3) at the
                // EXC_RETURN address (0xFFFF_FFxx, never memory).
                8 | 3 if pc >= 0xFFFF_FF00 => s.exception_return = Some(pc as u32 | 1),
                // EXCP_UDEF: an undefined instruction, a UsageFault that
                // escalates to HardFault (UsageFault is not enabled).
                1 => s.fault = Some(Fault::undefined_instruction(pc as u32)),
                _ => s.refuse(
                    format!(
                        "a CPU exception unicorn raised (#{intno}) that this model does not take"
                    ),
                    None,
                    pc,
                ),
            }
            let _ = uc.emu_stop();
        })
        .map_err(e("interrupt hook"))?;

        crate::hooks::install_instruction_hooks(&mut uc, &image)?;
        uc.get_data_mut().scs.vtor = chip.vtor;
        uc.get_data_mut().scs.mpu_regions = chip.mpu_regions;
        crate::reset::reset_core(&mut uc)?;
        Ok(Machine {
            uc,
            bridge: None,
            rtt: None,
            log: Vec::new(),
            pace: pace::Pace::default(),
            time_ns: 0,
            time_at: 0,
            fine_slices: false,
            rebuild: None,
            resets_left: 0,
            notes: Vec::new(),
        })
    }

    /// Runs until a stop or `cycles` more cycles.
    pub fn run(&mut self, cycles: u64) -> Option<Stop> {
        let deadline = self.uc.get_data().now.saturating_add(cycles);
        loop {
            if let Err(rule) = self.between_slices(deadline) {
                let pc = self.uc.reg_read(RegisterARM::PC).unwrap_or(0);
                self.uc.get_data_mut().refuse(rule, None, pc);
            }
            self.outside();
            let slice = self.slice();
            let s = self.uc.get_data_mut();
            if let Some(stop) = &s.stop {
                return Some(stop.clone());
            }
            if s.now >= deadline {
                return None;
            }
            if s.sleeping.is_some() {
                // Still asleep at the end of a slice (the bridge's turn).
                continue;
            }
            // Run until the next thing a model has to do by itself, or the
            // end of the slice.
            let next = s.bus.next_event(s.now).unwrap_or(u64::MAX);
            s.deadline = deadline.min(next.max(s.now + 1)).min(s.now + slice);
            s.slices += 1;
            if let Err(e) = crate::hooks::follow_code(&mut self.uc) {
                let pc = self.uc.reg_read(RegisterARM::PC).unwrap_or(0);
                self.uc.get_data_mut().refuse(e, None, pc);
                continue;
            }
            let pc = self.uc.reg_read(RegisterARM::PC).unwrap_or(0);
            let result = self.uc.emu_start(pc | 1, 0, 0, 0);
            let pc = self.uc.reg_read(RegisterARM::PC).unwrap_or(0);
            let s = self.uc.get_data_mut();
            if result == Err(unicorn_engine::uc_error::INSN_INVALID) && s.fault.is_none() {
                // An undefined instruction: unicorn stops on it with this
                // error (not its interrupt hook); silicon takes UsageFault
                // with UNDEFINSTR (B1.5.14). Unicorn's M7 decodes what the
                // M7 does (tests/cpu.rs), so this is the image's.
                s.fault = Some(Fault::undefined_instruction(pc as u32));
            } else if let Err(err) = result {
                // A store the MPU refused stops unicorn with an error; the
                // fault is taken next.
                if s.stop.is_none() && s.fault.is_none() {
                    s.refuse(format!("unicorn stopped: {err:?}"), None, pc);
                }
            }
        }
    }

    /// How many cycles run before the outside gets its turn: a
    /// millisecond of virtual time with a bridge, else unbounded.
    fn slice(&self) -> u64 {
        if self.bridge.is_some() {
            let per = if self.fine_slices { 20_000 } else { 1000 };
            (self.uc.get_data().shared.clocks.core_hz / per).max(1000)
        } else {
            u64::MAX / 4
        }
    }

    /// The outside's turn: virtual time brought up to date, the log read,
    /// the bridge polled, and in paced runs the wall clock waited for.
    fn outside(&mut self) {
        let (now, hz) = {
            let s = self.uc.get_data();
            (s.now, s.shared.clocks.core_hz.max(1))
        };
        self.time_ns += u128::from(now - self.time_at) * 1_000_000_000 / u128::from(hz);
        self.time_at = now;
        if let Some(rtt) = &mut self.rtt {
            let lines = rtt.lines(&mut self.uc);
            self.log.extend(lines);
        }
        if let Some(bridge) = &mut self.bridge {
            let us = (self.time_ns / 1000) as u64;
            let s = self.uc.get_data_mut();
            bridge.poll(&mut s.shared.link, us);
            if !s.shared.link.to_device.is_empty() {
                // Frames for the MAC: it takes them at its next advance.
                s.deadline = s.now;
            }
        }
        let listening = self.uc.get_data().shared.link.listening;
        self.notes
            .extend(self.pace.listening(listening, self.time_ns));
        self.pace.wait(self.time_ns);
    }

    /// The log lines read since the last call.
    pub fn take_log(&mut self) -> Vec<String> {
        std::mem::take(&mut self.log)
    }

    /// What happens between two slices of execution: an exception
    /// return, a fault, sleep until the next event, time moved on for
    /// every model, and the pending exceptions taken.
    /// A system reset a model or the core asked for: the chip restarted
    /// ([`crate::reset`]) while the run allows it, else the run stops
    /// naming it and the fault before it.
    fn take_reset(&mut self) -> Result<(), String> {
        let s = self.uc.get_data_mut();
        if s.shared.flash.cut {
            let Some(fresh) = self.rebuild else {
                return Err("a power cut, in a run that cannot restart the chip".into());
            };
            let pc = self.uc.reg_read(RegisterARM::PC).unwrap_or(0);
            let s = self.uc.get_data();
            let torn = &s.shared.flash.torn;
            self.notes.push(format!(
                "power cut at flash operation {} (cycle {}, {}){}: the chip powers up again, the SRAM lost, the flash kept",
                s.shared.flash.cut_at.unwrap_or(s.shared.flash.started),
                s.now,
                s.image.describe(pc),
                match (torn.first(), torn.len(), s.shared.flash.mixed) {
                    (_, _, Some((at, changed, of))) =>
                        format!(", tearing it: {changed} of the {of} bits it was changing from {at:#010x} changed"),
                    (Some(first), n, _) if s.shared.flash.tear =>
                        format!(", tearing it: {n} flash words torn from {first:#010x}"),
                    _ => String::new(),
                }
            ));
            // What the image logged before the cut is read; the decoder
            // then starts afresh (a frame cut in half is gone with the
            // SRAM).
            if let Some(rtt) = &mut self.rtt {
                self.log.extend(rtt.lines(&mut self.uc));
                rtt.restart();
            }
            self.restarted();
            crate::reset::power_cycle(&mut self.uc, fresh())?;
            return crate::torn_word::watch(&mut self.uc);
        }
        let cause = if s.scs.reset_requested {
            Some(ResetCause::Software)
        } else {
            s.shared.reset.take()
        };
        let Some(cause) = cause else {
            return Ok(());
        };
        let why = match cause {
            ResetCause::Software => "SCB_AIRCR SYSRESETREQ".to_string(),
            ResetCause::Watchdog { after_ms } => {
                format!("the independent watchdog expired, {after_ms} ms without a reload")
            }
        };
        let after = s
            .scs
            .fault_reason
            .as_ref()
            .map(|f| format!(" after {f}"))
            .unwrap_or_default();
        match self.rebuild {
            Some(fresh) if self.resets_left > 0 => {
                self.resets_left -= 1;
                self.notes.push(format!(
                    "system reset at cycle {} ({:.3} s of the chip's time; {why}{after}): the core restarts, the peripherals at their reset values, the RAM kept",
                    s.now,
                    pace::secs(self.time_ns)
                ));
                self.restarted();
                crate::reset::system_reset(&mut self.uc, cause, fresh())
            }
            _ => Err(format!(
                "the chip resets ({why}){after}; this run allows no {}reset (--resets N)",
                if self.rebuild.is_some() {
                    "further "
                } else {
                    ""
                }
            )),
        }
    }

    /// After a reset: the MAC's receiver is off (the model built anew
    /// holds its reset values; the wire keeps only what is outside).
    fn restarted(&mut self) {
        self.uc.get_data_mut().shared.link.listening = false;
        self.pace.restarted();
    }

    /// What the machine said since the last call (resets).
    pub fn take_notes(&mut self) -> Vec<String> {
        std::mem::take(&mut self.notes)
    }

    fn between_slices(&mut self, deadline: u64) -> Result<(), String> {
        let slice = self.slice();
        let uc = &mut self.uc;
        if let Some(ret) = uc.get_data_mut().exception_return.take() {
            exceptions::leave(uc, ret)?;
        }
        if let Some(at) = uc.get_data_mut().yield_at.take() {
            crate::hooks::step_over_yield(uc, at)?;
        }
        if let Some(fault) = uc.get_data_mut().fault.take() {
            exceptions::take_fault(uc, fault)?;
        }
        crate::mpu_enforce::sync(uc)?;
        self.take_reset()?;
        let uc = &mut self.uc;
        if let Some((pc, size, wfe)) = uc.get_data_mut().sleeping.take() {
            let s = uc.get_data_mut();
            if wfe && s.event {
                s.event = false;
            } else {
                loop {
                    crate::access::advance_models(uc)?;
                    if exceptions::next(uc).is_some() {
                        break;
                    }
                    let s = uc.get_data_mut();
                    let Some(t) = s.bus.next_event(s.now) else {
                        return Err(if wfe { "WFE" } else { "WFI" }.to_string()
                            + " with no interrupt pending, enabled or due: the core sleeps forever");
                    };
                    let t = t.max(s.now + 1);
                    let horizon = deadline.min(s.now.saturating_add(slice));
                    if t >= horizon {
                        let deadline = horizon;
                        s.slept += deadline.saturating_sub(s.now);
                        s.now = deadline;
                        // Resume at the sleep instruction next time.
                        s.sleeping = Some((pc, size, wfe));
                        return Ok(());
                    }
                    s.slept += t - s.now;
                    s.now = t;
                }
            }
            let _ = uc.reg_write(RegisterARM::PC, u64::from(pc + size));
        }
        crate::access::advance_models(uc)?;
        while let Some(exc) = exceptions::next(uc) {
            let pc = uc.reg_read(RegisterARM::PC).unwrap_or(0) as u32;
            exceptions::enter(uc, exc, pc)?;
        }
        Ok(())
    }

    /// The PC and its function.
    pub fn where_now(&self) -> String {
        let pc = self.uc.reg_read(RegisterARM::PC).unwrap_or(0);
        format!("PC {pc:#010x} in {}", self.uc.get_data().image.describe(pc))
    }

    /// Virtual time, in core cycles.
    pub fn now(&self) -> u64 {
        self.uc.get_data().now
    }
}

/// `--until`: a run that ends at a function's entry.
mod until;

pub mod pace;

/// A machine for the engine's own unit tests.
#[cfg(test)]
pub(crate) mod testing;
