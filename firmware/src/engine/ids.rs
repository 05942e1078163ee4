//! S3: the robot's message ids, a wrapping `u32` counter. Gaps are lost
//! messages, an equal id is a duplicate, an older one is reordered.

/// What one id says about the stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IdEvent {
    /// The first id seen (or the first after a reset).
    First,
    /// The next id (`last + 1`, wrapping from 4294967295 to 0).
    Next {
        /// The counter wrapped to reach it (counted, not an error).
        wrapped: bool,
    },
    /// Ahead by more than one: `lost` ids were skipped.
    Gap {
        /// Ids skipped: messages presumed lost (S1 `MaxLost` compares this).
        lost: u32,
        /// The counter wrapped on the way.
        wrapped: bool,
    },
    /// The same id as the last one.
    Duplicate,
    /// An id older than the last one (arrived late).
    Reordered,
}

/// Tracks the newest id. "Ahead" and "older" are decided on the wrapping
/// distance: less than 2^31 ahead is newer, so a counter that wraps is
/// never mistaken for a reset.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct IdTracker {
    last: Option<u32>,
}

impl IdTracker {
    /// Judges `id` against the newest so far; only a newer id becomes the
    /// newest (a duplicate or late arrival leaves it).
    pub fn observe(&mut self, id: u32) -> IdEvent {
        let Some(last) = self.last else {
            self.last = Some(id);
            return IdEvent::First;
        };
        let ahead = id.wrapping_sub(last);
        if ahead == 0 {
            IdEvent::Duplicate
        } else if ahead < 1 << 31 {
            self.last = Some(id);
            let wrapped = id < last;
            if ahead == 1 {
                IdEvent::Next { wrapped }
            } else {
                IdEvent::Gap {
                    lost: ahead - 1,
                    wrapped,
                }
            }
        } else {
            IdEvent::Reordered
        }
    }

    /// Forget the stream (a new peer starts its own).
    pub fn reset(&mut self) {
        self.last = None;
    }

    /// The newest id seen; `None` before the first (or after a reset).
    pub fn last(&self) -> Option<u32> {
        self.last
    }
}

/// S3 over a channel that carries several robot properties (M11).
///
/// The decision: the controller numbers all messages of one channel in one
/// sequence, so the channel's tracker judges each Id. A controller that
/// numbers each property on its own would look, to that tracker, like a
/// storm of gaps and reordering and trip a false `MaxLost` error, so every
/// property also has its own tracker and the two views are reconciled:
/// - an Id that is the next one in either view is in order (one view
///   explains it);
/// - otherwise the view that has explained more Ids so far decides (a
///   gap, a duplicate, a late arrival): the channel's at the start, the
///   property's once the controller has shown that it numbers per
///   property.
///
/// With one property the two views would be the same, so only the
/// channel's is kept (see [`ChannelIds::observe`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChannelIds<const N: usize> {
    channel: IdTracker,
    property: [IdTracker; N],
    /// Evidence for per-property numbering: up when only the property's
    /// view explains an Id, down when only the channel's does.
    per_property: i8,
}

impl<const N: usize> Default for ChannelIds<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> ChannelIds<N> {
    /// Nothing seen yet.
    pub const fn new() -> Self {
        ChannelIds {
            channel: IdTracker { last: None },
            property: [IdTracker { last: None }; N],
            per_property: 0,
        }
    }

    /// Judges `id` of a message of robot property `property` (an index
    /// below `N`; a larger one is judged by the channel's view alone).
    /// `several`: the layout has more than one robot property (with one,
    /// the two views are the same and only the channel's is kept; a
    /// compile-time constant for the engine, so single-property firmware
    /// carries none of this).
    pub fn observe(&mut self, several: bool, property: usize, id: u32) -> IdEvent {
        let channel = self.channel.observe(id);
        if !several {
            return channel;
        }
        let Some(own) = self.property.get_mut(property).map(|t| t.observe(id)) else {
            return channel;
        };
        let explained = |e: IdEvent| matches!(e, IdEvent::First | IdEvent::Next { .. });
        let strict = |e: IdEvent| matches!(e, IdEvent::Next { .. });
        // Evidence only from Ids exactly one view calls the next one.
        if strict(own) && !explained(channel) {
            self.per_property = self.per_property.saturating_add(1).min(16);
        } else if strict(channel) && !explained(own) {
            self.per_property = self.per_property.saturating_sub(1).max(-16);
        }
        match (explained(channel), explained(own)) {
            (true, _) => channel,
            (false, true) => own,
            (false, false) if self.per_property > 0 => own,
            (false, false) => channel,
        }
    }

    /// Forget every stream (a new peer starts its own).
    pub fn reset(&mut self) {
        *self = Self::new();
    }

    /// `true` once the controller has been seen numbering each property on
    /// its own.
    pub fn numbers_per_property(&self) -> bool {
        self.per_property > 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn s3_in_order_gaps_duplicates_reordering() {
        let mut t = IdTracker::default();
        assert_eq!(t.observe(10), IdEvent::First);
        assert_eq!(t.observe(11), IdEvent::Next { wrapped: false });
        assert_eq!(t.observe(11), IdEvent::Duplicate);
        assert_eq!(
            t.observe(15),
            IdEvent::Gap {
                lost: 3,
                wrapped: false
            }
        );
        assert_eq!(t.observe(13), IdEvent::Reordered);
        assert_eq!(t.last(), Some(15));
    }

    #[test]
    fn s3_wrap_from_max_to_zero_is_in_order() {
        let mut t = IdTracker::default();
        t.observe(u32::MAX - 1);
        assert_eq!(t.observe(u32::MAX), IdEvent::Next { wrapped: false });
        assert_eq!(t.observe(0), IdEvent::Next { wrapped: true });
        assert_eq!(
            t.observe(3),
            IdEvent::Gap {
                lost: 2,
                wrapped: false
            }
        );
        let mut t = IdTracker::default();
        t.observe(u32::MAX);
        assert_eq!(
            t.observe(2),
            IdEvent::Gap {
                lost: 2,
                wrapped: true
            }
        );
        assert_eq!(t.observe(u32::MAX), IdEvent::Reordered);
    }

    /// Lost ids the judged events add up to, as the engine counts them.
    fn lost(events: &[IdEvent]) -> u32 {
        events.iter().fold(0u32, |n, e| match e {
            IdEvent::Gap { lost, .. } => n + lost,
            IdEvent::Reordered => n.saturating_sub(1),
            _ => n,
        })
    }

    /// Three properties at 4, 16 and 64 ms for `ticks` cycles: (property,
    /// id) in sending order, numbered in one sequence or per property.
    fn stream(ticks: u32, per_property: bool) -> Vec<(usize, u32)> {
        // Property 2's counter starts ahead (its SiSetCyclic ran longer).
        let mut next = [1u32, 1, 500];
        let mut shared = 1u32;
        let mut out = Vec::new();
        for t in 0..ticks {
            for (p, every) in [(0usize, 1u32), (1, 4), (2, 16)] {
                if t % every == 0 {
                    let id = if per_property { next[p] } else { shared };
                    next[p] += 1;
                    shared += 1;
                    out.push((p, id));
                }
            }
        }
        out
    }

    #[test]
    fn m11_one_sequence_across_properties_is_in_order() {
        let mut ids = ChannelIds::<4>::default();
        let events: Vec<_> = stream(200, false)
            .into_iter()
            .map(|(p, id)| ids.observe(true, p, id))
            .collect();
        assert_eq!(lost(&events), 0);
        assert!(events
            .iter()
            .all(|e| matches!(e, IdEvent::First | IdEvent::Next { .. })));
        assert!(!ids.numbers_per_property());
    }

    #[test]
    fn m11_per_property_numbering_raises_no_false_loss() {
        let mut ids = ChannelIds::<4>::default();
        let events: Vec<_> = stream(200, true)
            .into_iter()
            .map(|(p, id)| ids.observe(true, p, id))
            .collect();
        assert_eq!(lost(&events), 0, "{events:?}");
        assert!(
            !events
                .iter()
                .any(|e| matches!(e, IdEvent::Gap { .. } | IdEvent::Duplicate)),
            "{events:?}"
        );
        assert!(ids.numbers_per_property());
    }

    #[test]
    fn m11_real_losses_are_counted_in_either_numbering() {
        for per_property in [false, true] {
            let mut ids = ChannelIds::<4>::default();
            let mut events = Vec::new();
            // Drop three messages of property 0 in a row, mid-run.
            let mut dropped = 0;
            for (i, (p, id)) in stream(200, per_property).into_iter().enumerate() {
                if p == 0 && i > 150 && dropped < 3 {
                    dropped += 1;
                    continue;
                }
                events.push(ids.observe(true, p, id));
            }
            assert_eq!(lost(&events), 3, "per_property={per_property}: {events:?}");
            if per_property {
                // Property 0's own burst, which MaxLost must see whole.
                assert!(
                    events
                        .iter()
                        .any(|e| matches!(e, IdEvent::Gap { lost: 3, .. })),
                    "{events:?}"
                );
            }
        }
    }

    #[test]
    fn m11_duplicates_and_reset() {
        let mut ids = ChannelIds::<2>::default();
        assert_eq!(ids.observe(true, 0, 7), IdEvent::First);
        assert_eq!(ids.observe(true, 0, 7), IdEvent::Duplicate);
        ids.reset();
        assert_eq!(ids.observe(true, 1, 3), IdEvent::First);
        // An index beyond the trackers is judged by the channel alone.
        assert_eq!(ids.observe(true, 9, 4), IdEvent::Next { wrapped: false });
    }
}
