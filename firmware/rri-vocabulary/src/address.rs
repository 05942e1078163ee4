//! IPv4 addresses as the user writes them: in Description.xml's
//! `<Network Address>` (G2) and in the build settings `RRI_CONTROLLER`,
//! `RRI_NETMASK`, `RRI_GATEWAY`.

/// Dotted-quad IPv4 text (`192.168.125.1`, whitespace around it allowed):
/// exactly four decimal octets, each 0–255. `None` for anything else,
/// including a host name, which the caller may accept on its own terms.
pub fn parse_ipv4(text: &str) -> Option<[u8; 4]> {
    let mut octets = [0u8; 4];
    let mut parts = text.trim().split('.');
    for octet in &mut octets {
        *octet = parts.next()?.parse().ok()?;
    }
    parts.next().is_none().then_some(octets)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn four_octets_and_nothing_else() {
        assert_eq!(parse_ipv4(" 192.168.125.1 "), Some([192, 168, 125, 1]));
        assert_eq!(parse_ipv4("0.0.0.0"), Some([0; 4]));
        for bad in [
            "192.168.125",
            "1.2.3.4.5",
            "256.1.1.1",
            "a.b.c.d",
            "",
            "1..2.3",
            "sensor.local",
        ] {
            assert_eq!(parse_ipv4(bad), None, "{bad}");
        }
    }
}
