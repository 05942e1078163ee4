//! `--fault` injection, so a sensor's supervision can be tested.
//! Deterministic: the same seed gives the same faults.

/// One fault kind and its parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fault {
    /// `drop:P`: do not send P % of the messages (their Ids are skipped).
    Drop(f64),
    /// `duplicate:P`: send P % of the messages twice.
    Duplicate(f64),
    /// `reorder:P`: swap P % of the messages with the one after.
    Reorder(f64),
    /// `pause:CYCLE:MS`: stop sending for MS ms at cycle CYCLE.
    Pause { at: u64, ms: u64 },
    /// `garbage:P`: in P % of the cycles also send a datagram of garbage.
    Garbage(f64),
    /// `oversize:P`: in P % of the cycles also send a 9000-byte datagram.
    Oversize(f64),
    /// `second-port:CYCLE`: from cycle CYCLE on, send from a second source
    /// port (a controller that reconnected).
    SecondPort { from: u64 },
}

pub const SPECS: &str = "drop:P, duplicate:P, reorder:P, pause:CYCLE:MS, garbage:P, oversize:P, second-port:CYCLE (P in percent)";

/// The faults that need datagrams (a TCP stream has no garbage datagram,
/// no size limit per message and no second source port).
pub const UDP_ONLY: &str = "garbage, oversize and second-port";

impl Fault {
    /// Reads `--fault` text; an error says what the kind needs.
    pub fn parse(spec: &str) -> Result<Fault, String> {
        let parts: Vec<&str> = spec.split(':').collect();
        let pct = |s: &str| -> Result<f64, String> {
            s.parse::<f64>()
                .ok()
                .filter(|p| (0.0..=100.0).contains(p))
                .ok_or_else(|| format!("--fault {spec}: `{s}` is not a percentage 0..100"))
        };
        let num = |s: &str| -> Result<u64, String> {
            s.parse::<u64>()
                .map_err(|_| format!("--fault {spec}: `{s}` is not a whole number"))
        };
        Ok(match parts.as_slice() {
            ["drop", p] => Fault::Drop(pct(p)?),
            ["duplicate", p] => Fault::Duplicate(pct(p)?),
            ["reorder", p] => Fault::Reorder(pct(p)?),
            ["pause", at, ms] => Fault::Pause {
                at: num(at)?,
                ms: num(ms)?,
            },
            ["garbage", p] => Fault::Garbage(pct(p)?),
            ["oversize", p] => Fault::Oversize(pct(p)?),
            ["second-port", from] => Fault::SecondPort { from: num(from)? },
            [kind, ..] => {
                let needs = match *kind {
                    "drop" | "duplicate" | "reorder" | "garbage" | "oversize" => {
                        format!("{kind} needs a percentage: {kind}:P, e.g. {kind}:1")
                    }
                    "pause" => "pause needs a cycle and a length: pause:CYCLE:MS (stop sending for MS ms at cycle CYCLE), e.g. pause:100:50".to_string(),
                    "second-port" => "second-port needs the cycle it starts at: second-port:CYCLE, e.g. second-port:200".to_string(),
                    _ => format!("no such fault; one of {SPECS}"),
                };
                return Err(format!("--fault {spec}: {needs}"));
            }
            [] => return Err(format!("--fault: empty; one of {SPECS}")),
        })
    }
}

/// The `--fault` spelling, as a user writes it.
impl std::fmt::Display for Fault {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Fault::Drop(p) => write!(f, "drop:{p}"),
            Fault::Duplicate(p) => write!(f, "duplicate:{p}"),
            Fault::Reorder(p) => write!(f, "reorder:{p}"),
            Fault::Pause { at, ms } => write!(f, "pause:{at}:{ms}"),
            Fault::Garbage(p) => write!(f, "garbage:{p}"),
            Fault::Oversize(p) => write!(f, "oversize:{p}"),
            Fault::SecondPort { from } => write!(f, "second-port:{from}"),
        }
    }
}

/// What to do in one cycle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Plan {
    pub drop: bool,
    pub duplicate: bool,
    /// Hold this message back and send it after the next one.
    pub reorder: bool,
    pub pause_ms: u64,
    pub garbage: bool,
    pub oversize: bool,
    pub second_port: bool,
}

/// The faults of a run and their random source (xorshift64*).
#[derive(Clone, Debug)]
pub struct Faults {
    faults: Vec<Fault>,
    state: u64,
}

impl Faults {
    pub fn new(faults: Vec<Fault>, seed: u64) -> Self {
        Faults {
            faults,
            state: seed | 1,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.faults.is_empty()
    }

    fn chance(&mut self, percent: f64) -> bool {
        self.state ^= self.state >> 12;
        self.state ^= self.state << 25;
        self.state ^= self.state >> 27;
        let r = self.state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11;
        (r as f64 / (1u64 << 53) as f64) * 100.0 < percent
    }

    pub fn plan(&mut self, cycle: u64) -> Plan {
        let mut p = Plan::default();
        for f in self.faults.clone() {
            match f {
                Fault::Drop(pct) => p.drop |= self.chance(pct),
                Fault::Duplicate(pct) => p.duplicate |= self.chance(pct),
                Fault::Reorder(pct) => p.reorder |= self.chance(pct),
                Fault::Pause { at, ms } if at == cycle => p.pause_ms = ms,
                Fault::Pause { .. } => {}
                Fault::Garbage(pct) => p.garbage |= self.chance(pct),
                Fault::Oversize(pct) => p.oversize |= self.chance(pct),
                Fault::SecondPort { from } => p.second_port |= cycle >= from,
            }
        }
        p
    }

    /// Faults that only make sense on UDP.
    pub fn udp_only(&self) -> Option<Fault> {
        self.faults.iter().copied().find(|f| {
            matches!(
                f,
                Fault::Garbage(_) | Fault::Oversize(_) | Fault::SecondPort { .. }
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_parse_and_bad_ones_say_why() {
        assert_eq!(Fault::parse("drop:5"), Ok(Fault::Drop(5.0)));
        assert_eq!(
            Fault::parse("pause:100:250"),
            Ok(Fault::Pause { at: 100, ms: 250 })
        );
        assert_eq!(
            Fault::parse("second-port:7"),
            Ok(Fault::SecondPort { from: 7 })
        );
        assert!(Fault::parse("drop:150").unwrap_err().contains("percentage"));
        assert!(Fault::parse("explode:1")
            .unwrap_err()
            .contains("no such fault"));
    }

    #[test]
    fn percentages_hold_and_are_deterministic() {
        let mut f = Faults::new(vec![Fault::Drop(10.0)], 42);
        let n = (0..100_000).filter(|&c| f.plan(c).drop).count();
        assert!((9_000..11_000).contains(&n), "{n}");
        let a: Vec<bool> = {
            let mut f = Faults::new(vec![Fault::Drop(50.0)], 7);
            (0..50).map(|c| f.plan(c).drop).collect()
        };
        let b: Vec<bool> = {
            let mut f = Faults::new(vec![Fault::Drop(50.0)], 7);
            (0..50).map(|c| f.plan(c).drop).collect()
        };
        assert_eq!(a, b);
    }

    #[test]
    fn errors_say_what_a_kind_needs_and_faults_print_as_typed() {
        let e = Fault::parse("pause:10").unwrap_err();
        assert!(
            e.contains("pause:CYCLE:MS") && e.contains("pause:100:50"),
            "{e}"
        );
        let e = Fault::parse("drop").unwrap_err();
        assert!(e.contains("drop needs a percentage: drop:P"), "{e}");
        let e = Fault::parse("second-port").unwrap_err();
        assert!(e.contains("second-port:CYCLE"), "{e}");
        let e = Fault::parse("jitter:3").unwrap_err();
        assert!(e.contains("no such fault; one of drop:P"), "{e}");
        for spec in ["drop:1.5", "pause:100:50", "second-port:200", "garbage:1"] {
            assert_eq!(Fault::parse(spec).unwrap().to_string(), spec);
        }
    }
}
