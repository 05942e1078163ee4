//! The naive comparison for the codec benches (feature `codec-baseline`;
//! never part of the sensor): what a first implementation on the same
//! tokenizer would do for the manual's `AnyDevice` messages — match names
//! as strings, parse with `str::parse`, format with `write!("{:.3}")`
//! (`core::fmt` float formatting, which the firmware itself never uses) —
//! and xmlparser tokenizing alone, the floor under any decoder built on it.
//! `cargo codec-bench` runs these on the host, the QEMU bench on Thumb-2.
#![allow(clippy::indexing_slicing)]

use core::fmt::Write as _;

/// Tokenizes `text` and nothing else; the number of tokens, or `None` on
/// a tokenizer error.
pub fn tokenize(text: &str) -> Option<usize> {
    let mut n = 0;
    for token in xmlparser::Tokenizer::from(text) {
        core::hint::black_box(token.ok()?);
        n += 1;
    }
    Some(n)
}

/// What a first implementation would do: match names as strings, parse
/// with `str::parse`, format with `write!("{:.3}")`.
#[derive(Default)]
pub struct Naive {
    /// The root's `Id`, echoed in the reply (M8).
    pub id: u32,
    /// The root's `Ts`, seconds (M1).
    pub ts: f64,
    /// `RobMode`: the enum alias as received, unchecked.
    pub mode: heapless::String<16>,
    /// `Ts_act`: feedback time, seconds.
    pub ts_act: f64,
    /// `Ts_des`: predicted time, seconds.
    pub ts_des: f64,
    /// `P_act`: feedback pose `X Y Z` (mm), `Rx Ry Rz` (deg) (M4, M5).
    pub p_act: [f32; 6],
    /// `J_act`: feedback joints `J1..J6`, degrees.
    pub j_act: [f32; 6],
    /// `P_des`: planned pose, as `p_act`.
    pub p_des: [f32; 6],
    /// `J_des`: planned joints, degrees.
    pub j_des: [f32; 6],
    /// `AppData`: `X1..X18`, also the values the reply sends back.
    pub app: [f32; 18],
}

/// Decodes a `RobData` message into `out` the naive way; `None` on any
/// tokenizer or number error. Unknown names are skipped, fields not in the
/// message keep their value.
pub fn naive_decode(text: &str, out: &mut Naive) -> Option<()> {
    use xmlparser::{Token, Tokenizer};
    let mut current = "";
    for token in Tokenizer::from(text) {
        match token.ok()? {
            Token::ElementStart { local, .. } => current = local.as_str(),
            Token::Attribute { local, value, .. } => {
                let key = local.as_str();
                let v = value.as_str().trim();
                let idx = |names: [&str; 6]| names.iter().position(|n| *n == key);
                const F: [&str; 6] = ["X", "Y", "Z", "Rx", "Ry", "Rz"];
                const J: [&str; 6] = ["J1", "J2", "J3", "J4", "J5", "J6"];
                match current {
                    "RobData" if key == "Id" => out.id = v.parse().ok()?,
                    "RobData" if key == "Ts" => out.ts = v.parse().ok()?,
                    "P_act" => out.p_act[idx(F)?] = v.parse().ok()?,
                    "P_des" => out.p_des[idx(F)?] = v.parse().ok()?,
                    "J_act" => out.j_act[idx(J)?] = v.parse().ok()?,
                    "J_des" => out.j_des[idx(J)?] = v.parse().ok()?,
                    "AppData" => {
                        let i: usize = key.get(1..)?.parse().ok()?;
                        *out.app.get_mut(i.checked_sub(1)?)? = v.parse().ok()?;
                    }
                    _ => {}
                }
            }
            Token::ElementEnd { end, .. } if !matches!(end, xmlparser::ElementEnd::Open) => {
                current = "";
            }
            Token::Text { text } => {
                let t = text.as_str().trim();
                match current {
                    "RobMode" => {
                        out.mode.clear();
                        out.mode.push_str(t).ok()?;
                    }
                    "Ts_act" => out.ts_act = t.parse().ok()?,
                    "Ts_des" => out.ts_des = t.parse().ok()?,
                    _ => {}
                }
            }
            _ => {}
        }
    }
    Some(())
}

/// Formats the `SensData` reply for `id` and `ts` with `app` as `AppData`
/// into `out` via `core::fmt` (`{:.3}`); `None` if `out` is too small.
pub fn naive_encode(
    id: u32,
    ts: f64,
    app: &[f32; 18],
    out: &mut heapless::String<2048>,
) -> Option<()> {
    out.clear();
    write!(
        out,
        "<SensData Id=\"{id}\" Ts=\"{ts:.3}\"><EStr>ok</EStr><AppData"
    )
    .ok()?;
    for (i, v) in app.iter().enumerate() {
        write!(out, " X{}=\"{v:.3}\"", i + 1).ok()?;
    }
    out.push_str("/></SensData>").ok()
}

/// One baseline cycle: decode `text`, encode a reply into `out`; the
/// reply's length.
pub fn cycle(text: &str, robot: &mut Naive, out: &mut heapless::String<2048>) -> Option<usize> {
    naive_decode(text, robot)?;
    naive_encode(robot.id, robot.ts, &robot.app, out)?;
    Some(out.len())
}
