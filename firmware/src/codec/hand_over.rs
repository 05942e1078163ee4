//! What the compiled decode path leaves the general one when it hands a
//! datagram over: the reals it already read the slow way (anything but
//! the robot's plain notation: long mantissas, exponents, midpoints), by
//! where their text stands in the datagram.
//!
//! Without it a datagram handed over late paid for every such number
//! twice (issue 36, finding 2): a message of 42 halfway-case reals whose
//! last byte is wrong cost the compiled pass and then the general pass,
//! each parsing all 42 exactly. With it the general pass takes each of
//! them from here, so a number costs one exact parse whichever path ends
//! up deciding.
//!
//! A value is taken only for the same bytes: the same start in the same
//! datagram and the same length, so `parse_f32` would give the same
//! result (both paths read attribute values raw, between their quotes;
//! the compiled path takes none with a reference in it). Both paths meet
//! the values in document order, so one cursor finds each in constant
//! time. Bounded: [`SLOTS`] values, the rest parsed again as before.
//!
//! And where the general path may start: the compiled path marks the end
//! of each field of a record it read whole (its mark); everything before
//! the last mark it checked byte for byte, with nothing the layout does
//! not hold, so the general path's walk there is known (in the root, its
//! `Id` and `Ts`, the fields seen and what was tolerated) and it resumes
//! there instead of tokenizing the datagram from its start.

use super::decode::error::Tally;
use crate::value::Time;

/// Reals kept: more than a robot message holds attribute reals in most
/// layouts (the manual's has 42); 8 bytes each on the stack of `decode`.
pub const SLOTS: usize = 64;

/// Where the general path may resume: the end of the last field of a
/// record the compiled path read whole (or of the root's start tag), the
/// fields seen up to there and what was tolerated in them (its
/// `missing_fields` left at 0: the general path counts those at the end).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Mark {
    /// A byte offset in the datagram; 0: no mark.
    pub at: usize,
    pub seen: u64,
    pub tally: Tally,
}

/// The reals the compiled path read the slow way, in document order, and
/// where the general path may resume (its mark).
pub struct HandOver {
    /// The address of the datagram's first byte (offsets are from it),
    /// and its length.
    base: usize,
    size: usize,
    /// The table, made at the first real kept: a robot's own message has
    /// none, and does not pay for clearing 512 bytes every cycle (it did:
    /// +195 instructions a message on the MCU).
    kept: Option<Kept>,
    /// The root's `Id` and `Ts`, once the compiled path is past its start
    /// tag into a record's fields.
    pub(crate) header: Option<(u32, Option<Time>)>,
    pub(crate) mark: Mark,
}

struct Kept {
    /// Each value's offset and length in the datagram.
    at: [(u16, u16); SLOTS],
    value: [f32; SLOTS],
    len: usize,
    /// The first value the general path has not passed yet.
    next: usize,
}

impl HandOver {
    /// Nothing kept yet, for the datagram `bytes`.
    #[inline(always)]
    pub fn new(bytes: &[u8]) -> Self {
        HandOver {
            base: bytes.as_ptr() as usize,
            size: bytes.len(),
            kept: None,
            header: None,
            mark: Mark::default(),
        }
    }

    /// Where `text` stands in the datagram, if it is a part of it that
    /// fits the table.
    #[inline(always)]
    fn place(&self, text: &[u8]) -> Option<(u16, u16)> {
        let offset = (text.as_ptr() as usize).checked_sub(self.base)?;
        if offset.checked_add(text.len())? > self.size {
            return None;
        }
        Some((u16::try_from(offset).ok()?, u16::try_from(text.len()).ok()?))
    }

    /// The compiled path read `text` as `v`. Values come in document
    /// order; one past [`SLOTS`] is not kept. Inline: a hostile message
    /// calls it for every real (a call each cost the halfway case about
    /// 800 instructions on the MCU); the table is made out of line.
    #[inline(always)]
    pub fn keep(&mut self, text: &[u8], v: f32) {
        let Some(place) = self.place(text) else {
            return;
        };
        let k = match &mut self.kept {
            Some(k) => k,
            None => Self::make(&mut self.kept),
        };
        if let (Some(at), Some(value)) = (k.at.get_mut(k.len), k.value.get_mut(k.len)) {
            *at = place;
            *value = v;
            k.len += 1;
        }
    }

    /// The table, made at the first real kept.
    #[cold]
    #[inline(never)]
    fn make(kept: &mut Option<Kept>) -> &mut Kept {
        kept.insert(Kept {
            at: [(0, 0); SLOTS],
            value: [0.0; SLOTS],
            len: 0,
            next: 0,
        })
    }

    /// The value kept for exactly `text`, if any: the general path asks in
    /// document order, so what lies before `text` is passed for good.
    #[inline(always)]
    pub fn take(&mut self, text: &[u8]) -> Option<f32> {
        // Nothing kept (a robot's own message): no arithmetic at all.
        self.kept.as_ref()?;
        let place = self.place(text)?;
        let k = self.kept.as_mut()?;
        while let Some(&at) = k.at.get(k.next).filter(|_| k.next < k.len) {
            if at.0 > place.0 {
                return None;
            }
            k.next += 1;
            if at == place {
                return k.value.get(k.next - 1).copied();
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn m5_a_value_is_taken_only_for_the_same_bytes() {
        let bytes = b"<R X=\"1.50\" Y=\" 2\" Z=\"3e0\"/>";
        let mut h = HandOver::new(bytes);
        h.keep(&bytes[6..10], 1.5);
        h.keep(&bytes[23..26], 3.0);
        // Another length at the same start: not the same text.
        assert_eq!(h.take(&bytes[6..9]), None);
        // A value the compiled path did not keep.
        assert_eq!(h.take(&bytes[16..18]), None);
        assert_eq!(h.take(&bytes[23..26]), Some(3.0));
        // Passed for good: asked again out of order, parsed again.
        assert_eq!(h.take(&bytes[6..10]), None);
    }

    #[test]
    fn m5_values_of_another_buffer_or_past_the_slots_are_not_kept() {
        let bytes = [b'1'; 200];
        let other = [b'1'; 4];
        let mut h = HandOver::new(&bytes);
        h.keep(&other, 1.0);
        for i in 0..SLOTS + 10 {
            h.keep(&bytes[i..i + 1], i as f32);
        }
        assert_eq!(h.take(&other), None);
        assert_eq!(h.take(&bytes[SLOTS - 1..SLOTS]), Some((SLOTS - 1) as f32));
        assert_eq!(h.take(&bytes[SLOTS..SLOTS + 1]), None);
    }
}
