//! Why a run stopped: the rule, where in memory, where in the code.

/// Why the run stopped.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Stop {
    /// The rule broken, or what ended the run.
    pub rule: String,
    /// The data address involved, if any.
    pub addr: Option<u64>,
    /// Where the core was, and the function that holds it.
    pub pc: u64,
    pub function: String,
    /// Virtual time of the stop, in core cycles.
    pub cycles: u64,
}

impl std::fmt::Display for Stop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.rule)?;
        if let Some(a) = self.addr {
            write!(f, " [address {a:#010x}]")?;
        }
        write!(
            f,
            " at PC {:#010x} in {} (cycle {})",
            self.pc, self.function, self.cycles
        )
    }
}
