//! `status`: the controller link, the newest published state, payload and monitor.

use fri::session::{PendingResync, SessionStatistics};
use fri::wire::InterfaceStatistics;
use serde::{Deserialize, Serialize};

use super::collision::MonitorSettings;
use super::lenient;
use super::payload::AppliedPayload;
use super::state::ServiceState;

/// Result of `status`. The state fields are `null` before the first measurement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StatusResult {
    /// A measurement arrived within the connection timeout (100 ms or ten controller cycles).
    pub connected: bool,
    /// The collision monitor's residual is valid (false while it warms up after a (re)start).
    pub residual_valid: bool,
    /// The FRI endpoint's view (`null` when the service runs without an endpoint snapshot).
    pub fri: Option<FriStatus>,
    /// Loop cycle of the newest published state.
    pub cycle: Option<u64>,
    /// Controller time of the newest state, s since the service started.
    pub time_s: Option<f64>,
    /// Measured joint positions, rad (joints 1..7).
    #[serde(deserialize_with = "lenient::opt_nan_array")]
    pub q: Option<[f64; 7]>,
    /// Filtered joint velocities, rad/s.
    #[serde(deserialize_with = "lenient::opt_nan_array")]
    pub qd: Option<[f64; 7]>,
    /// Measured joint torques τ_J, Nm.
    #[serde(deserialize_with = "lenient::opt_nan_array")]
    pub tau: Option<[f64; 7]>,
    /// Gravity torques of the model (with the applied payload), Nm.
    #[serde(deserialize_with = "lenient::opt_nan_array")]
    pub gravity: Option<[f64; 7]>,
    /// The controller's external-torque estimate, Nm.
    #[serde(deserialize_with = "lenient::opt_nan_array")]
    pub tau_ext: Option<[f64; 7]>,
    /// Collision-observer residual, Nm (NaN, `null` in JSON, while the monitor warms up).
    #[serde(deserialize_with = "lenient::opt_nan_array")]
    pub residual: Option<[f64; 7]>,
    /// The controller is in command mode.
    pub command_mode: bool,
    /// The arm is held (operator stop or collision reaction).
    pub stopped: bool,
    /// A collision reaction is active.
    pub collision: bool,
    /// The collision monitor reports a fault.
    pub observer_fault: bool,
    /// A commanded move is running.
    pub moving: bool,
    /// The payload applied to the observer (`null`: none).
    pub payload: Option<AppliedPayload>,
    /// Who applied the payload in force (`null`: no payload, or a daemon older than this
    /// field).
    #[serde(default)]
    pub payload_origin: Option<crate::origin::Origin>,
    /// Static samples of the stored tare (`null`: no tare stored).
    pub tare_samples: Option<usize>,
    /// What makes the monitor in force weaker than the configuration file's (higher
    /// thresholds, lower gains, a report-only reaction, disarmed); empty when nothing does.
    #[serde(default)]
    pub weaker_than_configuration: Vec<String>,
    /// Collision-monitor settings.
    pub monitor: MonitorSettings,
    /// The configuration's `[ros2] allow_unauthenticated_commands` is true: the service accepts
    /// commands a ROS 2 bridge forwards for participants DDS Security did not authenticate
    /// (absent from older daemons: false).
    #[serde(default)]
    pub ros2_unauthenticated_commands: bool,
    /// The service's state in the newest cycle (`null` before the first measurement; absent
    /// from daemons older than this field).
    #[serde(default)]
    pub state: Option<ServiceState>,
    /// The payload is declared unknown (`expect-payload`): the armed monitor detects against
    /// what a plausible flange load explains (`null`: the applied payload is the payload; absent
    /// from older daemons).
    #[serde(default)]
    pub unknown_payload: Option<super::expect_payload::UnknownPayload>,
    /// The robot model the service predicts torque with (absent from older daemons).
    #[serde(default)]
    pub robot: Option<RobotModelStatus>,
    /// What the service dropped rather than delay the 1 kHz loop (absent from older daemons).
    #[serde(default)]
    pub dropped: Option<DroppedCounts>,
}

/// Messages the service dropped since its start rather than let the loop wait.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct DroppedCounts {
    /// Cycle events (states, collisions, stops) the loop could not queue for the operator side:
    /// workflows and `watch` missed them.
    pub loop_events: u64,
    /// Messages the iceoryx2 publisher thread could not take (`null`: iceoryx2 disabled).
    pub ipc_messages: Option<u64>,
}

/// The robot model the observer, the detector and the estimate against a model use.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RobotModelStatus {
    /// Built-in model name (`lwr4`).
    pub model: String,
    /// The identified arm in force (`robot.calibration`; `null`: the nominal model).
    pub calibration: Option<ArmCalibration>,
}

/// An identified arm as the service loaded it (`fri-ctl offline identify --out FILE`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ArmCalibration {
    /// The file, as configured.
    pub path: String,
    /// The recordings it was identified from, as given to `identify`.
    pub logs: Vec<String>,
    /// Recorded time the identification used, s.
    pub duration_s: f64,
    /// Residual RMS of the nominal model on those recordings, Nm per joint.
    pub residual_rms_nominal: Vec<f64>,
    /// Held-out residual RMS of the identified model (segments of other speeds than the fit
    /// saw), Nm per joint: what it still gets wrong on motion it was not fitted to.
    pub heldout_rms: Vec<f64>,
    /// Per-joint torque offset the service subtracts, Nm.
    pub offset: Vec<f64>,
}

/// The FRI endpoint's snapshot as `status` reports it (enum values as their Rust names).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FriStatus {
    /// A measurement has been accepted since the start.
    pub valid: bool,
    /// FRI interface state: `Invalid`, `Off`, `Monitor`, `Command` or `Unknown(n)`.
    pub state: String,
    /// Communication quality: `Invalid`, `Unacceptable`, `Bad`, `Ok`, `Perfect` or `Unknown(n)`.
    pub quality: String,
    /// The KRL program's status (`fri::handshake::KrlStatus` name).
    pub krl_status: String,
    /// The KRL program's reason of the last drop to monitor mode (`DropReason` name).
    pub drop_reason: String,
    /// Cycles completed by the endpoint.
    pub cycles: u64,
    /// The session's counters (received, accepted, rejected by reason, sequence, timing in s).
    pub statistics: SessionStatistics,
    /// The controller's statistics of our answers (rates 0…1, latency and jitter in s).
    pub controller_statistics: InterfaceStatistics,
    /// While the controller is not connected: datagrams of a restarted controller (or of one on
    /// a new source) that the session refuses until the bound one has been silent for
    /// `fri.resync_after_s`, and how long that still takes (absent when nothing waits).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resync: Option<PendingResync>,
}
