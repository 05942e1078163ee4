//! What one reply showed (`--show`): its values, as the run's record of
//! each cycle keeps them ([`crate::report::Cycle`]) and [`crate::show`]
//! reads and writes them. Apart from both, so that neither module needs
//! the other's types in both directions.

use std::fmt;

/// One value as the reply carried it.
#[derive(Clone, Debug, PartialEq)]
pub enum Cell {
    /// `real`, `num` or `time` (plotted).
    Num(f64),
    /// `bool` (plotted as 0 / 1).
    Bool(bool),
    /// `string` or an enum member (printed and written, not plotted).
    Text(String),
    /// Missing or not parseable (only possible in a reply that failed the
    /// layout's checks, which are never shown).
    Missing,
}

impl Cell {
    /// The value on a plot's y axis, if it has one.
    pub fn number(&self) -> Option<f64> {
        match self {
            Cell::Num(x) => Some(*x),
            Cell::Bool(b) => Some(f64::from(u8::from(*b))),
            _ => None,
        }
    }
}

impl fmt::Display for Cell {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Cell::Num(x) => write!(f, "{x}"),
            Cell::Bool(b) => f.write_str(if *b { "TRUE" } else { "FALSE" }),
            Cell::Text(s) => f.write_str(s),
            Cell::Missing => Ok(()),
        }
    }
}

/// What one reply showed: its `Ts` (the device's clock, T2) and the
/// values of the shown columns, in their order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Shown {
    /// The reply's `Ts`, seconds.
    pub ts: Option<f64>,
    /// One per [`crate::show::Show::columns`].
    pub values: Vec<Cell>,
}
