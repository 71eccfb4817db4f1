//! Typed causes of aborted and failed workflows, sent with the error so that the operator (and
//! scripts) learn what really happened, with the controller's view at the time: a fault is never
//! reported as a contact, and only the operator's own `stop` as "stopped by the operator".

use serde::{Deserialize, Serialize};

use crate::fri_context::FriContext;

/// Why a workflow ended early.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Cause {
    /// The armed collision monitor detected a contact.
    Collision {
        /// Isolated link, 1..7.
        link: u32,
        /// Controller time of the onset, s since the service started.
        time_s: f64,
        /// Residual at the onset, Nm (joints 1..7).
        residual: [f64; 7],
    },
    /// A residual change during a workflow that may carry an unknown payload (monitor disarmed).
    ResidualChange {
        /// Joint, 1..7.
        joint: usize,
        /// Change since the previous static sample, Nm.
        change_nm: f64,
        /// The limit, Nm (twice the joint's threshold).
        limit_nm: f64,
    },
    /// The operator's `stop`.
    OperatorStop,
    /// The arm was already held (operator stop or collision reaction) when the move was asked.
    Held,
    /// The armed monitor faulted and stopped the arm.
    ObserverFault {
        /// The fault, as text.
        fault: String,
        /// The controller's view then.
        fri: FriContext,
    },
    /// The controller left command mode and stayed out of it (after the allowed retries).
    CommandModeLost {
        /// Moves re-driven before giving up.
        retries: u32,
        /// The controller's view when command mode was lost.
        fri: FriContext,
    },
    /// The controller restarted during the workflow.
    ControllerRestarted {
        /// The controller's view after the restart.
        fri: FriContext,
    },
    /// No measurement arrived for longer than the connection timeout.
    ControllerSilent {
        /// Silence so far, s (+∞, written as `null`, when no measurement ever arrived).
        #[serde(deserialize_with = "crate::results::lenient::infinity")]
        silent_s: f64,
        /// The controller's view in its last measurement, if any.
        fri: Option<FriContext>,
    },
    /// A request argument outside its allowed range (nothing was done).
    OutOfRange {
        /// The field, e.g. `thresholds[6]` (joint 7 is index 6).
        field: String,
        /// The rejected value, in `unit` (`null` in JSON for NaN or an infinity).
        #[serde(deserialize_with = "crate::results::lenient::nan")]
        value: f64,
        /// Smallest allowed value, in `unit`.
        min: f64,
        /// Largest allowed value, in `unit`.
        max: f64,
        /// The unit (empty for counts).
        unit: String,
    },
    /// The arm did not come to rest at a sampling pose in time (no sample was taken).
    NotSettled {
        /// Largest joint velocity over the last settle window, rad/s (`null` in JSON before a
        /// full window).
        #[serde(deserialize_with = "crate::results::lenient::nan")]
        speed_rad_s: f64,
        /// The rest limit `estimation.settle_velocity`, rad/s.
        limit_rad_s: f64,
        /// How long the workflow waited, s (`estimation.settle_timeout_s`).
        waited_s: f64,
    },
    /// The controller did not enter command mode in time.
    CommandModeNotEntered {
        /// The controller's view in its last measurement, if any.
        fri: Option<FriContext>,
    },
}
