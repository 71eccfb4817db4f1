//! What the cycle processor reports to the non-real-time side, each with its true cause and the
//! controller's view at the time (libfranka's exceptions carry the robot state the same way):
//! a fault is never reported as a contact, and only an operator stop as "stopped by the
//! operator".

use serde::Serialize;

pub use fri_api::fri_context::FriContext;

use crate::ipc::{CollisionMessage, RobotState};

/// Why the loop stopped the arm.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum StopReason {
    /// The operator's `stop`.
    Operator,
    /// The armed collision reaction (onset on `link`, 1..7).
    Collision {
        /// Isolated link, 1..7.
        link: u32,
        /// Time of the onset, s since the service started (controller time).
        time_s: f64,
        /// Residual at the onset, Nm (joints 1..7).
        residual: [f64; 7],
    },
    /// The armed monitor could no longer vouch for the arm: an observer fault.
    ObserverFault {
        /// What the observer rejected.
        fault: safety::Fault,
    },
}

impl StopReason {
    /// Operator-facing text.
    pub fn describe(&self) -> String {
        match self {
            StopReason::Operator => "stopped by the operator".to_owned(),
            StopReason::Collision { link, .. } => {
                format!("stopped by the collision reaction (contact on link {link})")
            }
            StopReason::ObserverFault { fault } => {
                format!("stopped because the collision monitor faulted: {fault}")
            }
        }
    }
}

/// Why a commanded move ended before its target.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum AbortReason {
    /// The arm is held (operator stop or collision reaction); moves are refused.
    Held,
    /// The controller left command mode without our request (missed answers, quality, limits).
    CommandModeLost,
    /// The controller restarted (new sequence epoch): command mode is gone.
    ControllerRestarted,
    /// The move could not be planned from the current set-point (limits invalid).
    Unplannable,
    /// A brake interrupted the move (stop or reaction) and it ended at rest.
    Braked,
    /// The service is shutting down: the move is braked and command mode left.
    ShuttingDown,
}

impl AbortReason {
    /// Operator-facing text.
    pub fn describe(&self) -> &'static str {
        match self {
            AbortReason::Held => "the arm is held (operator stop or collision reaction)",
            AbortReason::CommandModeLost => "the controller left command mode",
            AbortReason::ControllerRestarted => "the controller restarted",
            AbortReason::Unplannable => "the move could not be planned",
            AbortReason::Braked => "the move was braked",
            AbortReason::ShuttingDown => "the service is shutting down",
        }
    }
}

/// Why the collision monitor started over (its residual is invalid until the warm-up ends).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum ResyncReason {
    /// The controller restarted (or a new controller was bound).
    ControllerRestarted,
    /// Measurements went missing for longer than the observer can bridge.
    Gap {
        /// Controller cycles since the previous accepted measurement.
        cycles: u32,
    },
    /// The controller left command mode and braked the arm: the velocity filter's lag would
    /// read the braking as an external torque, so the monitor waits for rest.
    CommandModeLost,
}

impl ResyncReason {
    /// Operator-facing text.
    pub fn describe(&self) -> String {
        match self {
            ResyncReason::ControllerRestarted => "the controller restarted".to_owned(),
            ResyncReason::Gap { cycles } => {
                format!("{cycles} controller cycles passed without a measurement")
            }
            ResyncReason::CommandModeLost => {
                "the controller left command mode and braked the arm".to_owned()
            }
        }
    }
}

/// What the loop reports to the non-real-time side, in cycle order.
#[allow(clippy::large_enum_variant)] // by value on purpose: no allocation per cycle
#[derive(Debug, Clone, Copy)]
pub enum CycleEvent {
    /// The state of one cycle.
    State(RobotState),
    /// A collision onset while armed.
    Collision(CollisionMessage),
    /// The loop stopped the arm.
    Stopped {
        /// Cycle of the stop.
        cycle: u64,
        /// Why.
        reason: StopReason,
        /// The controller's view then.
        fri: FriContext,
    },
    /// The arm resumed (reaction ended or operator resume).
    Resumed {
        /// Cycle of the resume.
        cycle: u64,
    },
    /// A commanded move ended without reaching its target.
    MoveAborted {
        /// Cycle of the abort.
        cycle: u64,
        /// Why.
        reason: AbortReason,
        /// The controller's view then.
        fri: FriContext,
    },
    /// The collision monitor started over; its residual is invalid until its warm-up ends.
    Resynchronised {
        /// Cycle of the restart.
        cycle: u64,
        /// Why.
        reason: ResyncReason,
        /// The controller's view then.
        fri: FriContext,
    },
}
