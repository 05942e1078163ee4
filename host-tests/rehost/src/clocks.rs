//! The clock tree as the chip's RCC, PWR and FLASH registers have set it,
//! and the limits the chip's datasheet puts on it. Every model that
//! changes a clock, a voltage scale or the flash wait states calls
//! [`Clocks::check`] after the write: the write that breaks a limit is the
//! one that stops the run, as it is the one that would make silicon
//! misbehave.

/// Core cycles in `us` microseconds at the core clock in force, counted
/// at no less than `floor_hz` (the slowest clock the core can run from, so
/// that a wait begun before the clocks are known still ends); at least one.
pub fn core_cycles(clocks: &Clocks, floor_hz: u64, us: u64) -> u64 {
    (clocks.core_hz.max(floor_hz) * us / 1_000_000).max(1)
}

/// The figures the limits are checked against.
#[derive(Clone, Debug, Default)]
pub struct Clocks {
    /// The core clock (SYSCLK on the F7, sys_ck / D1CPRE on the H7), Hz.
    pub core_hz: u64,
    /// The AHB clock (HCLK; the AXI clock on the H7), Hz.
    pub hclk_hz: u64,
    /// APB clocks, Hz (APB1 and APB2 on the F7; APB1-4 on the H7).
    pub apb_hz: [u64; 4],
    /// Flash wait states (FLASH_ACR LATENCY).
    pub flash_latency: u32,
    /// H7 only: FLASH_ACR WRHIGHFREQ.
    pub flash_wrhighfreq: u32,
    /// The blocks whose RCC clock enable is set, by name.
    pub enabled: Vec<&'static str>,
    /// The limits in force (a function of the voltage scale and
    /// over-drive), set by the chip's PWR model.
    pub limits: Limits,
}

/// The maximum frequencies in the current power configuration.
#[derive(Clone, Copy, Debug, Default)]
pub struct Limits {
    pub core_hz: u64,
    pub hclk_hz: u64,
    pub apb_hz: [u64; 4],
    /// The wait states the flash needs at `hclk_hz` (from the chip's
    /// table), as a function.
    pub min_latency: Option<fn(u64) -> u32>,
    /// Which power configuration (for messages).
    pub label: &'static str,
}

impl Clocks {
    /// Every limit, checked against the tree as it stands.
    pub fn check(&self) -> Result<(), String> {
        let l = &self.limits;
        if l.core_hz != 0 && self.core_hz > l.core_hz {
            return Err(format!(
                "the core clock {} MHz is above {} MHz, the limit {}",
                mhz(self.core_hz),
                mhz(l.core_hz),
                l.label
            ));
        }
        if l.hclk_hz != 0 && self.hclk_hz > l.hclk_hz {
            return Err(format!(
                "HCLK {} MHz is above {} MHz, the limit {}",
                mhz(self.hclk_hz),
                mhz(l.hclk_hz),
                l.label
            ));
        }
        for (i, (hz, max)) in self.apb_hz.iter().zip(l.apb_hz).enumerate() {
            if max != 0 && *hz > max {
                return Err(format!(
                    "PCLK{} {} MHz is above {} MHz, the limit {}",
                    i + 1,
                    mhz(*hz),
                    mhz(max),
                    l.label
                ));
            }
        }
        if let Some(min) = l.min_latency {
            let need = min(self.hclk_hz);
            if self.flash_latency < need {
                return Err(format!(
                    "FLASH_ACR LATENCY is {} wait states with HCLK at {} MHz: the flash needs at least {need} {}",
                    self.flash_latency,
                    mhz(self.hclk_hz),
                    l.label
                ));
            }
        }
        Ok(())
    }
}

/// Hz as MHz with up to three decimals.
pub fn mhz(hz: u64) -> String {
    if hz.is_multiple_of(1_000_000) {
        format!("{}", hz / 1_000_000)
    } else {
        format!("{:.3}", hz as f64 / 1e6)
    }
}
