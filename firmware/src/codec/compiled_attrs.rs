//! The compiled path's values of attributes (M4): a frame's
//! `X Y Z Rx Ry Rz`, joints' `J1..J6` and an array's `X1..XN`, each in
//! that order with any left out, and the element's end. A second `impl`
//! block of [`Scan`], kept apart from the scanner's core (bytes, names,
//! texts, the root) in `compiled.rs`.

use super::{boolean, bump, string, time, Scan};
use crate::value::{Frame, Joints, RriString, Time};

impl<'a> Scan<'a> {
    /// A frame's attributes `X Y Z Rx Ry Rz` (M4) in that order, any left
    /// out, and the element's end ([`Scan::values_end`]).
    #[inline(always)]
    pub fn frame<const C: usize>(&mut self, f: &mut Frame, close: &[u8; C]) -> Option<()> {
        let mut n = 0;
        for (lit, slot) in [
            (b" X=\"" as &[u8; 4], &mut f.x),
            (b" Y=\"", &mut f.y),
            (b" Z=\"", &mut f.z),
        ] {
            if self.attr(lit) {
                *slot = self.real()?;
                n += 1;
            }
        }
        for (lit, slot) in [
            (b" Rx=\"" as &[u8; 5], &mut f.rx),
            (b" Ry=\"", &mut f.ry),
            (b" Rz=\"", &mut f.rz),
        ] {
            if self.attr(lit) {
                *slot = self.real()?;
                n += 1;
            }
        }
        self.values_end(n, 6, close)
    }

    /// Joints' attributes `J1..J6` (M4) in that order, any left out, and
    /// the element's end.
    #[inline(always)]
    pub fn joints<const C: usize>(&mut self, j: &mut Joints, close: &[u8; C]) -> Option<()> {
        const NAMES: [&[u8; 5]; 6] = [
            b" J1=\"", b" J2=\"", b" J3=\"", b" J4=\"", b" J5=\"", b" J6=\"",
        ];
        let mut n = 0;
        for (lit, slot) in NAMES.iter().zip(j.iter_mut()) {
            if self.attr(lit) {
                *slot = self.real()?;
                n += 1;
            }
        }
        self.values_end(n, 6, close)
    }

    /// An array's attributes `X1..XN` (M4) in that order, any left out,
    /// each read by `read`, and the element's end.
    #[inline(always)]
    fn array<const C: usize, T>(
        &mut self,
        a: &mut [T],
        close: &[u8; C],
        mut read: impl FnMut(&mut Self) -> Option<T>,
    ) -> Option<()> {
        let mut n = 0;
        for (i, slot) in a.iter_mut().enumerate() {
            if self.element(i + 1) {
                *slot = read(self)?;
                n += 1;
            }
        }
        self.values_end(n, a.len(), close)
    }

    /// An array of reals (M4, M5).
    #[inline(always)]
    pub fn reals<const C: usize>(&mut self, a: &mut [f32], close: &[u8; C]) -> Option<()> {
        self.array(a, close, Self::real)
    }

    /// An array of bools (M4, M7).
    pub fn bools<const C: usize>(&mut self, a: &mut [bool], close: &[u8; C]) -> Option<()> {
        self.array(a, close, |s| boolean(s.value()?))
    }

    /// An array of times (M4, M5).
    pub fn times<const C: usize>(&mut self, a: &mut [Time], close: &[u8; C]) -> Option<()> {
        self.array(a, close, |s| time(s.value()?))
    }

    /// An array of strings (M4, M6).
    pub fn strings<const C: usize>(&mut self, a: &mut [RriString], close: &[u8; C]) -> Option<()> {
        self.array(a, close, |s| string(s.value()?))
    }

    /// Array element `X<k>`'s name, `=` and opening quote, whitespace as
    /// for [`Scan::attr`]; `k` without leading zeros, as the general path
    /// reads it (M4).
    #[inline(always)]
    pub(super) fn element(&mut self, k: usize) -> bool {
        let save = self.rest;
        let compact = matches!(self.rest, [b' ', b'X', ..]);
        let named = if compact {
            self.rest = self.rest.get(2..).unwrap_or(&[]);
            true
        } else {
            self.ws() && self.lit(b"X")
        };
        if named && self.rest.first().is_some_and(|&b| b != b'0') {
            let (n, digits) = self.number();
            if digits > 0 && n == k && (self.lit(b"=\"") || self.equals()) {
                return true;
            }
        }
        self.rest = save;
        false
    }

    /// The end of a field of attributes that took `n` of its `count`
    /// values: `/>` (whitespace before it allowed), with the values left
    /// out counted (M4); or, when it took none, text and the end tag
    /// `close`: the real IRC5's `<AppData>0</AppData>` where attributes
    /// were expected, counted as a shape mismatch (M2).
    #[inline(always)]
    pub fn values_end<const C: usize>(
        &mut self,
        n: usize,
        count: usize,
        close: &[u8; C],
    ) -> Option<()> {
        self.ws();
        if self.lit(b"/>") {
            if n == 0 {
                bump(&mut self.tally.shape_mismatches);
            } else if n < count {
                let left_out = u16::try_from(count - n).unwrap_or(u16::MAX);
                let m = &mut self.tally.missing_values;
                *m = m.saturating_add(left_out);
            }
            return Some(());
        }
        if n == 0 && self.lit(b">") {
            self.text(close, |_| Some(()))?;
            bump(&mut self.tally.shape_mismatches);
            return Some(());
        }
        None
    }
}
