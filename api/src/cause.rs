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
    /// The calibration recording holds a contact-like onset: a residual held far beyond the
    /// rest of the recording (`safety::calibration::screen`); nothing was fitted or installed.
    ContactInRecording {
        /// Joint, 1..7.
        joint: usize,
        /// When the held residual first lay beyond the limit, s (the clock of `time_s`).
        onset_s: f64,
        /// When it peaked, s.
        peak_s: f64,
        /// The residual held over 0.1 s at the peak, Nm (signed).
        residual_nm: f64,
        /// The joint's residual envelope there without contact, Nm.
        envelope_nm: f64,
        /// The peak's score against the rest of the recording.
        score: f64,
        /// The score a recording without contact stays below.
        limit: f64,
    },
    /// Calibrated thresholds above the configured ceiling (`[observer] calibration_ceiling_nm`,
    /// at rest or as the median over the recording) are installed only with `allow_weaker`.
    CalibrationAboveCeiling {
        /// The joints above it.
        joints: Vec<ThresholdAboveCeiling>,
    },
}

/// A calibrated threshold above the configured ceiling: at rest, or as the median of the
/// schedule over the recording (what the monitor runs at during the task).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ThresholdAboveCeiling {
    /// Joint, 1..7.
    pub joint: usize,
    /// The calibrated threshold at rest θ0, Nm.
    pub threshold_at_rest_nm: f64,
    /// The median of the scheduled threshold over the recording, Nm.
    pub threshold_median_nm: f64,
    /// The ceiling, Nm.
    pub ceiling_nm: f64,
}
