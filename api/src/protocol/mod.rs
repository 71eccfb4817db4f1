//! Operator protocol messages: one JSON object per line in each direction.
//!
//! Request: `{"id": 1, "cmd": "status", ...arguments}`. Replies carry the request's `id` and are
//! either a final response `{"id": 1, "ok": true, "result": {...}}` /
//! `{"id": 1, "ok": false, "error": {"code": "...", "message": "..."}}`, or, before it, any number
//! of streamed events `{"id": 1, "event": "progress", "data": {...}}`.
//! The full schema is documented in `docs/operator-protocol.md`.

use serde::{Deserialize, Serialize};

pub mod arguments;
mod error;
mod reply;
mod request;

pub use error::{ErrorCode, OperatorError};
pub use reply::Reply;
pub use request::{Request, Ros2Caller, parse_request};

/// Request id chosen by the client; echoed on every reply line of that request.
pub type RequestId = u64;

/// One operator command with its arguments (the `cmd` field selects the variant).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "cmd", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Command {
    /// FRI state, statistics, measured state, residual, applied payload, monitor state.
    Status,
    /// One averaged static sample at the current pose.
    Sample {
        /// Averaging window, s (default from the config's `estimation.average_s`).
        #[serde(default)]
        duration_s: Option<f64>,
    },
    /// Drive the pose pattern without payload and store the samples as tare.
    Tare {
        /// Pick pose around which the pattern is driven, rad (default: current pose).
        #[serde(default)]
        around: Option<[f64; 7]>,
        /// Number of poses (default from config).
        #[serde(default)]
        poses: Option<usize>,
        /// Pattern increment, degrees (default from config, 7).
        #[serde(default)]
        step_deg: Option<f64>,
        /// Pose pattern (default `[estimation] pattern`, `centred`).
        #[serde(default)]
        pattern: Option<crate::pattern::PatternKind>,
        /// Store the tare even when its samples see a load (default false: such a tare is
        /// refused and the stored one kept; a load that belongs to the arm, e.g. a gripper the
        /// controller's model lacks, needs this once).
        #[serde(default)]
        replace_loaded: Option<bool>,
    },
    /// Drive the pose pattern with the payload, estimate it and return it with uncertainties.
    EstimatePayload {
        /// Pick pose around which the pattern is driven, rad (default: current pose).
        #[serde(default)]
        around: Option<[f64; 7]>,
        /// Number of poses (default from config).
        #[serde(default)]
        poses: Option<usize>,
        /// Pattern increment, degrees (default from config, 7).
        #[serde(default)]
        step_deg: Option<f64>,
        /// Pose pattern (default `[estimation] pattern`, `centred`).
        #[serde(default)]
        pattern: Option<crate::pattern::PatternKind>,
        /// Subtract the stored tare (default: when one is stored for the same poses).
        #[serde(default)]
        use_tare: Option<bool>,
        /// Apply the estimate to the observer and persist it (default false).
        #[serde(default)]
        apply: Option<bool>,
    },
    /// Apply a payload (frame 7) to the observer and persist it, once its gravity torques agree
    /// with the static torques measured at rest (`docs/collision-detection.md` §4.1).
    ApplyPayload {
        /// Mass, kg.
        mass: f64,
        /// Centre of mass in frame 7, m.
        com: [f64; 3],
        /// Apply it even when the check refuses it (default false); the audit trail records
        /// the refusal overridden as a weakening.
        #[serde(default)]
        force: Option<bool>,
    },
    /// Remove the applied payload (persisted).
    ClearPayload,
    /// Declare the payload unknown (before grasping it): the monitor stays armed and tolerates
    /// only what a plausible static flange load explains; `estimate-payload --apply`,
    /// `apply-payload` or `clear-payload` end it, or `end`.
    ExpectPayload {
        /// Largest plausible payload mass, kg (default `unknown_payload.max_mass_kg`).
        #[serde(default)]
        max_mass: Option<f64>,
        /// Radius around the flange point that holds the payload, m (default
        /// `unknown_payload.max_radius_m`).
        #[serde(default)]
        max_radius: Option<f64>,
        /// End the mode without applying a payload (the applied one, or none, is the payload).
        #[serde(default)]
        end: Option<bool>,
    },
    /// Arm, disarm or tune the collision monitor.
    Collision {
        /// What to do.
        action: CollisionAction,
        /// New per-joint thresholds, Nm (with `configure`).
        #[serde(default)]
        thresholds: Option<[f64; 7]>,
        /// New per-joint observer gains, 1/s (with `configure`).
        #[serde(default)]
        gains: Option<[f64; 7]>,
        /// New reaction to a detected contact (with `configure`).
        #[serde(default)]
        reaction: Option<ReactionMode>,
        /// New pause of the `pause` reaction, s (with `configure`).
        #[serde(default)]
        pause_s: Option<f64>,
    },
    /// Calibrate the collision thresholds for a false-alarm budget on a motion without contact
    /// (`docs/collision-detection.md` §7).
    CollisionCalibrate {
        /// What to fit on (default `excitation`).
        #[serde(default)]
        source: Option<CalibrationSource>,
        /// Recording length, s: required for `current-task`; with `excitation` the excitation
        /// is repeated until at least this much is recorded (default: one pass).
        #[serde(default)]
        duration_s: Option<f64>,
        /// False alarms per hour the thresholds may cause, whole arm (default 0.1: one per 10 h).
        #[serde(default)]
        budget_per_hour: Option<f64>,
        /// Install and persist the calibrated settings (default false: a preview).
        #[serde(default)]
        apply: Option<bool>,
        /// With `apply`: install thresholds above the configured ceiling
        /// (`[observer] calibration_ceiling_nm`, at rest or median over the recording) too —
        /// they weaken detection, and the audit trail records by how much (default false:
        /// refused).
        #[serde(default)]
        allow_weaker: Option<bool>,
    },
    /// Install thresholds calibrated offline (`fri-ctl offline calibrate-thresholds`), checked
    /// against this service's cycle, identified arm and ceiling, and persisted as a
    /// `collision-calibrate` with `apply` would (`docs/collision-detection.md` §7).
    CollisionInstall(Box<InstallThresholds>),
    /// Stop: hold the current position and abort any running workflow.
    Stop,
    /// Resume after a stop or a collision reaction.
    Resume,
    /// Record to a new file (CSV, or MCAP with `kind: mcap`) in the recording directory
    /// (`state.record_dir`).
    Record {
        /// File name in the recording directory: 1 to 255 characters of `A-Z a-z 0-9 . _ -`,
        /// not starting with `.` or `-`, no `/`; an existing name is refused. The reply's
        /// `path` is the full path.
        path: String,
        /// What to record.
        kind: RecordKind,
        /// Recording length for `log` and `mcap`, s; number of samples for `samples` is `count`.
        #[serde(default)]
        duration_s: Option<f64>,
        /// Number of static samples for `samples` (each taken at the current pose).
        #[serde(default)]
        count: Option<usize>,
        /// With `kind: log` only — MOVES THE ARM: drive the built-in identification
        /// excitation (offsets of this amplitude, deg, around the current pose, within the
        /// joint limits less 5°) while logging, repeated until `duration_s` (default one pass),
        /// then hold in monitor mode (default: nothing moves, the log records what the arm does).
        #[serde(default)]
        excite_deg: Option<f64>,
    },
    /// Stream events (collisions, state changes, workflow progress) until the client disconnects.
    Watch {
        /// Also stream a state line every this many cycles (default: events only).
        #[serde(default)]
        state_every: Option<u32>,
    },
}

impl Command {
    /// The `cmd` names the server knows, for `unknown-command` messages.
    pub const NAMES: &'static [&'static str] = &[
        "status",
        "sample",
        "tare",
        "estimate-payload",
        "apply-payload",
        "clear-payload",
        "expect-payload",
        "collision",
        "collision-calibrate",
        "collision-install",
        "stop",
        "resume",
        "record",
        "watch",
    ];

    /// The command's `cmd` name.
    pub fn name(&self) -> &'static str {
        match self {
            Command::Status => "status",
            Command::Sample { .. } => "sample",
            Command::Tare { .. } => "tare",
            Command::EstimatePayload { .. } => "estimate-payload",
            Command::ApplyPayload { .. } => "apply-payload",
            Command::ClearPayload => "clear-payload",
            Command::ExpectPayload { .. } => "expect-payload",
            Command::Collision { .. } => "collision",
            Command::CollisionCalibrate { .. } => "collision-calibrate",
            Command::CollisionInstall(_) => "collision-install",
            Command::Stop => "stop",
            Command::Resume => "resume",
            Command::Record { .. } => "record",
            Command::Watch { .. } => "watch",
        }
    }

    /// Whether the command may move the arm or change what the monitor protects (the audit
    /// trail records it with its origin): everything but reading (`status`, `sample`, `watch`,
    /// `record` without `excite_deg`, `collision show`; the previews of `estimate-payload` and
    /// `collision-calibrate` without `apply`, and an excited `record`, move the arm and so count).
    pub fn changes_state(&self) -> bool {
        !matches!(
            self,
            Command::Status
                | Command::Sample { .. }
                | Command::Watch { .. }
                | Command::Record {
                    excite_deg: None,
                    ..
                }
                | Command::Collision {
                    action: CollisionAction::Show,
                    ..
                }
        )
    }
}

/// The arguments of `collision-install`: a threshold schedule fitted offline and what it was
/// fitted for.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InstallThresholds {
    /// The calibrated schedule: θ0 per joint, Nm, and its motion coefficients.
    pub schedule: crate::schedule::ThresholdSchedule,
    /// What the schedule was fitted on (budget, length, covered speeds).
    pub recording: crate::schedule::CalibrationInfo,
    /// Median scheduled threshold per joint over that recording, Nm (with θ0, what the
    /// ceiling `[observer] calibration_ceiling_nm` is checked against).
    pub median_thresholds: [f64; 7],
    /// Controller period the residual was computed at, s: must be this service's cycle.
    pub period_s: f64,
    /// Observer gains the residual was computed with, 1/s: installed with the thresholds,
    /// which hold only for them.
    pub gains: [f64; 7],
    /// Per-joint torque offsets of the identified arm the observer ran on, Nm (`null`: the
    /// nominal model): must be this service's `robot.calibration`.
    #[serde(default)]
    pub arm_offset: Option<[f64; 7]>,
    /// Where the thresholds come from (the file's name, 1…255 characters), for `status` and
    /// the audit trail.
    pub source: String,
    /// Install thresholds above the configured ceiling too (default false: refused).
    #[serde(default)]
    pub allow_weaker: Option<bool>,
}

/// Collision-monitor sub-command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CollisionAction {
    /// Report the monitor's settings and state.
    Show,
    /// Arm the monitor (reactions enabled).
    Arm,
    /// Disarm the monitor (residual still computed and published).
    Disarm,
    /// Change thresholds, gains and/or the reaction; the new settings are persisted.
    Configure,
}

/// What the service does on a detected collision (the config's `[reaction] policy` and
/// `collision configure`'s `reaction`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ReactionMode {
    /// Only report the event; the arm keeps moving.
    Report,
    /// Stop (hold position) and wait for the operator's `resume`.
    Stop,
    /// Stop, wait `pause_s` after the contact is released, then resume by itself (the paper).
    Pause,
}

impl ReactionMode {
    /// The name used in the protocol and the configuration (`report`, `stop`, `pause`).
    pub fn name(self) -> &'static str {
        match self {
            ReactionMode::Report => "report",
            ReactionMode::Stop => "stop",
            ReactionMode::Pause => "pause",
        }
    }
}

/// What `collision-calibrate` fits the thresholds on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CalibrationSource {
    /// MOVES THE ARM: the built-in excitation within the `[motion]` limits (the paper's q_A,
    /// q_B, q_C joint-1 sweeps and the estimation pose pattern), recorded while it runs.
    #[default]
    Excitation,
    /// Records `duration_s` of whatever the arm does now (the task, run by the robot program or
    /// another client); the service does not move the arm.
    CurrentTask,
    /// Fits the service's last calibration recording again (e.g. for another budget); nothing
    /// moves or is recorded.
    LastRecording,
}

impl CalibrationSource {
    /// The name used in the protocol (`excitation`, `current-task`, `last-recording`).
    pub fn name(self) -> &'static str {
        match self {
            CalibrationSource::Excitation => "excitation",
            CalibrationSource::CurrentTask => "current-task",
            CalibrationSource::LastRecording => "last-recording",
        }
    }
}

/// What `record` writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum RecordKind {
    /// Averaged static samples in the static-sample CSV format (`q1..q7,tau1..tau7,g1..g7`).
    Samples,
    /// Every cycle: time, q, q̇, τ_J, gravity, external torque estimate, residual.
    Log,
    /// The stored tare's static samples (unloaded), in the static-sample CSV format, for
    /// `fri-ctl offline estimate --tare` and `offline calibrate`.
    Tare,
    /// Every cycle and the events as ROS 2 messages in an MCAP file (`ros2` profile): the
    /// topics of the ROS 2 bridge, stamped with the controller's time (docs/ros2.md).
    Mcap,
}

#[cfg(test)]
mod tests;
