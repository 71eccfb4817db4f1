//! Reaction requests: what the service should do after a collision or a fault.
//!
//! The safety crate does not command the robot; it returns a [`ReactionRequest`] that the service
//! executes (hold the measured position, resume the interrupted motion). The paper's experiment
//! stops for 2 s and then resumes ([`ReactionPolicy::PauseThenResume`] with 2 s).
//!
//! Rules that keep the reaction live (a supervisor that latched in a hold state while nobody
//! held the arm would ignore every later onset):
//! - disarmed, the supervisor never requests anything and stays [`ReactionState::Running`];
//! - [`ReactionSupervisor::set_armed`]`(true)` always starts from `Running`;
//! - the service calls [`ReactionSupervisor::release`] whenever it ends a hold itself (operator
//!   resume) or chooses not to hold (report-only), so `Running` means "the next onset reacts".

use serde::{Deserialize, Serialize};

use crate::detector::CollisionEvent;
use crate::error::ConfigError;
use crate::fault::Fault;

/// What to do when a collision is detected.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum ReactionPolicy {
    /// Stop and hold the current position; the task is aborted and only an explicit operator
    /// restart continues.
    Stop,
    /// Hold, then resume automatically once the contact has been released for `pause_s` \[s\].
    PauseThenResume {
        /// Pause after the contact ends \[s\] (paper: 2 s).
        pause_s: f64,
    },
    /// Hold until the operator acknowledges, then resume.
    WaitForOperator,
}

impl Default for ReactionPolicy {
    /// The paper's behaviour: pause 2 s, then resume.
    fn default() -> Self {
        ReactionPolicy::PauseThenResume { pause_s: 2.0 }
    }
}

impl ReactionPolicy {
    /// Checks the pause duration.
    pub fn validate(&self) -> Result<(), ConfigError> {
        match *self {
            ReactionPolicy::PauseThenResume { pause_s }
                if !(pause_s.is_finite() && pause_s >= 0.0) =>
            {
                Err(ConfigError::Pause(pause_s))
            }
            _ => Ok(()),
        }
    }
}

/// Why the robot is being stopped.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum StopCause<const N: usize> {
    /// A collision event.
    Collision(CollisionEvent<N>),
    /// An observer fault: the detector cannot vouch for the robot's safety.
    Fault(Fault),
}

/// A request for the service, emitted once when the reaction state changes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum ReactionRequest<const N: usize> {
    /// Stop and hold the current measured position; do not resume without an operator restart.
    Stop(StopCause<N>),
    /// Stop and hold; a [`ReactionRequest::Resume`] follows automatically after the pause.
    Pause {
        /// Cause of the pause.
        cause: StopCause<N>,
        /// Pause after the contact ends \[s\].
        pause_s: f64,
    },
    /// Stop and hold until the operator acknowledges.
    HoldForOperator(StopCause<N>),
    /// Resume the interrupted motion.
    Resume,
}

/// Reaction state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ReactionState {
    /// Normal operation.
    Running,
    /// Holding after a stop; needs [`ReactionSupervisor::acknowledge`].
    Stopped,
    /// Holding; resumes automatically.
    Paused,
    /// Holding until the operator acknowledges.
    WaitingForOperator,
}

/// Turns collision events and faults into reaction requests.
#[derive(Debug, Clone)]
pub struct ReactionSupervisor {
    policy: ReactionPolicy,
    fault_policy: ReactionPolicy,
    state: ReactionState,
    clear_since_s: Option<f64>,
    active_pause_s: f64,
    acknowledged: bool,
    armed: bool,
}

impl ReactionSupervisor {
    /// Supervisor reacting to collisions with `policy` and to observer faults with
    /// `fault_policy`.
    pub fn new(policy: ReactionPolicy, fault_policy: ReactionPolicy) -> Result<Self, ConfigError> {
        policy.validate()?;
        fault_policy.validate()?;
        Ok(Self {
            policy,
            fault_policy,
            state: ReactionState::Running,
            clear_since_s: None,
            active_pause_s: 0.0,
            acknowledged: false,
            armed: true,
        })
    }

    /// Arms (true) or disarms (false) the reaction. Either way the state becomes
    /// [`ReactionState::Running`]: arming never inherits a hold that was latched before, and a
    /// disarmed supervisor holds nothing. New supervisors are armed.
    pub fn set_armed(&mut self, armed: bool) {
        self.armed = armed;
        self.release();
    }

    /// Whether onsets and faults produce requests.
    pub fn is_armed(&self) -> bool {
        self.armed
    }

    /// Back to [`ReactionState::Running`] without a [`ReactionRequest::Resume`]: the service
    /// ended the hold itself (operator resume) or did not hold at all (report-only policy).
    pub fn release(&mut self) {
        self.state = ReactionState::Running;
        self.clear_since_s = None;
        self.acknowledged = false;
    }

    /// Current state.
    pub fn state(&self) -> ReactionState {
        self.state
    }

    /// Operator acknowledgement: resumes from [`ReactionState::WaitingForOperator`] and
    /// [`ReactionState::Stopped`] on the next update in which no contact is present.
    pub fn acknowledge(&mut self) {
        self.acknowledged = true;
    }

    fn request<const N: usize>(
        &mut self,
        policy: ReactionPolicy,
        cause: StopCause<N>,
    ) -> ReactionRequest<N> {
        self.acknowledged = false;
        self.clear_since_s = None;
        match policy {
            ReactionPolicy::Stop => {
                self.state = ReactionState::Stopped;
                ReactionRequest::Stop(cause)
            }
            ReactionPolicy::PauseThenResume { pause_s } => {
                self.state = ReactionState::Paused;
                self.active_pause_s = pause_s;
                ReactionRequest::Pause { cause, pause_s }
            }
            ReactionPolicy::WaitForOperator => {
                self.state = ReactionState::WaitingForOperator;
                ReactionRequest::HoldForOperator(cause)
            }
        }
    }

    /// Advances at time `time_s` \[s\] with this sample's collision onset (if any), whether a
    /// contact is present, and the observer fault (if any). Returns a request when the state
    /// changes; never one while disarmed.
    pub fn update<const N: usize>(
        &mut self,
        time_s: f64,
        onset: Option<&CollisionEvent<N>>,
        contact_present: bool,
        fault: Option<Fault>,
    ) -> Option<ReactionRequest<N>> {
        if !self.armed {
            return None;
        }
        if let Some(fault) = fault {
            // A fault escalates from Running or from an automatic pause; an already stopped or
            // operator-held robot stays as it is.
            if matches!(self.state, ReactionState::Running | ReactionState::Paused) {
                let policy = self.fault_policy;
                if !(self.state == ReactionState::Paused
                    && matches!(policy, ReactionPolicy::PauseThenResume { .. }))
                {
                    return Some(self.request(policy, StopCause::Fault(fault)));
                }
            }
            self.clear_since_s = None;
            return None;
        }
        if let Some(event) = onset
            && self.state == ReactionState::Running
        {
            return Some(self.request(self.policy, StopCause::Collision(*event)));
        }
        match self.state {
            ReactionState::Running => None,
            ReactionState::Paused => {
                if contact_present {
                    self.clear_since_s = None;
                    return None;
                }
                let since = *self.clear_since_s.get_or_insert(time_s);
                // 1 ns tolerance: times are sums of periods and carry rounding.
                if time_s - since >= self.active_pause_s - 1e-9 {
                    self.state = ReactionState::Running;
                    self.clear_since_s = None;
                    Some(ReactionRequest::Resume)
                } else {
                    None
                }
            }
            ReactionState::Stopped | ReactionState::WaitingForOperator => {
                if self.acknowledged && !contact_present {
                    self.acknowledged = false;
                    self.state = ReactionState::Running;
                    Some(ReactionRequest::Resume)
                } else {
                    None
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detector::JointSet;
    use nalgebra::Vector2;

    fn event() -> CollisionEvent<2> {
        CollisionEvent {
            cycle: 10,
            time_s: 0.01,
            joints_over: JointSet(0b10),
            residual: Vector2::new(1.0, 7.0),
            thresholds: Vector2::new(6.0, 6.0),
            isolated_link: 1,
            contact_wrench: None,
            contact: None,
        }
    }

    #[test]
    fn pause_resumes_two_seconds_after_the_contact_ends() {
        let mut s =
            ReactionSupervisor::new(ReactionPolicy::default(), ReactionPolicy::Stop).unwrap();
        let e = event();
        let r = s.update(1.0, Some(&e), true, None);
        assert!(matches!(r, Some(ReactionRequest::Pause { pause_s, .. }) if pause_s == 2.0));
        assert_eq!(s.state(), ReactionState::Paused);
        assert_eq!(s.update::<2>(2.5, None, true, None), None); // still in contact
        assert_eq!(s.update::<2>(2.6, None, false, None), None); // clear from 2.6 s
        assert_eq!(s.update::<2>(4.5, None, false, None), None);
        assert_eq!(
            s.update::<2>(4.6, None, false, None),
            Some(ReactionRequest::Resume)
        );
        assert_eq!(s.state(), ReactionState::Running);
    }

    #[test]
    fn operator_hold_needs_acknowledgement_and_fault_stops() {
        let mut s =
            ReactionSupervisor::new(ReactionPolicy::WaitForOperator, ReactionPolicy::Stop).unwrap();
        assert!(matches!(
            s.update(0.0, Some(&event()), true, None),
            Some(ReactionRequest::HoldForOperator(_))
        ));
        assert_eq!(s.update::<2>(100.0, None, false, None), None);
        s.acknowledge();
        assert_eq!(
            s.update::<2>(100.1, None, false, None),
            Some(ReactionRequest::Resume)
        );
        let f = Fault::InvalidTimeStep { dt_s: 0.0 };
        assert_eq!(
            s.update::<2>(100.2, None, false, Some(f)),
            Some(ReactionRequest::Stop(StopCause::Fault(f)))
        );
        assert_eq!(s.state(), ReactionState::Stopped);
        // No automatic resume from a stop.
        assert_eq!(s.update::<2>(200.0, None, false, None), None);
    }

    #[test]
    fn a_detection_while_disarmed_does_not_latch_the_reaction() {
        let mut s = ReactionSupervisor::new(ReactionPolicy::Stop, ReactionPolicy::Stop).unwrap();
        s.set_armed(false);
        // Disarmed: the uncompensated payload trips the detector, nothing is requested.
        assert_eq!(s.update(1.0, Some(&event()), true, None), None);
        let f = Fault::InvalidTimeStep { dt_s: 0.0 };
        assert_eq!(s.update::<2>(1.1, None, true, Some(f)), None);
        assert_eq!(s.state(), ReactionState::Running);
        s.set_armed(true);
        assert!(matches!(
            s.update(2.0, Some(&event()), true, None),
            Some(ReactionRequest::Stop(StopCause::Collision(_)))
        ));
    }

    #[test]
    fn arming_clears_a_latched_hold_and_release_rearms() {
        let mut s = ReactionSupervisor::new(ReactionPolicy::Stop, ReactionPolicy::Stop).unwrap();
        assert!(s.update(1.0, Some(&event()), true, None).is_some());
        assert_eq!(s.state(), ReactionState::Stopped);
        // A second onset while stopped requests nothing (the arm is held already) ...
        assert_eq!(s.update(1.5, Some(&event()), true, None), None);
        // ... but once the service released the hold, the next onset reacts again.
        s.release();
        assert!(s.update(2.0, Some(&event()), true, None).is_some());
        s.set_armed(true);
        assert_eq!(s.state(), ReactionState::Running);
    }

    #[test]
    fn negative_pause_is_refused() {
        assert!(
            ReactionSupervisor::new(
                ReactionPolicy::PauseThenResume { pause_s: -1.0 },
                ReactionPolicy::Stop
            )
            .is_err()
        );
    }
}
