//! The service's state as workflows and `status` see it: one enum per cycle, derived from the
//! cycle's snapshot and the stop that holds the arm, so nothing outside the cycle processor tests
//! flag bits of the shared-memory message.

use serde::Serialize;

use super::output::{FriContext, StopReason};
use crate::ipc::RobotState;
use fri_api::ipc::flags;

/// What the arm and the loop are doing in one cycle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum LoopState {
    /// The controller is in monitor mode and nothing is commanded.
    Monitor,
    /// A move is pending: command mode was requested and the controller has not entered it yet.
    EnteringCommand,
    /// In command mode, holding the set-point.
    Commanding,
    /// Driving a commanded move (estimation poses, return, brake).
    Moving,
    /// The arm is held after an operator stop or a collision reaction; moves are refused until
    /// `resume`.
    Stopped {
        /// Why the loop stopped the arm.
        reason: StopReason,
        /// The controller's view at the stop.
        fri: FriContext,
    },
    /// The arm is held, but the stop's event was lost (the loop's output queue overflowed): the
    /// reason is unknown; `resume` releases it.
    Held,
    /// The collision monitor faulted (NaN input, bad time step): its residual is not valid and
    /// the arm is held.
    Fault {
        /// The stop the fault caused, with the fault.
        reason: StopReason,
        /// The controller's view at the fault.
        fri: FriContext,
    },
}

impl LoopState {
    /// What clients see of the state (`status`).
    pub fn to_api(&self) -> fri_api::results::ServiceState {
        use fri_api::results::ServiceState;
        match *self {
            Self::Monitor => ServiceState::Monitor,
            Self::EnteringCommand => ServiceState::EnteringCommand,
            Self::Commanding => ServiceState::Commanding,
            Self::Moving => ServiceState::Moving,
            Self::Held => ServiceState::Held,
            Self::Stopped { reason, fri } => ServiceState::Stopped {
                cause: reason.to_cause(),
                fri,
            },
            Self::Fault { reason, fri } => ServiceState::Fault {
                cause: reason.to_cause(),
                fri,
            },
        }
    }

    /// The state of the cycle in `snapshot`, given the stop that holds the arm (if any).
    pub fn of(snapshot: &RobotState, stop: Option<(StopReason, FriContext)>) -> Self {
        let f = snapshot.flags;
        if f & flags::STOPPED != 0 {
            return match stop {
                Some((reason @ StopReason::ObserverFault { .. }, fri)) => {
                    Self::Fault { reason, fri }
                }
                Some((reason, fri)) => Self::Stopped { reason, fri },
                // Held, but the stop's event was lost (the loop's queue was full): the reason
                // is unknown and is never guessed (an operator stop must not be claimed).
                None => Self::Held,
            };
        }
        if f & flags::MOVING != 0 && f & flags::COMMAND_MODE != 0 {
            Self::Moving
        } else if f & flags::COMMAND_REQUESTED != 0 && f & flags::COMMAND_MODE == 0 {
            Self::EnteringCommand
        } else if f & flags::COMMAND_MODE != 0 {
            Self::Commanding
        } else {
            Self::Monitor
        }
    }

    /// Whether the arm is held (stopped or faulted).
    pub fn is_held(&self) -> bool {
        matches!(self, Self::Held | Self::Stopped { .. } | Self::Fault { .. })
    }

    /// The stop that holds the arm, if any.
    pub fn stop(&self) -> Option<(StopReason, FriContext)> {
        match *self {
            Self::Stopped { reason, fri } | Self::Fault { reason, fri } => Some((reason, fri)),
            _ => None,
        }
    }
}

/// One cycle as the tokio side sees it: the published snapshot and the service's state then.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Snapshot {
    /// The cycle's published state (what iceoryx2 subscribers get).
    pub robot: RobotState,
    /// The service's state in that cycle.
    pub state: LoopState,
}

impl Snapshot {
    /// Whether the collision monitor's residual is valid (not warming up).
    pub fn residual_valid(&self) -> bool {
        self.robot.flags & flags::RESIDUAL_INVALID == 0
    }

    /// Whether a collision is detected in this cycle.
    pub fn collision(&self) -> bool {
        self.robot.flags & flags::COLLISION != 0
    }

    /// Whether the controller is in command mode.
    pub fn command_mode(&self) -> bool {
        self.robot.flags & flags::COMMAND_MODE != 0
    }

    /// Whether the observer flagged a fault this cycle.
    pub fn observer_fault(&self) -> bool {
        self.robot.flags & flags::OBSERVER_FAULT != 0
    }

    /// Whether a commanded move is pending or running.
    pub fn moving(&self) -> bool {
        self.robot.flags & flags::MOVING != 0
    }

    /// Whether the collision monitor's reaction is armed in this cycle.
    pub fn monitor_armed(&self) -> bool {
        self.robot.flags & flags::MONITOR_ARMED != 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn snapshot(flags: u32) -> RobotState {
        RobotState {
            flags,
            ..RobotState::default()
        }
    }

    #[test]
    fn a_hold_whose_stop_was_not_seen_is_never_called_an_operator_stop() {
        let held = snapshot(flags::STOPPED | flags::COMMAND_MODE);
        assert_eq!(LoopState::of(&held, None), LoopState::Held);
        assert!(LoopState::Held.is_held());
        let collision = StopReason::Collision {
            link: 4,
            time_s: 1.0,
            residual: [0.0; 7],
        };
        let fri = FriContext::unknown();
        assert_eq!(
            LoopState::of(&held, Some((collision, fri))),
            LoopState::Stopped {
                reason: collision,
                fri
            }
        );
    }

    #[test]
    fn command_mode_requested_but_not_entered_is_entering_command() {
        let s = snapshot(flags::COMMAND_REQUESTED | flags::MOVING);
        assert_eq!(LoopState::of(&s, None), LoopState::EnteringCommand);
        let s = snapshot(flags::COMMAND_REQUESTED | flags::COMMAND_MODE | flags::MOVING);
        assert_eq!(LoopState::of(&s, None), LoopState::Moving);
        assert_eq!(LoopState::of(&snapshot(0), None), LoopState::Monitor);
    }
}
