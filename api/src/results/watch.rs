//! `watch`: the loop's events (and optionally every n-th state) until the client goes away.

use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::fri_context::FriContext;

/// Result of `watch` (sent when the loop's event stream ends).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WatchResult {
    /// Always `"ended"`.
    pub watch: String,
}

/// Payload of a `collision` event: an onset detected while the monitor is armed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CollisionDetected {
    /// Controller time of the onset, s since the service started.
    pub time_s: f64,
    /// Loop cycle of the onset.
    pub cycle: u64,
    /// Isolated link, 1..7.
    pub link: u32,
    /// Joints whose residual exceeded the threshold, 1-based.
    pub joints: Vec<usize>,
    /// Residual at the onset, Nm (joints 1..7).
    pub residual: [f64; 7],
    /// Confidence of `link` (the contact fit's posterior probability), 0…1; absent when the fit
    /// did not run (and from older daemons).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub confidence: Option<f64>,
    /// Estimated contact point, base frame, m; absent when the fit did not run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub contact_point: Option<[f64; 3]>,
    /// Estimated contact wrench at the base origin, base frame (force N, moment Nm; see
    /// `fri_api::ipc::CollisionMessage::wrench`); absent when the fit did not run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wrench: Option<[f64; 6]>,
}

/// Payload of a `stopped` event: the loop holds the arm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stopped {
    /// Loop cycle of the stop.
    pub cycle: u64,
    /// Short, stable name of the reason (scripts match on it).
    pub reason: StopKind,
    /// Operator text of the reason.
    pub detail: String,
    /// The reason with its data.
    pub cause: StopCause,
    /// The controller's view then.
    pub fri: FriContext,
}

/// Short name of a stop reason.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum StopKind {
    /// The operator's `stop`.
    Operator,
    /// The armed collision reaction.
    Collision,
    /// The armed monitor faulted.
    ObserverFault,
}

/// Why the loop stopped the arm, with its data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum StopCause {
    /// The operator's `stop`.
    Operator,
    /// The armed collision reaction.
    Collision {
        /// Isolated link, 1..7.
        link: u32,
        /// Controller time of the onset, s since the service started.
        time_s: f64,
        /// Residual at the onset, Nm (joints 1..7).
        residual: [f64; 7],
    },
    /// The armed monitor faulted.
    ObserverFault {
        /// The observer's fault as `safety::Fault` serialises it (externally tagged; joints
        /// 0-based); the operator text is the event's `detail`.
        fault: Value,
    },
}

/// Payload of a `resumed` event.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Resumed {
    /// Loop cycle of the resume.
    pub cycle: u64,
}

/// Payload of a `move-aborted` event: a commanded move ended before its target.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MoveAborted {
    /// Loop cycle of the abort.
    pub cycle: u64,
    /// Why.
    pub reason: AbortReason,
    /// Operator text of the reason.
    pub detail: String,
    /// The controller's view then.
    pub fri: FriContext,
}

/// Why a commanded move ended before its target.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum AbortReason {
    /// The arm is held (operator stop or collision reaction).
    Held,
    /// The controller left command mode without our request.
    CommandModeLost,
    /// The controller restarted (new sequence epoch).
    ControllerRestarted,
    /// The move could not be planned from the current set-point.
    Unplannable,
    /// A brake (stop or reaction) interrupted the move.
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

/// Payload of a `monitor-restarted` event: the residual is invalid until the warm-up ends.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MonitorRestarted {
    /// Loop cycle of the restart.
    pub cycle: u64,
    /// Why.
    pub reason: ResyncReason,
    /// Operator text of the reason.
    pub detail: String,
    /// The controller's view then.
    pub fri: FriContext,
}

/// Why the collision monitor started over.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum ResyncReason {
    /// The controller restarted (or a new controller was bound).
    ControllerRestarted,
    /// Measurements went missing for longer than the observer can bridge.
    Gap {
        /// Controller cycles since the previous accepted measurement.
        cycles: u32,
    },
    /// The controller left command mode within a gap the observer would otherwise bridge: its
    /// stop steps the torque somewhere inside the gap, which no integration across it can place.
    StoppedInGap {
        /// Controller cycles since the previous accepted measurement.
        cycles: u32,
    },
}

impl ResyncReason {
    /// Operator-facing text.
    pub fn describe(&self) -> String {
        match self {
            ResyncReason::ControllerRestarted => "the controller restarted".to_owned(),
            ResyncReason::Gap { cycles } => {
                format!("{cycles} controller cycles passed without a measurement")
            }
            ResyncReason::StoppedInGap { cycles } => format!(
                "the controller left command mode within {cycles} cycles without a measurement"
            ),
        }
    }
}

/// Payload of the first event of a `watch`: nothing after `cycle` is missed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Watching {
    /// The newest loop cycle when the subscription started (`None` before any measurement).
    pub cycle: Option<u64>,
}

/// Payload of a `state` event (`watch --state-every N`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StateLine {
    /// Loop cycle.
    pub cycle: u64,
    /// Controller time, s since the service started.
    pub time_s: f64,
    /// Measured joint positions, rad (joints 1..7).
    pub q: [f64; 7],
    /// Measured joint torques τ_J, Nm.
    pub tau: [f64; 7],
    /// Collision-observer residual, Nm (NaN, `null` in JSON, while the monitor warms up).
    #[serde(deserialize_with = "crate::results::lenient::nan_array")]
    pub residual: [f64; 7],
    /// State flags (`fri_api::ipc::flags` bits).
    pub flags: u32,
}
