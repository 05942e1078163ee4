//! The MPU's write denials ([`crate::mpu`]) enforced on the core's
//! stores. unicorn keeps RAM on its fast path, so the pages (1 KiB on an
//! M-profile core) that hold a write-denied range are protected in unicorn
//! and every store into them reaches [`on_write`]; the stores the MPU
//! allows are done there, the others refused, which stops the core on the
//! store with nothing after it executed (tests/cpu.rs proves both), and
//! the MemManage fault is taken next.

use crate::chip::Access;
use crate::fault::{Fault, DACCVIOL, MEM_MANAGE, MMARVALID};
use crate::mpu::{describe, hit, pages, write_denied};
use crate::state::State;
use unicorn_engine::{Prot, RegisterARM, Unicorn};

/// unicorn's page size (1 KiB on an M-profile core).
fn page_size(uc: &Unicorn<State>) -> u64 {
    uc.ctl_get_page_size().map(u64::from).unwrap_or(1024)
}

/// Brings unicorn's page protection in line with the MPU after its
/// registers changed: the RAM pages holding a write-denied range
/// protected, the others given back their writes.
pub fn sync(uc: &mut Unicorn<State>) -> Result<(), String> {
    let s = uc.get_data();
    let seen = (s.scs.mpu_ctrl, s.scs.mpu);
    if seen == s.mpu_seen {
        return Ok(());
    }
    let denied = write_denied(&s.scs);
    let page = page_size(uc);
    let chip = s.chip;
    let wanted: Vec<u64> = pages(&denied, page)
        .into_iter()
        .filter(|&p| chip.memory_at(p).is_some_and(|m| m.access == Access::Ram))
        .collect();
    let old = s.mpu_pages.clone();
    for &p in old.iter().filter(|p| !wanted.contains(p)) {
        uc.mem_protect(p, page, Prot::ALL)
            .map_err(|e| format!("unicorn: unprotecting {p:#010x}: {e:?}"))?;
    }
    for &p in wanted.iter().filter(|p| !old.contains(p)) {
        uc.mem_protect(p, page, Prot::READ | Prot::EXEC)
            .map_err(|e| format!("unicorn: protecting {p:#010x}: {e:?}"))?;
    }
    let s = uc.get_data_mut();
    s.mpu_seen = seen;
    s.mpu_denied = denied;
    s.mpu_pages = wanted;
    Ok(())
}

/// Whether `addr` is in a page [`sync`] protected (else a write-protect
/// hit is a write into flash).
pub fn guarded_page(uc: &Unicorn<State>, addr: u64) -> bool {
    let page = page_size(uc);
    uc.get_data()
        .mpu_pages
        .iter()
        .any(|&p| (p..p + page).contains(&addr))
}

/// A store into a protected page: done here when the MPU allows it (or
/// does not apply: HardFault, NMI and FAULTMASK with HFNMIENA clear,
/// B3.5.1); else the MemManage fault is noted and the store refused, which
/// stops the core on it. Returns whether the store was done.
pub fn on_write(uc: &mut Unicorn<State>, addr: u64, size: usize, value: i64) -> bool {
    let exempt =
        uc.get_data().scs.mpu_ctrl & 2 == 0 && crate::exceptions::execution_priority(uc) < 0;
    let denied = hit(&uc.get_data().mpu_denied, addr, size as u64);
    match denied {
        Some(d) if !exempt => {
            let pc = uc.reg_read(RegisterARM::PC).unwrap_or(0);
            let sp = uc.reg_read(RegisterARM::SP).unwrap_or(0);
            uc.get_data_mut().fault = Some(Fault {
                exc: MEM_MANAGE,
                at: pc as u32,
                why: describe(&d, addr, size, sp),
                cfsr: DACCVIOL | MMARVALID,
                mmfar: Some(addr as u32),
                bfar: None,
            });
            let _ = uc.emu_stop();
            false
        }
        _ => {
            let bytes = value.to_le_bytes();
            uc.mem_write(addr, &bytes[..size.min(8)]).is_ok()
        }
    }
}
