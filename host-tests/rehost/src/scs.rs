//! The Cortex-M7's own peripherals on the private peripheral bus, which
//! unicorn does not model: the NVIC, SCB (with the cache maintenance
//! operations, recorded), SysTick, the MPU, DWT, the debug control block
//! and the FPU's control registers.
//!
//! Sources: the ARMv7-M Architecture Reference Manual (DDI 0403E) B3.2
//! (SCS), B3.3 (SysTick), B3.4 (NVIC), B3.5 (PMSAv7 MPU), C1.8 (DWT);
//! the Cortex-M7 Technical Reference Manual (DDI 0489F) §3.3 and §4.1 for
//! the ID and cache identification values; CMSIS `core_cm7.h` for the
//! offsets. An offset no row names stops the run.

use crate::bus::{narrow, widen, Cx, Refusal};

/// External interrupts the NVIC implements (IRQ 0..).
pub const IRQS: usize = 160;

/// One MPU region as programmed (RBAR and RASR).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MpuRegion {
    pub rbar: u32,
    pub rasr: u32,
}

impl MpuRegion {
    /// Whether the region is on, and the address range it covers.
    pub fn range(&self) -> Option<(u64, u64)> {
        if self.rasr & 1 == 0 {
            return None;
        }
        let size = 1u64 << (((self.rasr >> 1) & 0x1f) + 1);
        let base = u64::from(self.rbar & !0x1f) & !(size - 1);
        Some((base, base + size))
    }
    /// AP (RASR[26:24]): 0 = no access at any privilege.
    pub fn ap(&self) -> u32 {
        (self.rasr >> 24) & 7
    }
    /// XN (RASR[28]).
    pub fn execute_never(&self) -> bool {
        self.rasr & (1 << 28) != 0
    }
    /// Cacheable per TEX/C/B (RASR[21:16]): normal memory with C set or
    /// TEX=1xx with an inner policy other than non-cacheable.
    pub fn cacheable(&self) -> bool {
        let tex = (self.rasr >> 19) & 7;
        let c = (self.rasr >> 17) & 1;
        let b = (self.rasr >> 16) & 1;
        if tex & 4 != 0 {
            // Inner policy in C:B.
            return (c << 1 | b) != 0;
        }
        // TEX=000/001 with C=1 (write-through or write-back).
        c == 1 && tex & 2 == 0
    }
}

/// The system control space.
#[derive(Clone, Debug)]
pub struct Scs {
    pub enabled: [bool; IRQS],
    pub pending: [bool; IRQS],
    pub priority: [u8; IRQS],
    /// SHPR1-3: the system handlers' priorities (exceptions 4-15).
    pub shpr: [u8; 12],
    pub vtor: u32,
    pub scr: u32,
    pub ccr: u32,
    pub aircr_prigroup: u32,
    pub shcsr: u32,
    pub cpacr: u32,
    pub csselr: u32,
    pub fpccr: u32,
    pub fpcar: u32,
    pub fpdscr: u32,
    /// BFAR: the address of the last precise bus fault (a torn H743
    /// flash word's read, `crate::torn_word`).
    pub bfar: u32,
    pub pendsv: bool,
    pub systick: SysTick,
    pub mpu_ctrl: u32,
    pub mpu_rnr: u32,
    pub mpu: [MpuRegion; 16],
    pub dwt_ctrl: u32,
    /// Cycle counter value at `dwt_base_cycle` (DWT_CYCCNT counts core
    /// cycles while DWT_CTRL.CYCCNTENA is set).
    pub dwt_cyccnt: u32,
    pub dwt_since: Option<u64>,
    pub dwt_unlocked: bool,
    pub demcr: u32,
    /// Cache maintenance operations, by register name, in order.
    pub cache_ops: Vec<(&'static str, u32)>,
    /// MPU regions the core has (MPU_TYPE.DREGION: 8 on the STM32F7, 16 on
    /// the STM32H7; PM0253 §4.6).
    pub mpu_regions: u32,
    /// SysTick's exception is pending (ICSR PENDSTSET).
    pub systick_pending: bool,
    /// Why the last fault was taken, and as which exception (for the
    /// report when the image resets after it).
    pub fault_reason: Option<String>,
    /// The fault status and address registers (B3.2.15-B3.2.18): CFSR
    /// (MMFSR, BFSR, UFSR), HFSR, MMFAR; written by the faults the model
    /// takes, cleared by writing ones.
    pub cfsr: u32,
    pub hfsr: u32,
    pub mmfar: u32,
    /// A software reset was requested (AIRCR.SYSRESETREQ).
    pub reset_requested: bool,
}

/// SysTick (B3.3).
#[derive(Clone, Copy, Debug, Default)]
pub struct SysTick {
    pub ctrl: u32,
    pub load: u32,
    pub val: u32,
}

impl Scs {
    pub fn new() -> Scs {
        Scs {
            enabled: [false; IRQS],
            pending: [false; IRQS],
            priority: [0; IRQS],
            shpr: [0; 12],
            vtor: 0,
            scr: 0,
            // STKALIGN set out of reset on the Cortex-M7.
            ccr: 0x0000_0200,
            aircr_prigroup: 0,
            shcsr: 0,
            cpacr: 0,
            csselr: 0,
            fpccr: 0xC000_0000,
            fpcar: 0,
            fpdscr: 0,
            bfar: 0,
            pendsv: false,
            systick: SysTick::default(),
            mpu_ctrl: 0,
            mpu_rnr: 0,
            mpu: [MpuRegion::default(); 16],
            dwt_ctrl: 0x4000_0000,
            dwt_cyccnt: 0,
            dwt_since: None,
            dwt_unlocked: false,
            demcr: 0,
            cache_ops: Vec::new(),
            reset_requested: false,
            systick_pending: false,
            mpu_regions: 8,
            fault_reason: None,
            cfsr: 0,
            hfsr: 0,
            mmfar: 0,
        }
    }

    fn cyccnt(&self, now: u64) -> u32 {
        match self.dwt_since {
            Some(since) => self.dwt_cyccnt.wrapping_add((now - since) as u32),
            None => self.dwt_cyccnt,
        }
    }

    pub fn read(&mut self, addr: u32, size: u32, cx: &mut Cx) -> Result<u32, Refusal> {
        let word = addr & !3;
        let v = match word {
            0xE000_E004 => (IRQS as u32 / 32).saturating_sub(1), // ICTR
            0xE000_E010 => {
                let v = self.systick.ctrl;
                self.systick.ctrl &= !(1 << 16); // COUNTFLAG clears on read
                v
            }
            0xE000_E014 => self.systick.load,
            0xE000_E018 => self.systick.val,
            0xE000_E01C => 0x4000_0000, // CALIB: no reference clock skew info
            0xE000_E100..=0xE000_E13C => bits(&self.enabled, word - 0xE000_E100),
            0xE000_E180..=0xE000_E1BC => bits(&self.enabled, word - 0xE000_E180),
            0xE000_E200..=0xE000_E23C => bits(&self.pending, word - 0xE000_E200),
            0xE000_E280..=0xE000_E2BC => bits(&self.pending, word - 0xE000_E280),
            0xE000_E300..=0xE000_E33C => 0, // IABR: active bits (none tracked here)
            0xE000_E400..=0xE000_E4FF => {
                let i = (word - 0xE000_E400) as usize;
                u32::from_le_bytes(
                    [0, 1, 2, 3].map(|k| self.priority.get(i + k).copied().unwrap_or(0)),
                )
            }
            0xE000_ED00 => 0x411F_C272, // CPUID: Cortex-M7 r1p2
            0xE000_ED04 => u32::from(self.pendsv) << 28,
            0xE000_ED08 => self.vtor,
            0xE000_ED0C => 0xFA05_0000 | (self.aircr_prigroup << 8),
            0xE000_ED10 => self.scr,
            0xE000_ED14 => self.ccr,
            0xE000_ED18..=0xE000_ED20 => {
                let i = (word - 0xE000_ED18) as usize;
                u32::from_le_bytes([
                    self.shpr[i],
                    self.shpr[i + 1],
                    self.shpr[i + 2],
                    self.shpr[i + 3],
                ])
            }
            0xE000_ED24 => self.shcsr,
            0xE000_ED28 => self.cfsr,
            0xE000_ED2C => self.hfsr,
            0xE000_ED34 => self.mmfar,
            0xE000_ED38 => self.bfar,
            // DFSR, AFSR: no debug event is modelled.
            0xE000_ED30 | 0xE000_ED3C => 0,
            0xE000_ED78 => 0x0900_0003, // CLIDR: L1 instruction and data caches
            0xE000_ED7C => 0x8303_C003, // CTR
            0xE000_ED80 => {
                // CCSIDR for CSSELR: 16 KiB 4-way data / 16 KiB 2-way instruction, 32-byte lines.
                if self.csselr & 1 == 0 {
                    0xF00F_E019
                } else {
                    0xF01F_E009
                }
            }
            0xE000_ED84 => self.csselr,
            0xE000_ED88 => self.cpacr,
            0xE000_ED90 => self.mpu_regions << 8, // MPU_TYPE: DREGION
            0xE000_ED94 => self.mpu_ctrl,
            0xE000_ED98 => self.mpu_rnr,
            0xE000_ED9C => self.mpu[(self.mpu_rnr & 15) as usize].rbar | (self.mpu_rnr & 15),
            0xE000_EDA0 => self.mpu[(self.mpu_rnr & 15) as usize].rasr,
            0xE000_EDF0 => 0, // DHCSR: no debugger attached
            0xE000_EDFC => self.demcr,
            0xE000_EF34 => self.fpccr,
            0xE000_EF38 => self.fpcar,
            0xE000_EF3C => self.fpdscr,
            0xE000_1000 => self.dwt_ctrl | u32::from(self.dwt_since.is_some()),
            0xE000_1004 => self.cyccnt(cx.now),
            0xE000_1FB4 => u32::from(!self.dwt_unlocked) << 1 | 1, // LSR: lock present, locked?
            _ => {
                return Err(format!(
                "the system control space has no register at {addr:#010x} that this model knows"
            ))
            }
        };
        Ok(narrow(v, addr, size))
    }

    pub fn write(&mut self, addr: u32, size: u32, value: u32, cx: &mut Cx) -> Result<(), Refusal> {
        let word = addr & !3;
        let old = self.read(word, 4, cx).unwrap_or(0);
        let v = widen(old, addr, size, value);
        match word {
            0xE000_E010 => self.systick.ctrl = v & 0x7,
            0xE000_E014 => self.systick.load = v & 0x00FF_FFFF,
            0xE000_E018 => self.systick.val = 0,
            0xE000_E100..=0xE000_E13C => set_bits(&mut self.enabled, word - 0xE000_E100, v, true),
            0xE000_E180..=0xE000_E1BC => set_bits(&mut self.enabled, word - 0xE000_E180, v, false),
            0xE000_E200..=0xE000_E23C => set_bits(&mut self.pending, word - 0xE000_E200, v, true),
            0xE000_E280..=0xE000_E2BC => set_bits(&mut self.pending, word - 0xE000_E280, v, false),
            0xE000_E400..=0xE000_E4FF => {
                let i = (word - 0xE000_E400) as usize;
                for (k, b) in v.to_le_bytes().into_iter().enumerate() {
                    if let Some(p) = self.priority.get_mut(i + k) {
                        // Four priority bits on the STM32s: the low four read as zero.
                        *p = b & 0xF0;
                    }
                }
            }
            0xE000_EF00 => {
                let irq = (v & 0x1FF) as usize;
                if let Some(p) = self.pending.get_mut(irq) {
                    *p = true;
                }
            }
            0xE000_ED04 => {
                if v & (1 << 26) != 0 {
                    self.systick_pending = true;
                }
                if v & (1 << 25) != 0 {
                    self.systick_pending = false;
                }
                if v & (1 << 28) != 0 {
                    self.pendsv = true;
                }
                if v & (1 << 27) != 0 {
                    self.pendsv = false;
                }
            }
            0xE000_ED08 => self.vtor = v & 0xFFFF_FF80,
            0xE000_ED0C => {
                if v >> 16 != 0x05FA {
                    return Err(format!("SCB_AIRCR written without its key 0x05FA ({v:#010x}): the write is ignored on silicon"));
                }
                self.aircr_prigroup = (v >> 8) & 7;
                if v & (1 << 2) != 0 {
                    self.reset_requested = true;
                }
            }
            0xE000_ED10 => self.scr = v & 0x16,
            0xE000_ED14 => self.ccr = v & 0x0007_031B,
            0xE000_ED18..=0xE000_ED20 => {
                let i = (word - 0xE000_ED18) as usize;
                for (k, b) in v.to_le_bytes().into_iter().enumerate() {
                    self.shpr[i + k] = b & 0xF0;
                }
            }
            0xE000_ED24 => self.shcsr = v,
            // Write-one-to-clear: a byte write (MMFSR, BFSR) clears only
            // the ones it writes.
            0xE000_ED28 => self.cfsr &= !widen(0, addr, size, value),
            0xE000_ED2C => self.hfsr &= !widen(0, addr, size, value),
            0xE000_ED34 => self.mmfar = v,
            0xE000_ED30 | 0xE000_ED38 | 0xE000_ED3C => {}
            0xE000_ED84 => self.csselr = v & 1,
            0xE000_ED88 => self.cpacr = v & 0x00F0_0000,
            0xE000_ED94 => self.mpu_ctrl = v & 7,
            0xE000_ED98 => self.mpu_rnr = v & 0xFF,
            0xE000_ED9C => {
                if v & 0x10 != 0 {
                    self.mpu_rnr = v & 15;
                }
                self.mpu[(self.mpu_rnr & 15) as usize].rbar = v & !0x1F;
            }
            0xE000_EDA0 => self.mpu[(self.mpu_rnr & 15) as usize].rasr = v,
            0xE000_EDFC => self.demcr = v & 0x010F_07F1,
            0xE000_EF34 => self.fpccr = v,
            0xE000_EF38 => self.fpcar = v,
            0xE000_EF3C => self.fpdscr = v,
            // Cache maintenance (ARMv7-M B2.2.7; Cortex-M7 TRM §4.1): recorded.
            0xE000_EF50 => self.cache_ops.push(("ICIALLU", v)),
            0xE000_EF58 => self.cache_ops.push(("ICIMVAU", v)),
            0xE000_EF5C => self.cache_ops.push(("DCIMVAC", v)),
            0xE000_EF60 => self.cache_ops.push(("DCISW", v)),
            0xE000_EF64 => self.cache_ops.push(("DCCMVAU", v)),
            0xE000_EF68 => self.cache_ops.push(("DCCMVAC", v)),
            0xE000_EF6C => self.cache_ops.push(("DCCSW", v)),
            0xE000_EF70 => self.cache_ops.push(("DCCIMVAC", v)),
            0xE000_EF74 => self.cache_ops.push(("DCCISW", v)),
            0xE000_EF78 => self.cache_ops.push(("BPIALL", v)),
            0xE000_1000 => {
                self.dwt_ctrl = (self.dwt_ctrl & 0xF000_0000) | (v & 0x0FFF_FFFE);
                let on = v & 1 != 0;
                if on && self.dwt_since.is_none() {
                    if self.demcr & (1 << 24) == 0 {
                        return Err("DWT_CTRL.CYCCNTENA set while DEMCR.TRCENA is clear: the DWT is off and the counter stays 0".into());
                    }
                    self.dwt_since = Some(cx.now);
                } else if !on {
                    self.dwt_cyccnt = self.cyccnt(cx.now);
                    self.dwt_since = None;
                }
            }
            0xE000_1004 => {
                self.dwt_cyccnt = v;
                if self.dwt_since.is_some() {
                    self.dwt_since = Some(cx.now);
                }
            }
            0xE000_1FB0 => self.dwt_unlocked = v == 0xC5AC_CE55,
            _ => return Err(format!("the system control space has no writable register at {addr:#010x} that this model knows")),
        }
        Ok(())
    }
}

impl Default for Scs {
    fn default() -> Scs {
        Scs::new()
    }
}

fn bits(flags: &[bool], byte_offset: u32) -> u32 {
    let first = byte_offset as usize * 8;
    (0..32).fold(0, |acc, i| {
        acc | (u32::from(flags.get(first + i).copied().unwrap_or(false)) << i)
    })
}

fn set_bits(flags: &mut [bool], byte_offset: u32, v: u32, to: bool) {
    let first = byte_offset as usize * 8;
    for i in 0..32 {
        if v & (1 << i) != 0 {
            if let Some(f) = flags.get_mut(first + i) {
                *f = to;
            }
        }
    }
}
