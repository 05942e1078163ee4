//! Numbers the way a real IRC5 writes them (see
//! `../shared/rri/real-world/captured-RobData.xml`): about 6 significant
//! digits, exponent notation with a two-digit exponent for small values
//! (`1.21592e-06`), timestamps with 6 decimals (`765.315969`).

/// `%g`-style with 6 significant digits, as the controller's C runtime.
pub fn g6(x: f64) -> String {
    if !x.is_finite() {
        return "0".into();
    }
    if x == 0.0 {
        return "0".into();
    }
    let exp = x.abs().log10().floor() as i32;
    // Rounding can carry into the next power of ten (999999.5 → 1e+06).
    let rounded: f64 = format!("{x:.5e}").parse().unwrap_or(x);
    let exp = if rounded.abs() >= 10f64.powi(exp + 1) {
        exp + 1
    } else {
        exp
    };
    if !(-5..6).contains(&exp) {
        let s = format!("{x:.5e}");
        let (mantissa, e) = s.split_once('e').unwrap_or((&s, "0"));
        let e: i32 = e.parse().unwrap_or(0);
        let mantissa = trim_zeros(mantissa);
        format!("{mantissa}e{}{:02}", if e < 0 { '-' } else { '+' }, e.abs())
    } else {
        let decimals = (5 - exp).max(0) as usize;
        trim_zeros(&format!("{x:.decimals$}")).to_string()
    }
}

fn trim_zeros(s: &str) -> &str {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.')
    } else {
        s
    }
}

/// A controller timestamp: seconds with 6 decimals.
pub fn ts(seconds: f64) -> String {
    format!("{seconds:.6}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn like_the_captured_irc5_message() {
        assert_eq!(g6(397.589), "397.589");
        assert_eq!(g6(-34.9865), "-34.9865");
        assert_eq!(g6(-0.000497347), "-0.000497347");
        assert_eq!(g6(1.21592e-06), "1.21592e-06");
        assert_eq!(g6(90.0006), "90.0006");
        assert_eq!(g6(0.0), "0");
        assert_eq!(g6(1620.0), "1620");
        assert_eq!(g6(1234567.0), "1.23457e+06");
        assert_eq!(ts(765.315969), "765.315969");
    }
}
