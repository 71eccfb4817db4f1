//! Requests are never replayed: each request sample is identified by its DDS writer GUID and
//! sequence number, and the bridge executes it only when it is newer than every sample it saw from
//! that writer, carries a source timestamp, was issued after the bridge started and is not older
//! (nor further in the future) than `ros2.request_max_age_s`. A transient-local `resume` written
//! while the bridge was down, a retransmission, or a sample a peer sends again are ignored.

use std::collections::{HashMap, VecDeque};

/// Writers remembered for de-duplication; the oldest is forgotten first (its later replays are
/// still older than the age bound, which is at most 60 s).
pub const MAX_WRITERS: usize = 4096;

/// Why a request is ignored.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Ignored {
    /// The sample has no source timestamp.
    NoTimestamp,
    /// Issued before the bridge started (s before).
    BeforeStart(f64),
    /// Older than the bound (age, s).
    TooOld(f64),
    /// Issued later than now plus the bound (s ahead): the clocks disagree.
    InFuture(f64),
    /// Not newer than a sample already seen from this writer.
    Duplicate,
}

impl std::fmt::Display for Ignored {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::NoTimestamp => f.write_str("no source timestamp"),
            Self::BeforeStart(s) => write!(f, "issued {s:.3} s before the bridge started"),
            Self::TooOld(s) => write!(f, "issued {s:.3} s ago (older than the bound)"),
            Self::InFuture(s) => write!(f, "issued {s:.3} s in the future (clocks disagree)"),
            Self::Duplicate => f.write_str("already seen (same or older sequence number)"),
        }
    }
}

/// A request the guard let through.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Admitted {
    /// Samples of this writer skipped since the previous one (lost before the bridge read
    /// them: counted as dropped requests).
    pub skipped: u64,
}

/// The replay guard of one request topic.
#[derive(Debug)]
pub struct ReplayGuard {
    started_ns: i64,
    max_age_ns: i64,
    highest: HashMap<[u8; 16], i64>,
    order: VecDeque<[u8; 16]>,
}

impl ReplayGuard {
    /// A guard for a bridge that started at `started_ns` (ns since the Unix epoch) and accepts
    /// requests at most `max_age_s` old.
    pub fn new(started_ns: i64, max_age_s: f64) -> Self {
        Self {
            started_ns,
            max_age_ns: (max_age_s * 1e9) as i64,
            highest: HashMap::new(),
            order: VecDeque::new(),
        }
    }

    /// Judges the sample `seq` of `writer` with source timestamp `source_ns` (ns since the
    /// Unix epoch) at `now_ns`.
    pub fn admit(
        &mut self,
        writer: [u8; 16],
        seq: i64,
        source_ns: Option<i64>,
        now_ns: i64,
    ) -> Result<Admitted, Ignored> {
        let skipped = match self.highest.get_mut(&writer) {
            Some(h) if seq <= *h => return Err(Ignored::Duplicate),
            Some(h) => {
                let skipped = seq.saturating_sub(*h).saturating_sub(1);
                *h = seq;
                u64::try_from(skipped).unwrap_or(0)
            }
            None => {
                if self.order.len() >= MAX_WRITERS
                    && let Some(old) = self.order.pop_front()
                {
                    self.highest.remove(&old);
                }
                self.highest.insert(writer, seq);
                self.order.push_back(writer);
                0
            }
        };
        let s = |ns: i64| ns as f64 * 1e-9;
        let source = source_ns.ok_or(Ignored::NoTimestamp)?;
        if source < self.started_ns {
            return Err(Ignored::BeforeStart(s(self.started_ns - source)));
        }
        let age = now_ns.saturating_sub(source);
        if age > self.max_age_ns {
            return Err(Ignored::TooOld(s(age)));
        }
        if -age > self.max_age_ns {
            return Err(Ignored::InFuture(s(-age)));
        }
        Ok(Admitted { skipped })
    }
}

/// Now, ns since the Unix epoch (the clock DDS source timestamps use).
pub fn now_ns() -> i64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const S: i64 = 1_000_000_000;

    #[test]
    fn replays_stale_early_and_future_requests_are_ignored() {
        let start = 1_000 * S;
        let mut g = ReplayGuard::new(start, 5.0);
        let w = [1; 16];
        assert_eq!(
            g.admit(w, 1, Some(start - S), start + S),
            Err(Ignored::BeforeStart(1.0))
        );
        assert_eq!(
            g.admit(w, 2, Some(start + S), start + 7 * S),
            Err(Ignored::TooOld(6.0))
        );
        assert_eq!(
            g.admit(w, 3, Some(start + 9 * S), start + 2 * S),
            Err(Ignored::InFuture(7.0))
        );
        assert_eq!(g.admit(w, 4, None, start), Err(Ignored::NoTimestamp));
        assert_eq!(
            g.admit(w, 5, Some(start + S), start + S),
            Ok(Admitted { skipped: 0 })
        );
        assert_eq!(
            g.admit(w, 5, Some(start + S), start + S),
            Err(Ignored::Duplicate)
        );
        assert_eq!(
            g.admit(w, 9, Some(start + S), start + S),
            Ok(Admitted { skipped: 3 })
        );
        // Another writer has its own sequence.
        assert!(g.admit([2; 16], 1, Some(start + S), start + S).is_ok());
    }

    #[test]
    fn the_writer_table_is_bounded() {
        let mut g = ReplayGuard::new(0, 5.0);
        for i in 0..(MAX_WRITERS as u32 + 10) {
            let mut w = [0; 16];
            w[..4].copy_from_slice(&i.to_le_bytes());
            assert!(g.admit(w, 1, Some(S), S).is_ok());
        }
        assert_eq!(g.highest.len(), MAX_WRITERS);
        assert_eq!(g.order.len(), MAX_WRITERS);
    }

    proptest! {
        /// Over any sequence of samples (few writers, repeated sequence numbers, timestamps
        /// around the start and the bound, a clock that advances), no (writer, sequence number)
        /// is executed twice, and every executed one was issued after the start, within the
        /// bound of the time it was judged.
        #[test]
        fn no_request_is_executed_twice_or_outside_the_window(
            ops in prop::collection::vec((0u8..4, 0i64..30, -12i64..12, 0i64..3), 1..200)
        ) {
            let start = 100 * S;
            let max_age = 5.0;
            let mut g = ReplayGuard::new(start, max_age);
            let mut now = start;
            let mut executed = std::collections::HashSet::new();
            for (w, seq, offset_s, advance_s) in ops {
                now += advance_s * S;
                let source = now + offset_s * S;
                if g.admit([w; 16], seq, Some(source), now).is_ok() {
                    prop_assert!(executed.insert((w, seq)), "({w}, {seq}) executed twice");
                    prop_assert!(source >= start);
                    prop_assert!((now - source).abs() <= 5 * S);
                }
            }
        }
    }
}
