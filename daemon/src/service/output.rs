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
    /// What clients see of the reason (the observer fault as its JSON form).
    pub fn to_cause(&self) -> fri_api::results::StopCause {
        use fri_api::results::StopCause;
        match *self {
            StopReason::Operator => StopCause::Operator,
            StopReason::Collision {
                link,
                time_s,
                residual,
            } => StopCause::Collision {
                link,
                time_s,
                residual,
            },
            StopReason::ObserverFault { fault } => StopCause::ObserverFault {
                fault: serde_json::to_value(fault).unwrap_or(serde_json::Value::Null),
            },
        }
    }

    /// The stable short name (scripts match on it).
    pub fn kind(&self) -> fri_api::results::StopKind {
        use fri_api::results::StopKind;
        match self {
            StopReason::Operator => StopKind::Operator,
            StopReason::Collision { .. } => StopKind::Collision,
            StopReason::ObserverFault { .. } => StopKind::ObserverFault,
        }
    }

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

pub use fri_api::results::{AbortReason, ReleaseReason, ResyncReason};

/// The unknown-payload mode as the loop holds it (fixed-size: it leaves the loop by value).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum UnknownPayloadView {
    /// Declared: what is tolerated and until when (controller time).
    Active(safety::ToleranceStatus),
    /// Ended (applied, ended by the operator, or expired).
    Ended {
        /// The declaration that ended.
        declaration: u32,
        /// Why.
        reason: safety::ModeEnd,
    },
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
        /// Why the service released it on its own (`None`: the operator's `resume`, at once).
        by_service: Option<ReleaseReason>,
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
    /// The unknown-payload mode changed: declared, pinned, pinned again by static samples, or
    /// ended (an expiry is known only here).
    UnknownPayload {
        /// Cycle of the change.
        cycle: u64,
        /// The mode after it.
        view: UnknownPayloadView,
    },
    /// The controller left command mode during a move and brakes the arm: until the arm rests,
    /// the detector sees the residual less `allowance_nm`.
    Braking {
        /// Cycle of the loss of command mode.
        cycle: u64,
        /// Allowance per joint, Nm (joints 1..7).
        allowance_nm: [f64; 7],
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
