//! What the chip's pins and system configuration connect, as the GPIO
//! and SYSCFG models have set it: the Ethernet model reads it to check
//! that the MAC really reaches the PHY (RMII selected, every RMII pin in
//! its alternate function).

/// Ports A..K, 16 pins each: (MODER value, alternate function).
#[derive(Clone, Debug, Default)]
pub struct Wiring {
    pub pins: [[(u8, u8); 16]; 11],
    /// SYSCFG selects RMII for the Ethernet MAC (F7: PMC MII_RMII_SEL;
    /// H7: PMCR EPIS = 100).
    pub rmii: bool,
}

/// The NUCLEO-144 boards' RMII wiring to the LAN8742A (UM1974, "Ethernet"
/// solder bridges at their defaults): pin, signal. Alternate function 11
/// on both chips (DS11532 Table 12, DS12110 Table 9).
pub const NUCLEO_RMII: &[(&str, &str)] = &[
    ("PA1", "RMII_REF_CLK"),
    ("PA2", "RMII_MDIO"),
    ("PA7", "RMII_CRS_DV"),
    ("PC1", "RMII_MDC"),
    ("PC4", "RMII_RXD0"),
    ("PC5", "RMII_RXD1"),
    ("PG11", "RMII_TX_EN"),
    ("PG13", "RMII_TXD0"),
    ("PB13", "RMII_TXD1"),
];

/// The alternate function of the Ethernet pins.
pub const AF_ETH: u8 = 11;

impl Wiring {
    /// Every NUCLEO RMII pin not in alternate-function mode with AF11, as
    /// "PG13 (RMII_TXD0): mode 1, AF0"; RMII not selected is named first.
    pub fn rmii_faults(&self) -> Vec<String> {
        let mut faults = Vec::new();
        if !self.rmii {
            faults.push("SYSCFG does not select RMII for the Ethernet MAC".to_string());
        }
        for (pin, signal) in NUCLEO_RMII {
            let port = (pin.as_bytes()[1] - b'A') as usize;
            let n: usize = pin[2..].parse().unwrap_or(0);
            let (mode, af) = self.pins[port][n];
            if mode != 2 || af != AF_ETH {
                faults.push(format!(
                    "{pin} ({signal}) is in mode {mode} with AF{af}, not alternate function AF{AF_ETH}"
                ));
            }
        }
        faults
    }

    /// [`Wiring::rmii_faults`] of the data path only (RMII selected,
    /// REF_CLK, CRS_DV, RXD, TX_EN, TXD), or of the management pins only
    /// (MDC, MDIO): the MAC moves frames without MDIO, and MDIO frames go
    /// out without the data pins.
    pub fn rmii_faults_of(&self, management: bool) -> Vec<String> {
        self.rmii_faults()
            .into_iter()
            .filter(|f| (f.contains("(RMII_MDIO)") || f.contains("(RMII_MDC)")) == management)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_rmii_pin_on_af11_with_rmii_selected_is_clean() {
        let mut w = Wiring::default();
        assert_eq!(w.rmii_faults().len(), NUCLEO_RMII.len() + 1);
        w.rmii = true;
        for (pin, _) in NUCLEO_RMII {
            let port = (pin.as_bytes()[1] - b'A') as usize;
            let n: usize = pin[2..].parse().unwrap();
            w.pins[port][n] = (2, AF_ETH);
        }
        assert!(w.rmii_faults().is_empty());
        w.pins[6][13] = (2, 0);
        assert_eq!(
            w.rmii_faults(),
            vec!["PG13 (RMII_TXD0) is in mode 2 with AF0, not alternate function AF11".to_string()]
        );
    }
}
