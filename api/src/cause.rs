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
    /// The estimate means nothing (`estimator::verdict`): it was not applied, and nothing
    /// applies it.
    EstimateRejected {
        /// The estimated mass, kg.
        #[serde(deserialize_with = "crate::results::lenient::nan")]
        mass_kg: f64,
        /// Its 1σ, kg.
        #[serde(deserialize_with = "crate::results::lenient::nan")]
        mass_std_kg: f64,
        /// The estimated centre of mass in the flange frame, m (`null` where undetermined).
        #[serde(deserialize_with = "crate::results::lenient::nan_array")]
        com_flange_m: [f64; 3],
        /// Every bound it breaks.
        problems: Vec<EstimateProblem>,
    },
    /// The tare's own samples, fitted as a payload, see a load: refused unless
    /// `replace_loaded` (the stored tare is kept).
    LoadedTare {
        /// The load's mass, kg.
        mass_kg: f64,
        /// Its 1σ, kg.
        mass_std_kg: f64,
        /// k: a load counts above k·σ.
        sigmas: f64,
        /// What the samples were compared with.
        against: TareReference,
    },
    /// Calibrated thresholds above the configured ceiling (`[observer] calibration_ceiling_nm`,
    /// at rest or as the median over the recording) are installed only with `allow_weaker`.
    CalibrationAboveCeiling {
        /// The joints above it.
        joints: Vec<ThresholdAboveCeiling>,
    },
    /// `expect-payload` while the payload is declared unknown already: a new declaration would
    /// reopen the grasp window and forget the pin, so the active one stays as it is.
    AlreadyDeclared {
        /// The active declaration's number.
        declaration: u32,
        /// Whether its load is pinned (a change of it is a contact).
        pinned: bool,
    },
    /// `expect-payload` after `max` declarations with no payload applied since: each opens a
    /// grasp window in which a flange force passes for a load.
    DeclarationsExhausted {
        /// Declarations since a payload with mass was last applied.
        declarations: u32,
        /// The bound.
        max: u32,
    },
    /// `apply-payload`: the declared payload does not explain the static torques measured at
    /// rest, or the check could not compare (the arm moves, no baseline, no measurement);
    /// nothing was applied (`force` applies it, audited as weakening).
    PayloadImplausible {
        /// Why, with both figures.
        refusal: crate::payload_check::PayloadRefusal,
    },
    /// Thresholds fitted offline for another setup than this service's (`collision-install`):
    /// the residual they bound was computed at another controller period or on another arm
    /// model, so they would not bound this service's residual.
    ThresholdsForAnotherSetup {
        /// What differs: `period_s` or `arm_offset`.
        field: String,
        /// The thresholds' value, with its unit.
        thresholds: String,
        /// This service's value, with its unit.
        service: String,
    },
}

/// A calibrated threshold above the configured ceiling: at rest, as the median of the schedule
/// over the recording (what the monitor runs at during the task), or at the schedule's largest
/// value (its cap: what it may reach in a faster motion).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ThresholdAboveCeiling {
    /// Joint, 1..7.
    pub joint: usize,
    /// The calibrated threshold at rest θ0, Nm.
    pub threshold_at_rest_nm: f64,
    /// The median of the scheduled threshold over the recording, Nm.
    pub threshold_median_nm: f64,
    /// The largest the scheduled threshold may become (its cap), Nm (0 from a service that did
    /// not report it).
    #[serde(default)]
    pub threshold_max_nm: f64,
    /// The ceiling, Nm.
    pub ceiling_nm: f64,
}

/// Why an estimate means nothing (`estimator::verdict::Problem`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "problem", rename_all = "kebab-case")]
pub enum EstimateProblem {
    /// The mass is not significantly positive: m ≤ k·σ_m.
    MassNotSignificant {
        /// The mass, kg.
        mass_kg: f64,
        /// Its 1σ, kg.
        mass_std_kg: f64,
        /// k.
        sigmas: f64,
    },
    /// The centre of mass lies beyond `[estimation] max_com_distance_m` of the flange point.
    ComBeyondReach {
        /// Its distance from the flange point, m.
        distance_m: f64,
        /// The bound, m.
        max_m: f64,
    },
    /// σ_m above `[estimation] max_mass_std_kg`.
    MassUncertain {
        /// σ_m, kg.
        mass_std_kg: f64,
        /// The bound, kg.
        max_kg: f64,
    },
    /// The centre of mass's RMS error above `[estimation] max_com_std_m`.
    ComUncertain {
        /// √(σx² + σy² + σz²), m.
        com_std_m: f64,
        /// The bound, m.
        max_m: f64,
    },
}

impl std::fmt::Display for EstimateProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            EstimateProblem::MassNotSignificant {
                mass_kg,
                mass_std_kg,
                sigmas,
            } => write!(
                f,
                "the mass {mass_kg:.4} ± {mass_std_kg:.4} kg is not significantly positive (it must exceed {sigmas}σ)"
            ),
            EstimateProblem::ComBeyondReach { distance_m, max_m } => write!(
                f,
                "the centre of mass lies {:.0} mm from the flange, beyond the {:.0} mm a payload held by it can reach",
                distance_m * 1e3,
                max_m * 1e3
            ),
            EstimateProblem::MassUncertain {
                mass_std_kg,
                max_kg,
            } => write!(
                f,
                "the mass is uncertain by {mass_std_kg:.4} kg (1σ), more than {max_kg} kg"
            ),
            EstimateProblem::ComUncertain { com_std_m, max_m } => write!(
                f,
                "the centre of mass is uncertain by {:.1} mm (RMS), more than {:.1} mm",
                com_std_m * 1e3,
                max_m * 1e3
            ),
        }
    }
}

/// What a tare's samples were compared with to see a load.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TareReference {
    /// The stored tare at the same poses (taken after the last controller restart).
    PreviousTare,
    /// The controller's gravity vector (no usable stored tare, the nominal model).
    ControllerGravity,
    /// The identified arm's gravity and offsets (no usable stored tare, `robot.calibration`).
    IdentifiedModel,
}

impl TareReference {
    /// In words.
    pub fn describe(self) -> &'static str {
        match self {
            TareReference::PreviousTare => "the stored tare at the same poses",
            TareReference::ControllerGravity => "the controller's gravity vector",
            TareReference::IdentifiedModel => "the identified arm's gravity and offsets",
        }
    }
}
