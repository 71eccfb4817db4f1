//! Tracking of the controller's `sendSeqCount` (u16, wrapping) and the public verdict on each
//! accepted measurement ([`Arrival`], [`Verdict`]).
//!
//! The restart rule: a sequence number that is neither next, a small gap ahead, a duplicate nor
//! a small step back is only taken as a controller restart after the controller has been silent
//! (no accepted datagram) for longer than `resync_after`. While it talks, such a number is
//! rejected as out of the window: a replayed capture or a forged datagram cannot reset the
//! session. A counter back at 0 gets no special treatment for the same reason (it was once a
//! restart trigger; a real restart re-synchronises after the silence, measured from the last
//! accepted datagram, so a controller that restarts at once is accepted `resync_after` later).

use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use crate::wire::{InterfaceState, Measurement};

/// Controller cycle assumed when a measurement's `desiredMsrSampleTime` is not a usable cycle
/// time (0, negative or above [`MAX_CYCLE`]): FRI's default cycle, 1 ms.
pub const NOMINAL_CYCLE: Duration = Duration::from_millis(1);
/// Longest controller cycle taken from `desiredMsrSampleTime` as it is: FRI 1.x allows
/// 1…100 ms, so anything above 1 s is a corrupt value, not a cycle time.
pub const MAX_CYCLE: Duration = Duration::from_secs(1);

/// Counters of the controller's sequence numbers as seen by us.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct SequenceCounters {
    /// Measurements never received: sum of the gaps in accepted sequence numbers.
    pub lost: u64,
    /// Datagrams repeating the newest accepted sequence number (rejected).
    pub duplicated: u64,
    /// Datagrams older than the newest accepted one (rejected, never answered).
    pub reordered: u64,
    /// Datagrams of the bound controller whose number is neither within the window ahead nor
    /// within it behind the newest accepted one while the controller talks (rejected: a replay
    /// is not a restart).
    pub out_of_window: u64,
    /// Controller restarts: a number other than the next one after a silence longer than the
    /// resync time.
    pub restarted: u64,
    /// Times the session bound a new controller source after the bound one fell silent for
    /// longer than the resync time (each starts a new epoch like a restart).
    pub rebinds: u64,
    /// Accepted measurements whose `reflSeqCount` was not the counter of our previous reply,
    /// i.e. the controller had not received our last answer when it sent this one.
    pub reflection_mismatches: u64,
    /// Accepted measurements left unanswered because a newer one arrived first.
    pub superseded: u64,
}

/// How an accepted measurement follows the previous measurement the application answered.
///
/// Read it from [`super::Session::last_arrival`] or `EndpointState::arrival` instead of
/// recomputing it from `sendSeqCount`: it already folds in measurements that were accepted but
/// superseded before they were answered, and it marks the start of every new epoch (after which
/// differences to older measurements are meaningless).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Arrival {
    /// The first measurement of the session: nothing to compare with.
    First,
    /// The same epoch goes on: `cycles` controller cycles passed since the previous answered
    /// measurement (1 when nothing was lost or superseded, n + 1 after n such measurements).
    Continued {
        /// Controller cycles since the previous answered measurement, ≥ 1.
        cycles: u32,
    },
    /// The bound controller restarted (or resumed) after a silence longer than `resync_after`:
    /// a new epoch, counted in `SequenceCounters::restarted`.
    Restart,
    /// A new controller source was bound after the old one fell silent for longer than
    /// `resync_after`: a new epoch, counted in `SequenceCounters::rebinds`.
    Rebind,
}

impl Arrival {
    /// Controller cycles since the previous answered measurement; `None` when this measurement
    /// starts an epoch ([`Arrival::First`], [`Arrival::Restart`], [`Arrival::Rebind`]).
    pub fn elapsed_cycles(self) -> Option<u32> {
        match self {
            Self::Continued { cycles } => Some(cycles),
            Self::First | Self::Restart | Self::Rebind => None,
        }
    }

    /// True when this measurement starts a new epoch: filters, differences and integrators
    /// over earlier measurements must start over.
    pub fn starts_epoch(self) -> bool {
        self.elapsed_cycles().is_none()
    }

    /// The arrival the application sees when `self` was accepted but never answered and `next`
    /// superseded it: an epoch start stays an epoch start, cycles add up.
    pub(crate) fn then(self, next: Arrival) -> Arrival {
        match (self, next) {
            (_, Self::First | Self::Restart | Self::Rebind) => next,
            (Self::First | Self::Restart | Self::Rebind, Self::Continued { .. }) => self,
            (Self::Continued { cycles: a }, Self::Continued { cycles: b }) => Self::Continued {
                cycles: a.saturating_add(b),
            },
        }
    }
}

/// The session's verdict on one accepted measurement, relative to the previous measurement the
/// application answered: what the application needs to integrate, differentiate and decide
/// whether its commands take effect, without recomputing any of it from the raw fields.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Verdict {
    /// Where the measurement sits in the controller's sequence (cycles elapsed or epoch start).
    pub arrival: Arrival,
    /// Controller time since the previous answered measurement: elapsed cycles times the
    /// controller's cycle (`desiredMsrSampleTime`, else [`NOMINAL_CYCLE`]); zero when the
    /// measurement starts an epoch (as libfranka's first callback gets a zero duration).
    pub elapsed: Duration,
    /// True when the controller applies our commands: state CMD and a drive powered. Outside
    /// it the session mirrors the set-point whatever the application asks.
    pub commanding: bool,
}

impl Verdict {
    /// The verdict on `msr` given its sequence verdict, with the session's own rules for
    /// elapsed time and commanding (public so stand-ins of a session agree with it).
    pub fn new(msr: &Measurement, arrival: Arrival) -> Self {
        let elapsed = arrival.elapsed_cycles().map_or(Duration::ZERO, |cycles| {
            controller_cycle(msr).saturating_mul(cycles)
        });
        Self {
            arrival,
            elapsed,
            commanding: commanding(msr),
        }
    }

    /// Controller cycles since the previous answered measurement; `None` at an epoch start.
    pub fn elapsed_cycles(&self) -> Option<u32> {
        self.arrival.elapsed_cycles()
    }
}

/// True when the controller applies our commands: state CMD and a drive powered.
pub(crate) fn commanding(msr: &Measurement) -> bool {
    msr.interface.state == InterfaceState::Command && msr.drives_powered()
}

/// The controller's cycle as it reports it, or [`NOMINAL_CYCLE`] when the value is unusable
/// (the field comes off the wire: it must never panic a conversion or make time stand still).
fn controller_cycle(msr: &Measurement) -> Duration {
    Duration::try_from_secs_f64(msr.interface.desired_msr_sample_time)
        .ok()
        .filter(|d| !d.is_zero() && *d <= MAX_CYCLE)
        .unwrap_or(NOMINAL_CYCLE)
}

/// Why a sequence number of the bound controller is refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Refusal {
    /// Same number as the newest accepted one.
    Duplicate,
    /// Older than the newest accepted one, within the window.
    Reordered,
    /// Neither within the window ahead nor behind, while the controller talks.
    OutOfWindow,
}

/// Newest accepted sequence number and its arrival time.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct SequenceTracker {
    newest: Option<(u16, Instant)>,
}

impl SequenceTracker {
    /// Classifies `seq` of the bound controller received at `now`. `window` bounds both the
    /// accepted forward gap and the backward distance still taken as reordering;
    /// `resync_after` is the silence after which any number is accepted as a restart.
    pub(crate) fn classify(
        &self,
        seq: u16,
        now: Instant,
        window: u16,
        resync_after: Duration,
    ) -> Result<Arrival, Refusal> {
        let Some((last, _)) = self.newest else {
            return Ok(Arrival::First);
        };
        let ahead = seq.wrapping_sub(last);
        if ahead == 1 {
            Ok(Arrival::Continued { cycles: 1 })
        } else if self.silent(now, resync_after) {
            Ok(Arrival::Restart)
        } else if ahead == 0 {
            Err(Refusal::Duplicate)
        } else if ahead <= window {
            Ok(Arrival::Continued {
                cycles: u32::from(ahead),
            })
        } else if last.wrapping_sub(seq) <= window {
            Err(Refusal::Reordered)
        } else {
            Err(Refusal::OutOfWindow)
        }
    }

    /// True when nothing was accepted for longer than `resync_after` before `now` (or ever).
    pub(crate) fn silent(&self, now: Instant, resync_after: Duration) -> bool {
        self.newest
            .is_none_or(|(_, at)| now.saturating_duration_since(at) > resync_after)
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

    const fn after(cycles: u32) -> Result<Arrival, Refusal> {
        Ok(Arrival::Continued { cycles })
    }

    #[test]
    fn classifies_every_case() {
        let t = Instant::now();
        let w = 1000;
        let r = Duration::from_secs(1);
        let soon = t + Duration::from_millis(1);
        assert_eq!(
            SequenceTracker::default().classify(5, t, w, r),
            Ok(Arrival::First)
        );
        let s = tracker_at(5000, t);
        assert_eq!(s.classify(5001, soon, w, r), after(1));
        assert_eq!(s.classify(5000, soon, w, r), Err(Refusal::Duplicate));
        assert_eq!(s.classify(5004, soon, w, r), after(4));
        assert_eq!(s.classify(6000, soon, w, r), after(1000));
        assert_eq!(s.classify(4999, soon, w, r), Err(Refusal::Reordered));
        assert_eq!(s.classify(4000, soon, w, r), Err(Refusal::Reordered));
        // While the controller talks, neither 0 nor a jump is a restart.
        assert_eq!(s.classify(0, soon, w, r), Err(Refusal::OutOfWindow));
        assert_eq!(s.classify(6001, soon, w, r), Err(Refusal::OutOfWindow));
        assert_eq!(s.classify(3999, soon, w, r), Err(Refusal::OutOfWindow));
        assert_eq!(s.classify(30000, soon, w, r), Err(Refusal::OutOfWindow));
        // Exactly `resync_after` of silence is not yet silence.
        assert_eq!(s.classify(0, t + r, w, r), Err(Refusal::OutOfWindow));
        // After a long silence anything but the next number is a restart.
        let late = t + Duration::from_secs(2);
        assert_eq!(s.classify(0, late, w, r), Ok(Arrival::Restart));
        assert_eq!(s.classify(4999, late, w, r), Ok(Arrival::Restart));
        assert_eq!(s.classify(5000, late, w, r), Ok(Arrival::Restart));
        assert_eq!(s.classify(5001, late, w, r), after(1));
        // Wrapping 65535 → 0 is in order, a gap across the wrap is a gap.
        let s = tracker_at(0xFFFF, t);
        assert_eq!(s.classify(0, soon, w, r), after(1));
        let s = tracker_at(0xFFFE, t);
        assert_eq!(s.classify(0, soon, w, r), after(2));
        // Reordering across the wrap; a late 0 shortly after the wrap is reordering too.
        let s = tracker_at(2, t);
        assert_eq!(s.classify(0xFFFF, soon, w, r), Err(Refusal::Reordered));
        assert_eq!(s.classify(0, soon, w, r), Err(Refusal::Reordered));
    }

    #[test]
    fn silence_is_measured_from_the_last_accepted_number() {
        let t = Instant::now();
        let r = Duration::from_millis(50);
        assert!(SequenceTracker::default().silent(t, r));
        let s = tracker_at(1, t);
        assert!(!s.silent(t + r, r));
        assert!(s.silent(t + r + Duration::from_nanos(1), r));
    }

    #[test]
    fn verdict_takes_elapsed_time_from_the_counter_and_the_controllers_cycle() {
        let mut m = Measurement::default();
        m.interface.desired_msr_sample_time = 0.002;
        let v = Verdict::new(&m, Arrival::Continued { cycles: 3 });
        assert_eq!(v.elapsed, Duration::from_millis(6));
        assert_eq!(v.elapsed_cycles(), Some(3));
        assert!(!v.commanding);
        // Epoch starts have no elapsed time; unusable cycle times fall back to 1 ms.
        assert_eq!(Verdict::new(&m, Arrival::Restart).elapsed, Duration::ZERO);
        for bad in [0.0, -0.001, 2.0] {
            m.interface.desired_msr_sample_time = bad;
            let v = Verdict::new(&m, Arrival::Continued { cycles: 2 });
            assert_eq!(v.elapsed, Duration::from_millis(2), "cycle time {bad}");
        }
        m.interface.state = InterfaceState::Command;
        assert!(
            !Verdict::new(&m, Arrival::First).commanding,
            "no drive powered"
        );
        m.robot.power = 0x01;
        assert!(Verdict::new(&m, Arrival::First).commanding);
    }

    #[test]
    fn superseded_arrivals_fold_into_the_next() {
        let c = |cycles| Arrival::Continued { cycles };
        assert_eq!(c(1).then(c(3)), c(4));
        assert_eq!(c(u32::MAX).then(c(3)), c(u32::MAX));
        for start in [Arrival::First, Arrival::Restart, Arrival::Rebind] {
            assert_eq!(start.then(c(1)), start);
            assert_eq!(c(2).then(start), start);
            assert!(start.starts_epoch());
            assert_eq!(start.elapsed_cycles(), None);
        }
        assert_eq!(Arrival::Restart.then(Arrival::Rebind), Arrival::Rebind);
        assert_eq!(c(5).elapsed_cycles(), Some(5));
        assert!(!c(5).starts_epoch());
    }
}
