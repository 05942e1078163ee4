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
//! This file is the MPU as programmed (which ranges it denies); how the
//! machine makes unicorn check every store into them is `mpu_enforce.rs`.
//! Not modelled: unprivileged code (the firmware runs privileged), read
//! and execute permissions (AP = 000 reads, XN), the background map for
//! addresses no region covers (PRIVDEFENA is what the images set).

use crate::scs::Scs;

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
