//! A synchronous fault as the core records it before taking it: which
//! configurable fault, where, why, and the status bits it sets (ARMv7-M
//! Architecture Reference Manual, DDI 0403E, B1.5.14 and B3.2.15-B3.2.18).
//! Plain data: the machine takes it ([`crate::exceptions::take_fault`]).

/// The configurable faults' exception numbers (B1.5.2).
pub const MEM_MANAGE: u32 = 4;
pub const BUS_FAULT: u32 = 5;
pub const USAGE_FAULT: u32 = 6;

/// CFSR bits (B3.2.15): MMFSR DACCVIOL, MSTKERR, MMARVALID; UFSR
/// UNDEFINSTR. HFSR FORCED (B3.2.16).
pub const DACCVIOL: u32 = 1 << 1;
pub const MSTKERR: u32 = 1 << 4;
pub const MMARVALID: u32 = 1 << 7;
/// BFSR PRECISERR, BFARVALID (B3.2.15).
pub const PRECISERR: u32 = 1 << 9;
pub const BFARVALID: u32 = 1 << 15;
pub const UNDEFINSTR: u32 = 1 << 16;
pub const FORCED: u32 = 1 << 30;

/// A synchronous fault the core takes before its next instruction: the
/// configurable fault it is (MemManage, UsageFault), the address of the
/// instruction that faulted (stacked as the return address), why, and what
/// it sets in CFSR, MMFAR and BFAR.
#[derive(Clone, Debug)]
pub struct Fault {
    pub exc: u32,
    pub at: u32,
    pub why: String,
    pub cfsr: u32,
    pub mmfar: Option<u32>,
    pub bfar: Option<u32>,
}

impl Fault {
    /// An undefined instruction at `at` (UFSR UNDEFINSTR, B3.2.15).
    pub fn undefined_instruction(at: u32) -> Fault {
        Fault {
            exc: USAGE_FAULT,
            at,
            why: "an undefined instruction".to_string(),
            cfsr: UNDEFINSTR,
            mmfar: None,
            bfar: None,
        }
    }
}
