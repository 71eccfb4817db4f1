//! Tracking of the controller's `sendSeqCount` (u16, wrapping).

use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

/// Counters of the controller's sequence numbers as seen by us.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct SequenceCounters {
    /// Measurements never received: sum of the gaps in accepted sequence numbers.
    pub lost: u64,
    /// Datagrams repeating the newest accepted sequence number (rejected).
    pub duplicated: u64,
    /// Datagrams older than the newest accepted one (rejected, never answered).
    pub reordered: u64,
    /// Controller restarts: the counter went back to 0, jumped out of the window, or resumed
    /// after a silence longer than the resync time.
    pub restarted: u64,
    /// Accepted measurements whose `reflSeqCount` was not the counter of our previous reply,
    /// i.e. the controller had not received our last answer when it sent this one.
    pub reflection_mismatches: u64,
    /// Accepted measurements left unanswered because a newer one arrived first.
    pub superseded: u64,
}

/// How an incoming sequence number relates to the newest accepted one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Verdict {
    /// First datagram of the session.
    First,
    /// Exactly the next number.
    InOrder,
    /// Ahead by more than one: this many datagrams were lost.
    Gap(u16),
    /// The controller restarted (or we resynchronise after a silence).
    Restart,
    /// Same number as the newest accepted one.
    Duplicate,
    /// Older than the newest accepted one.
    Reordered,
}

impl Verdict {
    /// True for verdicts whose datagram is accepted.
    pub(crate) fn accepted(self) -> bool {
        !matches!(self, Self::Duplicate | Self::Reordered)
    }
}

/// Newest accepted sequence number and its arrival time.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct SequenceTracker {
    newest: Option<(u16, Instant)>,
}

impl SequenceTracker {
    /// Classifies `seq` received at `now`. `window` bounds both the accepted forward gap and the
    /// backward distance still taken as reordering; `resync_after` is the silence after which
    /// any number is accepted as a restart.
    pub(crate) fn classify(
        &self,
        seq: u16,
        now: Instant,
        window: u16,
        resync_after: Duration,
    ) -> Verdict {
        let Some((last, last_at)) = self.newest else {
            return Verdict::First;
        };
        let ahead = seq.wrapping_sub(last);
        if ahead == 1 {
            Verdict::InOrder
        } else if now.saturating_duration_since(last_at) > resync_after {
            Verdict::Restart
        } else if ahead == 0 {
            Verdict::Duplicate
        } else if ahead <= window {
            Verdict::Gap(ahead - 1)
        } else if seq == 0 {
            Verdict::Restart
        } else if last.wrapping_sub(seq) <= window {
            Verdict::Reordered
        } else {
            Verdict::Restart
        }
    }

    /// Records an accepted number.
    pub(crate) fn accept(&mut self, seq: u16, now: Instant) {
        self.newest = Some((seq, now));
    }

    /// Newest accepted number.
    pub(crate) fn newest(&self) -> Option<u16> {
        self.newest.map(|(s, _)| s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tracker_at(seq: u16, t: Instant) -> SequenceTracker {
        let mut s = SequenceTracker::default();
        s.accept(seq, t);
        s
    }

    #[test]
    fn classifies_every_case() {
        let t = Instant::now();
        let w = 1000;
        let r = Duration::from_secs(1);
        let soon = t + Duration::from_millis(1);
        assert_eq!(
            SequenceTracker::default().classify(5, t, w, r),
            Verdict::First
        );
        let s = tracker_at(100, t);
        assert_eq!(s.classify(101, soon, w, r), Verdict::InOrder);
        assert_eq!(s.classify(100, soon, w, r), Verdict::Duplicate);
        assert_eq!(s.classify(104, soon, w, r), Verdict::Gap(3));
        assert_eq!(s.classify(99, soon, w, r), Verdict::Reordered);
        assert_eq!(s.classify(0, soon, w, r), Verdict::Restart);
        assert_eq!(s.classify(30000, soon, w, r), Verdict::Restart);
        // After a long silence anything but the next number is a restart.
        assert_eq!(
            s.classify(99, t + Duration::from_secs(2), w, r),
            Verdict::Restart
        );
        assert_eq!(
            s.classify(101, t + Duration::from_secs(2), w, r),
            Verdict::InOrder
        );
        // Wrapping 65535 → 0 is in order, a gap across the wrap is a gap.
        let s = tracker_at(0xFFFF, t);
        assert_eq!(s.classify(0, soon, w, r), Verdict::InOrder);
        let s = tracker_at(0xFFFE, t);
        assert_eq!(s.classify(0, soon, w, r), Verdict::Gap(1));
        // Reordering across the wrap.
        let s = tracker_at(2, t);
        assert_eq!(s.classify(0xFFFF, soon, w, r), Verdict::Reordered);
    }
}
