//! The machine: unicorn's Cortex-M7 with the chip's memories mapped, its
//! peripheral blocks and the core's system control space answered by the
//! models, the image loaded into flash, and virtual time counted in
//! retired instructions (one instruction a cycle of the core clock).
//!
//! Strict: the first access that nothing claims, a write into flash, or a
//! write a model refuses stops the run; [`Stop`] says where (the address,
//! the PC and the function the PC is in) and by which rule.

use crate::bus::{Bus, Cx};
use crate::chip::{Access, Chip};
use crate::clocks::Clocks;
use crate::image::Image;
use crate::scs::Scs;
use std::rc::Rc;
use unicorn_engine::{Arch, ArmCpuModel, HookType, MemType, Mode, Prot, RegisterARM, Unicorn};

/// Where the peripherals are: one window for the chip's buses (APB, AHB,
/// and on the H7 the D3 domain) and the core's private peripheral bus.
const PERIPHERALS: (u64, u64) = (0x4000_0000, 0x2000_0000);
const PPB: (u64, u64) = (0xE000_0000, 0x10_0000);

/// Why the run stopped.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Stop {
    /// The rule broken, or what ended the run.
    pub rule: String,
    /// The data address involved, if any.
    pub addr: Option<u64>,
    /// Where the core was, and the function that holds it.
    pub pc: u64,
    pub function: String,
    /// Virtual time of the stop, in core cycles.
    pub cycles: u64,
}

impl std::fmt::Display for Stop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.rule)?;
        if let Some(a) = self.addr {
            write!(f, " [address {a:#010x}]")?;
        }
        write!(
            f,
            " at PC {:#010x} in {} (cycle {})",
            self.pc, self.function, self.cycles
        )
    }
}

/// Everything the hooks reach.
pub struct State {
    pub chip: Chip,
    pub image: Rc<Image>,
    pub bus: Bus,
    pub scs: Scs,
    pub clocks: Clocks,
    /// Retired instructions (= core cycles).
    pub now: u64,
    /// The run ends when `now` reaches this.
    pub deadline: u64,
    pub stop: Option<Stop>,
    /// Interrupt lines raised by models since the last look.
    pub raised: Vec<u32>,
}

impl State {
    /// Records the first stop; later ones are consequences of it.
    fn refuse(&mut self, rule: String, addr: Option<u64>, pc: u64) {
        if self.stop.is_none() {
            self.stop = Some(Stop {
                rule,
                addr,
                pc,
                function: self.image.describe(pc),
                cycles: self.now,
            });
        }
    }
}

/// The emulated chip with its image.
pub struct Machine {
    pub uc: Unicorn<'static, State>,
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
            clocks,
            now: 0,
            deadline: u64::MAX,
            stop: None,
            raised: Vec::new(),
        };
        fn e(what: &'static str) -> impl Fn(unicorn_engine::uc_error) -> String {
            move |err| format!("unicorn: {what}: {err:?}")
        }
        let mut uc = Unicorn::new_with_data(Arch::ARM, Mode::THUMB | Mode::MCLASS, state)
            .map_err(e("open"))?;
        uc.ctl_set_cpu_model(ArmCpuModel::CORTEX_M7 as i32)
            .map_err(e("Cortex-M7"))?;
        for m in chip.memories {
            let prot = match m.access {
                Access::Rom => Prot::READ | Prot::EXEC,
                Access::Ram => Prot::ALL,
            };
            uc.mem_map(u64::from(m.base), u64::from(m.size), prot)
                .map_err(e(m.name))?;
        }
        for load in &image.loads {
            if chip.memory_at(load.addr).is_none() {
                return Err(format!(
                    "the image loads {} bytes at {:#010x}, where {} has no memory: is it built for this board?",
                    load.bytes.len(),
                    load.addr,
                    chip.name
                ));
            }
            uc.mem_write(load.addr, &load.bytes).map_err(e("load"))?;
        }
        // The factory data: a unique ID (fixed, so runs repeat) and the
        // flash size in KiB.
        uc.mem_write(
            u64::from(chip.uid_base),
            &[
                0x31, 0x00, 0x4b, 0x00, 0x11, 0x51, 0x38, 0x30, 0x33, 0x36, 0x38, 0x37,
            ],
        )
        .map_err(e("unique ID"))?;
        uc.mem_write(u64::from(chip.flash_size_base), &2048u16.to_le_bytes())
            .map_err(e("flash size"))?;

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
        // Virtual time: every retired instruction is one core cycle.
        uc.add_code_hook(1, 0, |uc, _addr, _size| {
            let s = uc.get_data_mut();
            s.now += 1;
            if s.now >= s.deadline {
                let _ = uc.emu_stop();
            }
        })
        .map_err(e("code hook"))?;
        uc.add_intr_hook(|uc, intno| {
            let pc = uc.reg_read(RegisterARM::PC).unwrap_or(0);
            uc.get_data_mut().refuse(
                format!("a CPU exception unicorn raised (#{intno})"),
                None,
                pc,
            );
            let _ = uc.emu_stop();
        })
        .map_err(e("interrupt hook"))?;

        let sp = image
            .word(u64::from(chip.boot))
            .ok_or("no vector table at the boot address")?;
        let reset = image
            .word(u64::from(chip.boot) + 4)
            .ok_or("no reset vector")?;
        uc.reg_write(RegisterARM::MSP, u64::from(sp))
            .map_err(e("MSP"))?;
        uc.reg_write(RegisterARM::SP, u64::from(sp))
            .map_err(e("SP"))?;
        uc.reg_write(RegisterARM::PC, u64::from(reset & !1))
            .map_err(e("PC"))?;
        Ok(Machine { uc })
    }

    /// Runs until a stop or `cycles` more cycles.
    pub fn run(&mut self, cycles: u64) -> Option<Stop> {
        let s = self.uc.get_data_mut();
        s.deadline = s.now.saturating_add(cycles);
        loop {
            let pc = self.uc.reg_read(RegisterARM::PC).unwrap_or(0);
            let result = self.uc.emu_start(pc | 1, 0, 0, 0);
            let pc = self.uc.reg_read(RegisterARM::PC).unwrap_or(0);
            let s = self.uc.get_data_mut();
            if let Some(stop) = &s.stop {
                return Some(stop.clone());
            }
            if let Err(err) = result {
                s.refuse(format!("unicorn stopped: {err:?}"), None, pc);
                return s.stop.clone();
            }
            if s.now >= s.deadline {
                return None;
            }
        }
    }

    /// Virtual time, in core cycles.
    pub fn now(&self) -> u64 {
        self.uc.get_data().now
    }
}

fn bus_read(uc: &mut Unicorn<State>, addr: u64, size: usize) -> u64 {
    let pc = uc.reg_read(RegisterARM::PC).unwrap_or(0);
    let s = uc.get_data_mut();
    let result = access(s, addr, size as u32, None);
    match result {
        Ok(v) => u64::from(v),
        Err(rule) => {
            s.refuse(rule, Some(addr), pc);
            let _ = uc.emu_stop();
            0
        }
    }
}

fn bus_write(uc: &mut Unicorn<State>, addr: u64, size: usize, value: u64) {
    let pc = uc.reg_read(RegisterARM::PC).unwrap_or(0);
    let s = uc.get_data_mut();
    if let Err(rule) = access(s, addr, size as u32, Some(value as u32)) {
        s.refuse(rule, Some(addr), pc);
        let _ = uc.emu_stop();
    }
}

/// One access to a peripheral or the system control space.
fn access(s: &mut State, addr: u64, size: u32, write: Option<u32>) -> Result<u32, String> {
    let a = addr as u32;
    let mut cx = Cx {
        now: s.now,
        clocks: &mut s.clocks,
        raise: &mut s.raised,
    };
    if addr >= PPB.0 {
        return match write {
            Some(v) => s.scs.write(a, size, v, &mut cx).map(|()| 0),
            None => s.scs.read(a, size, &mut cx),
        };
    }
    let kind = if write.is_some() { "write" } else { "read" };
    let Some((block, offset)) = s.bus.find(a) else {
        return Err(format!(
            "a {size}-byte {kind} that no memory or model claims"
        ));
    };
    let name = block.model.name();
    if let Some(clock) = block.clock {
        if !cx.clocks.enabled.contains(&clock) {
            return Err(format!("{name} {kind} at offset {offset:#x} with its clock off (RCC enable bit for {clock} clear): silicon ignores it"));
        }
    }
    block
        .model
        .advance(&mut cx)
        .map_err(|rule| format!("{name}: {rule}"))?;
    let result = match write {
        Some(v) => block.model.write(offset, size, v, &mut cx).map(|()| 0),
        None => block.model.read(offset, size, &mut cx),
    };
    result.map_err(|rule| {
        if rule.starts_with(name) {
            rule
        } else {
            format!("{name}: {rule}")
        }
    })
}
