//! The MPU's write permissions enforced: a privileged write that the MPU
//! forbids is a MemManage fault on silicon (DACCVIOL, with MMFAR), taken
//! precisely on the store, the store not done; a fault while stacking an
//! exception frame is MSTKERR. The firmware's stack guard
//! (hal-board `stack_guard`) is such a region.
//!
//! Sources: the ARMv7-M Architecture Reference Manual (DDI 0403E) B3.5
//! (PMSAv7: regions, subregions, the highest-numbered region wins, AP
//! encodings, HFNMIENA) and B1.5.14-15 (derived faults on stacking); the
//! STM32F7/H7 programming manual PM0253 §4.6 (RASR fields).
//!
//! How: unicorn keeps RAM on its fast path, so the pages (1 KiB on an
//! M-profile core) that hold a write-denied range are protected in unicorn
//! and every store into them reaches [`on_write`]; the stores the MPU
//! allows are done there, the others refused, which stops the core on the
//! store with nothing after it executed (tests/cpu.rs proves both).
//! Not modelled: unprivileged code (the firmware runs privileged), read
//! and execute permissions (AP = 000 reads, XN), the background map for
//! addresses no region covers (PRIVDEFENA is what the images set).

use crate::chip::Access;
use crate::exceptions::{Fault, DACCVIOL, MEM_MANAGE, MMARVALID};
use crate::machine::State;
use crate::scs::Scs;
use unicorn_engine::{Prot, RegisterARM, Unicorn};

/// A range the MPU forbids privileged writes to, and the region that
/// decides it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Denied {
    pub start: u64,
    pub end: u64,
    pub region: usize,
    /// The region's AP field (B3.5.9): 000 no access, 101/110/111 read-only.
    pub ap: u32,
}

/// AP values that forbid a privileged write (B3.5.9 Table B3-15).
fn denies_write(ap: u32) -> bool {
    matches!(ap, 0b000 | 0b101 | 0b110 | 0b111)
}

/// Every write-denied range the MPU as programmed makes: for each address,
/// the highest-numbered enabled region whose enabled subregion covers it
/// decides (B3.5.3); none while MPU_CTRL.ENABLE is clear.
pub fn write_denied(scs: &Scs) -> Vec<Denied> {
    if scs.mpu_ctrl & 1 == 0 {
        return Vec::new();
    }
    // (start, end, region) of every enabled subregion.
    let mut spans: Vec<(u64, u64, usize)> = Vec::new();
    for (i, r) in scs.mpu.iter().enumerate().take(scs.mpu_regions as usize) {
        let Some((base, end)) = r.range() else {
            continue;
        };
        let size = end - base;
        let srd = (r.rasr >> 8) & 0xFF;
        // Subregions exist for regions of 256 bytes or more (B3.5.4).
        if size >= 256 && srd != 0 {
            let sub = size / 8;
            for k in (0..8u64).filter(|k| srd & (1 << k) == 0) {
                spans.push((base + k * sub, base + (k + 1) * sub, i));
            }
        } else {
            spans.push((base, end, i));
        }
    }
    let mut cuts: Vec<u64> = spans.iter().flat_map(|s| [s.0, s.1]).collect();
    cuts.sort_unstable();
    cuts.dedup();
    let mut out: Vec<Denied> = Vec::new();
    for w in cuts.windows(2) {
        let (a, b) = (w[0], w[1]);
        let Some(&(_, _, i)) = spans
            .iter()
            .filter(|s| s.0 <= a && b <= s.1)
            .max_by_key(|s| s.2)
        else {
            continue;
        };
        let ap = scs.mpu[i].ap();
        if !denies_write(ap) {
            continue;
        }
        match out.last_mut() {
            Some(d) if d.end == a && d.region == i => d.end = b,
            _ => out.push(Denied {
                start: a,
                end: b,
                region: i,
                ap,
            }),
        }
    }
    out
}

/// The denied range `[addr, addr + len)` touches, if any.
pub fn hit(denied: &[Denied], addr: u64, len: u64) -> Option<Denied> {
    denied
        .iter()
        .copied()
        .find(|d| addr < d.end && d.start < addr + len)
}

/// The pages (of `page` bytes) that hold a denied range.
pub fn pages(denied: &[Denied], page: u64) -> Vec<u64> {
    let mut out: Vec<u64> = denied
        .iter()
        .flat_map(|d| (d.start / page..d.end.div_ceil(page)).map(move |p| p * page))
        .collect();
    out.dedup();
    out
}

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

/// How a refused write reads in a report: the region and what it is.
pub fn describe(d: &Denied, addr: u64, size: usize, sp: u64) -> String {
    let what = if d.ap == 0 { "no access" } else { "read-only" };
    let mut s = format!(
        "a {size}-byte write at {addr:#010x} into MPU region {} ({:#010x}..{:#010x}, {what})",
        d.region, d.start, d.end
    );
    if sp < d.end + 1024 {
        s.push_str(&format!(
            ": the stack (SP {sp:#010x}) ran into the MPU's stack guard"
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scs_with(regions: &[(usize, u32, u32)]) -> Scs {
        let mut scs = Scs::new();
        scs.mpu_regions = 8;
        scs.mpu_ctrl = 0b101;
        for &(i, rbar, rasr) in regions {
            scs.mpu[i].rbar = rbar;
            scs.mpu[i].rasr = rasr;
        }
        scs
    }

    /// RASR: enabled, SIZE for 2^(n) bytes, AP, SRD.
    fn rasr(log2: u32, ap: u32, srd: u32) -> u32 {
        1 | ((log2 - 1) << 1) | (srd << 8) | (ap << 24)
    }

    #[test]
    fn a_read_only_region_above_a_read_write_one_is_denied_and_wins() {
        // Region 0: 512 KiB read-write; region 7: the 256-byte guard.
        let scs = scs_with(&[
            (0, 0x2000_0000, rasr(19, 0b011, 0)),
            (7, 0x2000_0100, rasr(8, 0b110, 0)),
        ]);
        let d = write_denied(&scs);
        assert_eq!(
            d,
            [Denied {
                start: 0x2000_0100,
                end: 0x2000_0200,
                region: 7,
                ap: 0b110
            }]
        );
        assert!(hit(&d, 0x2000_01FC, 4).is_some());
        assert!(hit(&d, 0x2000_0200, 4).is_none());
        assert!(hit(&d, 0x2000_00FC, 4).is_none());
        assert_eq!(pages(&d, 1024), [0x2000_0000]);
    }

    #[test]
    fn a_higher_read_write_region_lifts_a_lower_denial() {
        let scs = scs_with(&[
            (1, 0x2000_0000, rasr(10, 0b101, 0)),
            (2, 0x2000_0200, rasr(9, 0b011, 0)),
        ]);
        assert_eq!(
            write_denied(&scs)
                .iter()
                .map(|d| (d.start, d.end))
                .collect::<Vec<_>>(),
            [(0x2000_0000, 0x2000_0200)]
        );
    }

    #[test]
    fn disabled_subregions_and_a_disabled_mpu_deny_nothing() {
        // 2 KiB read-only with subregions 0-6 disabled: only the last 256 B.
        let mut scs = scs_with(&[(3, 0x2000_0800, rasr(11, 0b111, 0x7F))]);
        assert_eq!(
            write_denied(&scs)
                .iter()
                .map(|d| (d.start, d.end))
                .collect::<Vec<_>>(),
            [(0x2000_0F00, 0x2000_1000)]
        );
        scs.mpu_ctrl = 0;
        assert!(write_denied(&scs).is_empty());
    }

    #[test]
    fn the_report_names_the_guard_when_the_stack_pointer_is_at_it() {
        let d = Denied {
            start: 0x2000_0100,
            end: 0x2000_0200,
            region: 7,
            ap: 0b110,
        };
        let s = describe(&d, 0x2000_01F8, 4, 0x2000_01F0);
        assert!(s.contains("region 7") && s.contains("stack guard"), "{s}");
        assert!(!describe(&d, 0x2000_01F8, 4, 0x2001_0000).contains("stack"));
    }
}
