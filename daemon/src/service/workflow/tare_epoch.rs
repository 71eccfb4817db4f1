//! Whether a stored tare predates a controller restart. A restart (a reboot, or the KRL program
//! opening FRI again after a silence) may zero the joint-torque sensors anew; a tare from before
//! it carries the change of their offsets into the estimate as a payload (issue 20: after a
//! restart the same tare gave 0.0403 kg with its centre of mass 737 mm below the flange). The
//! estimate reuses such a tare only with a warning in its result.
//!
//! Evidence, either of:
//! - the same service instance took the tare and its FRI session has counted more controller
//!   restarts since (a sequence number other than the next after a silence longer than the
//!   resync time, `fri::session`). A new controller source alone (a rebind: the same controller
//!   back from another port after a silence, its clock running on) is not a restart;
//! - the controller's own clock (`intf.timestamp`) reads less than when the tare ended: the
//!   controller started again.
//!
//! Across restarts of the service only the clock can tell: a controller that restarted and has
//! since run longer than it had at the tare is not seen.

use crate::persistence::{Clocks, SessionMark, Tare};
use crate::service::core::ServiceCore;

impl ServiceCore {
    /// This instance and the controller restarts its FRI session has counted (`None` before
    /// the first measurement).
    pub(crate) fn session_mark(&self) -> Option<SessionMark> {
        let s = self.fri_state.as_ref().map(|f| f())?;
        s.valid.then_some(SessionMark {
            instance: self.instance,
            restarts: s.statistics.sequence.restarted,
        })
    }
}

/// How a restart since `tare` was seen (`None`: none seen), from the clocks `now` and the
/// session `mark` at the estimate's start.
pub(crate) fn restart_since(
    tare: &Tare,
    now: Option<Clocks>,
    mark: Option<SessionMark>,
) -> Option<String> {
    if let (Some(then), Some(now)) = (tare.session, mark)
        && then.instance == now.instance
        && now.restarts > then.restarts
    {
        let n = now.restarts - then.restarts;
        return Some(format!(
            "the FRI session counted {n} controller restart{} since the tare",
            if n == 1 { "" } else { "s" }
        ));
    }
    if let (Some(then), Some(now)) = (tare.clock, now)
        && now.controller_s < then.controller_s
    {
        return Some(format!(
            "the controller's clock went back from {:.3} s at the tare to {:.3} s",
            then.controller_s, now.controller_s
        ));
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tare(clock: f64, instance: u64, restarts: u64) -> Tare {
        Tare {
            around: [0.0; 7],
            samples: Vec::new(),
            pattern_poses: None,
            taken_unix_s: None,
            targets: None,
            pattern: None,
            step_deg: None,
            clock: Some(Clocks {
                service_s: 10.0,
                controller_s: clock,
            }),
            session: Some(SessionMark { instance, restarts }),
        }
    }

    fn clocks(controller_s: f64) -> Option<Clocks> {
        Some(Clocks {
            service_s: 20.0,
            controller_s,
        })
    }

    fn mark(instance: u64, restarts: u64) -> Option<SessionMark> {
        Some(SessionMark { instance, restarts })
    }

    #[test]
    fn a_restart_is_seen_by_the_session_count_or_the_controllers_clock() {
        let t = tare(3600.0, 7, 1);
        // Same instance, same count, clock on: the same session.
        assert_eq!(restart_since(&t, clocks(3700.0), mark(7, 1)), None);
        // The session counted a restart (the controller's clock ran on).
        let seen = restart_since(&t, clocks(3700.0), mark(7, 2)).unwrap();
        assert!(seen.contains("1 controller restart since"), "{seen}");
        // Another instance starts its count again: only the clock tells.
        assert_eq!(restart_since(&t, clocks(3700.0), mark(8, 0)), None);
        let seen = restart_since(&t, clocks(12.0), mark(8, 0)).unwrap();
        assert!(seen.contains("went back from 3600.000 s"), "{seen}");
        // Older tares without marks: the clock only, and nothing without it.
        let mut old = t.clone();
        old.session = None;
        assert_eq!(restart_since(&old, clocks(3700.0), mark(7, 5)), None);
        old.clock = None;
        assert_eq!(restart_since(&old, clocks(1.0), mark(7, 5)), None);
    }
}
