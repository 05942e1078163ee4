//! S3: the robot's message ids, a wrapping `u32` counter. Gaps are lost
//! messages, an equal id is a duplicate, an older one is reordered.

/// What one id says about the stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IdEvent {
    /// The first id seen (or the first after a reset).
    First,
    /// The next id (`last + 1`, wrapping from 4294967295 to 0).
    Next { wrapped: bool },
    /// Ahead by more than one: `lost` ids were skipped.
    Gap { lost: u32, wrapped: bool },
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

    pub fn last(&self) -> Option<u32> {
        self.last
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
}
