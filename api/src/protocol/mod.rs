//! Operator protocol messages: one JSON object per line in each direction.
//!
//! Request: `{"id": 1, "cmd": "status", ...arguments}`. Replies carry the request's `id` and are
//! either a final response `{"id": 1, "ok": true, "result": {...}}` /
//! `{"id": 1, "ok": false, "error": {"code": "...", "message": "..."}}`, or, before it, any number
//! of streamed events `{"id": 1, "event": "progress", "data": {...}}`.
//! The full schema is documented in `docs/operator-protocol.md`.

use serde::{Deserialize, Serialize};
use serde_json::Value;

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
    /// Apply a payload (frame 7) to the observer and persist it.
    ApplyPayload {
        /// Mass, kg.
        mass: f64,
        /// Centre of mass in frame 7, m.
        com: [f64; 3],
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

/// Error codes of the protocol (stable strings; scripts match on them).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ErrorCode {
    /// Not JSON, not an object, or missing/invalid `id`.
    Malformed,
    /// Line longer than the server's limit.
    TooLarge,
    /// `cmd` missing or not a known command.
    UnknownCommand,
    /// Arguments missing, of the wrong type, unknown, or out of range.
    InvalidArguments,
    /// Too many requests in flight on this connection, or a workflow already running.
    Busy,
    /// The robot is not in a state that allows the command (no FRI connection, stopped, ...).
    NotReady,
    /// The workflow was aborted by a collision or an operator stop.
    Aborted,
    /// The command ran but failed (e.g. estimation could not be computed).
    Failed,
    /// Internal error of the service.
    Internal,
}

/// A failed request: code plus human-readable message.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, thiserror::Error)]
#[error("{code:?}: {message}")]
pub struct OperatorError {
    /// Machine-readable code.
    pub code: ErrorCode,
    /// What went wrong and, where possible, what to do.
    pub message: String,
    /// The typed cause with the controller's view at the time, where the service knows it
    /// (boxed: it is large and every `Result<_, OperatorError>` would carry its size).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cause: Option<Box<crate::cause::Cause>>,
}

impl OperatorError {
    /// Builds an error.
    pub fn new(code: ErrorCode, message: impl Into<String>) -> Self {
        Self {
            code,
            message: message.into(),
            cause: None,
        }
    }

    /// The `invalid-arguments` error for a value outside its range, with the field, value and
    /// range as its cause.
    pub fn out_of_range(e: crate::bounds::OutOfRange) -> Self {
        let cause = crate::cause::Cause::OutOfRange {
            field: e.field.clone(),
            value: e.value,
            min: e.range.min,
            max: e.range.max,
            unit: e.range.unit.to_owned(),
        };
        Self::new(ErrorCode::InvalidArguments, e.to_string()).with_cause(cause)
    }

    /// This error with its typed cause.
    pub fn with_cause(mut self, cause: crate::cause::Cause) -> Self {
        self.cause = Some(Box::new(cause));
        self
    }
}

/// One line from the server.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Reply {
    /// A streamed event of a running request.
    Event {
        /// Request id (`null` when the request had no readable id).
        id: Option<RequestId>,
        /// Event kind, e.g. `progress`, `collision`, `state`.
        event: String,
        /// Event payload.
        data: Value,
    },
    /// Final success.
    Ok {
        /// Request id.
        id: Option<RequestId>,
        /// Always true.
        ok: bool,
        /// Command result.
        result: Value,
    },
    /// Final failure.
    Err {
        /// Request id (`null` when the request had no readable id).
        id: Option<RequestId>,
        /// Always false.
        ok: bool,
        /// The error.
        error: OperatorError,
    },
}

impl Reply {
    /// A success line.
    pub fn ok(id: Option<RequestId>, result: Value) -> Self {
        Reply::Ok {
            id,
            ok: true,
            result,
        }
    }

    /// An error line.
    pub fn err(id: Option<RequestId>, error: OperatorError) -> Self {
        Reply::Err {
            id,
            ok: false,
            error,
        }
    }

    /// Serialises to one line without the trailing newline.
    pub fn to_line(&self) -> String {
        // Serialising a Value-based enum cannot fail (no maps with non-string keys).
        serde_json::to_string(self).unwrap_or_else(|_| {
            r#"{"id":null,"ok":false,"error":{"code":"internal","message":"serialisation failed"}}"#
                .to_owned()
        })
    }

    /// Whether this line ends its request (success or error).
    pub fn is_final(&self) -> bool {
        !matches!(self, Reply::Event { .. })
    }
}

/// The ROS 2 participant a bridge forwards a request for (the request's `ros2` key): the
/// service records it, with the bridge's own credentials, as the request's
/// [`Origin`](crate::origin::Origin).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Ros2Caller {
    /// The participant's DDS GUID, hex with `.` separators (at most
    /// [`MAX_PARTICIPANT_LEN`](crate::origin::MAX_PARTICIPANT_LEN) characters).
    pub participant: String,
    /// Whether DDS Security authenticated it.
    pub authenticated: bool,
}

/// A parsed request line.
#[derive(Debug, Clone, PartialEq)]
pub struct Request {
    /// Client-chosen id.
    pub id: RequestId,
    /// The ROS 2 participant the request is forwarded for (`None`: the client's own).
    pub ros2: Option<Ros2Caller>,
    /// The command.
    pub command: Command,
}

impl Request {
    /// A request of the client's own (no ROS 2 participant).
    pub fn new(id: RequestId, command: Command) -> Self {
        Self {
            id,
            ros2: None,
            command,
        }
    }

    /// Serialises to one line without the trailing newline (used by `fri-ctl`).
    pub fn to_line(&self) -> String {
        let mut value = serde_json::to_value(&self.command).unwrap_or(Value::Null);
        if let Value::Object(map) = &mut value {
            map.insert("id".to_owned(), Value::from(self.id));
            if let Some(caller) = &self.ros2
                && let Ok(v) = serde_json::to_value(caller)
            {
                map.insert("ros2".to_owned(), v);
            }
        }
        value.to_string()
    }
}

/// Reads and checks the request's `ros2` key (removed from `map`).
fn take_ros2_caller(
    id: RequestId,
    map: &mut serde_json::Map<String, Value>,
) -> Result<Option<Ros2Caller>, (Option<RequestId>, OperatorError)> {
    let Some(value) = map.remove("ros2") else {
        return Ok(None);
    };
    let invalid = |message: String| {
        (
            Some(id),
            OperatorError::new(ErrorCode::InvalidArguments, message),
        )
    };
    let caller: Ros2Caller = serde_json::from_value(value).map_err(|e| {
        invalid(format!(
            "`ros2` must be {{\"participant\": GUID, \"authenticated\": bool}}: {e}"
        ))
    })?;
    if !crate::origin::Origin::valid_participant(&caller.participant) {
        return Err(invalid(format!(
            "`ros2.participant` must be 1 to {} characters of hex digits, `.` and `:`",
            crate::origin::MAX_PARTICIPANT_LEN
        )));
    }
    Ok(Some(caller))
}

/// Parses one request line. On failure returns the id (when it could be read) and the error,
/// so the error reply can still be matched to its request.
pub fn parse_request(line: &[u8]) -> Result<Request, (Option<RequestId>, OperatorError)> {
    let value: Value = serde_json::from_slice(line).map_err(|e| {
        (
            None,
            OperatorError::new(ErrorCode::Malformed, format!("not valid JSON: {e}")),
        )
    })?;
    let Value::Object(mut map) = value else {
        return Err((
            None,
            OperatorError::new(ErrorCode::Malformed, "a request must be a JSON object"),
        ));
    };
    let id = match map.remove("id") {
        Some(v) => v.as_u64().ok_or((
            None,
            OperatorError::new(ErrorCode::Malformed, "`id` must be a non-negative integer"),
        ))?,
        None => {
            return Err((
                None,
                OperatorError::new(ErrorCode::Malformed, "missing `id`"),
            ));
        }
    };
    let cmd = match map.get("cmd") {
        Some(Value::String(s)) => s.clone(),
        Some(_) => {
            return Err((
                Some(id),
                OperatorError::new(ErrorCode::UnknownCommand, "`cmd` must be a string"),
            ));
        }
        None => {
            return Err((
                Some(id),
                OperatorError::new(ErrorCode::UnknownCommand, "missing `cmd`"),
            ));
        }
    };
    if !Command::NAMES.contains(&cmd.as_str()) {
        return Err((
            Some(id),
            OperatorError::new(
                ErrorCode::UnknownCommand,
                format!(
                    "unknown command `{cmd}`; known: {}",
                    Command::NAMES.join(", ")
                ),
            ),
        ));
    }
    let ros2 = take_ros2_caller(id, &mut map)?;
    // Ranges first: serde's messages name neither the field nor the allowed range.
    crate::arguments::check(&cmd, &map).map_err(|e| (Some(id), e))?;
    let keys: Vec<String> = map.keys().cloned().collect();
    let command: Command = serde_json::from_value(Value::Object(map)).map_err(|e| {
        (
            Some(id),
            OperatorError::new(
                ErrorCode::InvalidArguments,
                format!("invalid arguments for `{cmd}`: {e}"),
            ),
        )
    })?;
    // serde ignores unknown fields on unit variants of internally tagged enums; every field of
    // every variant is serialised (None as null), so a key missing there is unknown.
    if let Ok(Value::Object(known)) = serde_json::to_value(&command)
        && let Some(extra) = keys.iter().find(|k| !known.contains_key(*k))
    {
        return Err((
            Some(id),
            OperatorError::new(
                ErrorCode::InvalidArguments,
                format!("unknown argument `{extra}` for `{cmd}`"),
            ),
        ));
    }
    Ok(Request { id, ros2, command })
}

#[cfg(test)]
mod tests;
