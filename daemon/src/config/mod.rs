//! Service configuration: the TOML file given to `fri-service run --config FILE.toml`.
//!
//! Every section and key is optional and falls back to the documented default; unknown keys are
//! rejected (serde `deny_unknown_fields`), and [`Config::validate`] rejects bad values with the
//! key's dotted name and the reason, so a typo never silently runs the robot with defaults.
//! The commented example lives at `daemon/config/fri-service.example.toml`.

use std::net::{IpAddr, SocketAddr};
use std::path::PathBuf;

use serde::{Deserialize, Serialize};

pub use fri_api::{DEFAULT_SOCKET, JOINTS, stop_socket_beside};

/// Errors while loading or validating the configuration.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read (the I/O error is the source: a cause chain prints it once).
    #[error("cannot read config file {path}")]
    Read {
        /// File that failed.
        path: PathBuf,
        /// Underlying I/O error.
        source: std::io::Error,
    },
    /// The file is not valid TOML or has unknown keys / wrong types.
    #[error("config file {path}: {message}")]
    Parse {
        /// File that failed.
        path: PathBuf,
        /// Parser message (names the key and line).
        message: String,
    },
    /// A value is out of its allowed range.
    #[error("config key `{key}`: {reason}")]
    Invalid {
        /// Dotted key name, e.g. `motion.max_velocity`.
        key: String,
        /// Why the value is rejected.
        reason: String,
    },
}

/// Whole service configuration.
#[derive(Debug, Clone, Default, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct Config {
    /// FRI UDP endpoint settings.
    pub fri: FriConfig,
    /// Robot model used by the observer and the estimator.
    pub robot: RobotConfig,
    /// Collision observer gains and thresholds.
    pub observer: ObserverSettings,
    /// What the service does when a collision is detected.
    pub reaction: ReactionConfig,
    /// Limits for moves the service commands itself (estimation poses, returns).
    pub motion: MotionConfig,
    /// Static-sample settling detection and averaging for `sample`, `tare`, `estimate-payload`.
    pub estimation: EstimationConfig,
    /// What a payload declared unknown (`expect-payload`) may be.
    pub unknown_payload: UnknownPayloadConfig,
    /// Operator socket.
    pub operator: OperatorConfig,
    /// Persistent state (applied payload, tare, calibration).
    pub state: StateConfig,
    /// iceoryx2 publication.
    pub iceoryx2: IpcConfig,
    /// The ROS 2 bridge's table, read and validated by `fri-ros2` (docs/ros2.md); the service
    /// only accepts it, so one file configures both.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ros2: Option<toml::Table>,
}

/// FRI UDP endpoint settings.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct FriConfig {
    /// Local address and UDP port the service listens on (default 0.0.0.0:49938).
    pub bind: SocketAddr,
    /// Only accept datagrams from this controller IP address (default: any).
    pub controller: Option<IpAddr>,
    /// Only accept datagrams from this controller UDP port, 1–65535 (default: any; the KRC
    /// sends from its `FRISOCK` port, 49938).
    pub controller_port: Option<u16>,
    /// Silence of the bound controller after which a restart (any counter) or a new source
    /// within the filter is accepted, s (default 1; max(0.01, 10 × cycle_s) to 10).
    pub resync_after_s: f64,
    /// Expected controller cycle, s (default 0.001; FRI allows 0.001–0.1).
    pub cycle_s: f64,
    /// Largest joint set-point change per cycle in command mode, rad (default 2e-4, well under
    /// the controller's set-point jump limit); `motion.max_velocity × cycle_s` must not exceed it.
    pub max_joint_step: f64,
}

impl Default for FriConfig {
    fn default() -> Self {
        Self {
            bind: SocketAddr::from(([0, 0, 0, 0], 49938)),
            controller: None,
            controller_port: None,
            resync_after_s: 1.0,
            cycle_s: 0.001,
            max_joint_step: 2.0e-4,
        }
    }
}

/// Robot model selection.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct RobotConfig {
    /// Built-in model name; only `lwr4` (KUKA LWR 4+, 7 joints) is supported by the service.
    pub model: String,
    /// The arm identified from its own recordings (`fri-ctl offline identify --out FILE`), checked
    /// against `model` at start: the observer, the detector and the estimate against a model
    /// predict torque with it. Unset: the nominal model.
    pub calibration: Option<PathBuf>,
}

impl Default for RobotConfig {
    fn default() -> Self {
        Self {
            model: "lwr4".to_owned(),
            calibration: None,
        }
    }
}

/// The `[observer]` section: collision observer (momentum residual, paper eq. 48) gains,
/// thresholds and arming (the service's settings; `safety::ObserverConfig` is the observer's own).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ObserverSettings {
    /// Observer gains K_I per joint, 1/s (default `safety::DEFAULT_GAIN` = 400 on every joint);
    /// one number sets every joint.
    #[serde(deserialize_with = "per_joint::deserialize")]
    pub gains: [f64; JOINTS],
    /// Detection thresholds per joint, Nm (default 6, as in the paper's Fig. 6); one number
    /// (the form of older files) sets every joint. Also the stated constant of `collision
    /// calibrate`: a calibrated schedule never exceeds it where the recording supports no
    /// smaller constant for the budget.
    #[serde(deserialize_with = "per_joint::deserialize")]
    pub thresholds: [f64; JOINTS],
    /// Whether the collision monitor is armed at start (default true).
    pub armed: bool,
    /// Largest calibrated threshold — at rest, as the median of the schedule over the
    /// recording, and as the schedule's cap (the largest it may reach) — that `collision
    /// calibrate --apply` and `collision-install` install without `allow_weaker`, per joint, Nm
    /// (default the default thresholds, the paper's 6 Nm: a calibration may make detection
    /// sharper than the configuration, never weaker, unless allowed; one number sets every
    /// joint; each within the thresholds' range). A calibration above it weakens detection:
    /// refused, or installed with `allow_weaker` and logged as weaker than the configuration.
    #[serde(deserialize_with = "per_joint::deserialize")]
    pub calibration_ceiling_nm: [f64; JOINTS],
}

/// Default `[observer] calibration_ceiling_nm`, Nm per joint: the default threshold, the
/// paper's constant (a calibration that weakens the configured detection needs `allow_weaker`).
pub const DEFAULT_CALIBRATION_CEILING_NM: f64 = safety::DEFAULT_THRESHOLD_NM;

impl Default for ObserverSettings {
    fn default() -> Self {
        Self {
            gains: [safety::DEFAULT_GAIN; JOINTS],
            thresholds: [6.0; JOINTS],
            armed: true,
            calibration_ceiling_nm: [DEFAULT_CALIBRATION_CEILING_NM; JOINTS],
        }
    }
}

/// `[reaction] policy`: what the service does on a detected collision (mapped onto
/// `safety::ReactionPolicy` by the service; `report` does not react). The protocol's type, so
/// `collision configure --reaction` and the file read the same names.
pub use fri_api::protocol::ReactionMode;

/// What the service does on a collision.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ReactionConfig {
    /// Reaction mode (default `stop`).
    pub policy: ReactionMode,
    /// Pause duration for the `pause` policy, s (default 2).
    pub pause_s: f64,
}

impl Default for ReactionConfig {
    fn default() -> Self {
        Self {
            policy: ReactionMode::Stop,
            pause_s: 2.0,
        }
    }
}

/// Limits for service-commanded joint moves (conservative defaults, well under the LWR's limits).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct MotionConfig {
    /// Maximum joint velocity per joint, rad/s (default 0.18; at most
    /// `fri.max_joint_step / fri.cycle_s`, 0.2 rad/s with the defaults).
    pub max_velocity: [f64; JOINTS],
    /// Maximum joint acceleration per joint, rad/s² (default 1.0).
    pub max_acceleration: [f64; JOINTS],
    /// Maximum joint jerk per joint, rad/s³ (default 5.0).
    pub max_jerk: [f64; JOINTS],
    /// Largest distance of a pattern centre (`around`) from the measured pose, per joint, rad
    /// (default 0.5; 0.01 to 1).
    pub max_around_distance_rad: f64,
}

impl Default for MotionConfig {
    fn default() -> Self {
        Self {
            max_velocity: [0.18; JOINTS],
            max_acceleration: [1.0; JOINTS],
            max_jerk: [5.0; JOINTS],
            max_around_distance_rad: 0.5,
        }
    }
}

/// Settling detection and averaging of static samples.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct EstimationConfig {
    /// Settled when every joint's mean velocity over the settle window (the least-squares slope
    /// of its measured positions) stays below this, rad/s (default 2e-4).
    pub settle_velocity: f64,
    /// Settled when the torque standard deviation of every joint over the settle window is below
    /// this, Nm (default 0.15).
    pub settle_torque_std: f64,
    /// Window over which settling is judged, s (default 0.1).
    pub settle_window_s: f64,
    /// Upper bound of the wait for settling after a move, s (default 1, the paper's wait).
    pub settle_timeout_s: f64,
    /// Averaging window of one static sample, s (default 0.25).
    pub average_s: f64,
    /// Pose pattern of `tare` and `estimate-payload` when the request names none (default
    /// centred).
    pub pattern: fri_api::pattern::PatternKind,
    /// Increment of the pose pattern, degrees (default: the pattern's own, 5 for centred and 7
    /// for paper and optimized).
    pub pattern_step_deg: Option<f64>,
    /// Number of poses of the pattern (default 10, as in the paper's Sec. VI-A).
    pub pattern_poses: usize,
    /// Drive back to the first pose at the end of a pattern and sample it again, so that the
    /// torque sensors' drift over the procedure is measured (default true).
    pub revisit_first_pose: bool,
    /// Prior random-walk rate of the torque offsets, Nm/√s: σ of the drift after t seconds is
    /// rate·√t (default 0.002, the mock robot's model; revisits measure the real one).
    pub drift_rate: f64,
    /// Weight of `drift_rate` against measured drift increments, in increments (one joint over
    /// one revisit is one; default 7, one revisit's worth).
    pub drift_prior_weight: f64,
    /// Without a tare: 1σ of the per-joint constant error of Δτ = τ_J − g_ctrl (torque offset
    /// and the controller's model error at the poses), Nm (default 0.2).
    pub untared_offset_std: f64,
    /// Farthest an estimate's centre of mass may lie from the flange point, m (default 0.3;
    /// 0.01 to 1): beyond it the estimate means nothing and is refused, never applied; the
    /// bound of `apply-payload` too (`estimator::verdict`).
    pub max_com_distance_m: f64,
    /// Largest 1σ of an estimate's mass, kg (default 0.1; 0.001 to 5): above it the estimate
    /// is refused.
    pub max_mass_std_kg: f64,
    /// Largest RMS error √(σx² + σy² + σz²) of an estimate's centre of mass, m (default 0.05;
    /// 0.001 to 1): above it the estimate is refused.
    pub max_com_std_m: f64,
    /// 1σ of the apparent mass the controller's gravity-model error gives a fit against its
    /// gravity vector, kg (default 0.039, lwr4-model.md §4; 0 to 1): added to the fit's σ of an
    /// estimate without a tare and of the load check of a tare without a stored one.
    pub controller_model_mass_std_kg: f64,
}

impl EstimationConfig {
    /// What an estimate must satisfy before it is reported or applied (the mass at least
    /// `estimator::verdict::MASS_SIGNIFICANCE` σ above zero, and this section's bounds); against
    /// the controller's gravity (`tared` false) its model error joins the mass σ.
    pub fn verdict_bounds(&self, tared: bool) -> estimator::verdict::Bounds {
        estimator::verdict::Bounds {
            mass_sigmas: estimator::verdict::MASS_SIGNIFICANCE,
            reference_mass_std_kg: if tared {
                0.0
            } else {
                self.controller_model_mass_std_kg
            },
            max_com_distance_m: self.max_com_distance_m,
            max_mass_std_kg: self.max_mass_std_kg,
            max_com_std_m: self.max_com_std_m,
        }
    }
}

impl Default for EstimationConfig {
    fn default() -> Self {
        Self {
            settle_velocity: 2e-4,
            settle_torque_std: 0.15,
            settle_window_s: 0.1,
            settle_timeout_s: 1.0,
            average_s: 0.25,
            pattern: fri_api::pattern::PatternKind::Centred,
            pattern_step_deg: None,
            pattern_poses: 10,
            revisit_first_pose: true,
            drift_rate: 0.002,
            drift_prior_weight: 7.0,
            untared_offset_std: 0.2,
            max_com_distance_m: estimator::verdict::MAX_COM_DISTANCE_M,
            max_mass_std_kg: estimator::verdict::MAX_MASS_STD_KG,
            max_com_std_m: estimator::verdict::MAX_COM_STD_M,
            controller_model_mass_std_kg: estimator::verdict::CONTROLLER_MODEL_MASS_STD_KG,
        }
    }
}

/// Default bounds of a payload declared unknown (`expect-payload` may narrow them per grasp).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct UnknownPayloadConfig {
    /// Largest plausible payload mass, kg (default 7, the LWR 4+'s rating; range 0.01…7).
    pub max_mass_kg: f64,
    /// Radius around the flange point that holds the payload (its mass and centre of mass), m
    /// (default 0.3; range 0.01…1).
    pub max_radius_m: f64,
    /// Longest time after `expect-payload` in which the load may change (the grasp), s; at its
    /// end the load is pinned (default 10; range 0.5…120).
    pub grasp_window_s: f64,
    /// Time a changed load must stay settled at rest to be pinned before the window ends, s
    /// (default 0.5; range 0.05…5).
    pub settle_s: f64,
    /// Time without an estimate (since the declaration or the last static sample's refit) after
    /// which the mode ends and the monitor detects against the applied payload again, s
    /// (default 120; range 5…3600).
    pub expire_s: f64,
}

impl Default for UnknownPayloadConfig {
    fn default() -> Self {
        Self {
            max_mass_kg: 7.0,
            max_radius_m: 0.3,
            grasp_window_s: safety::payload_tolerance::settle::DEFAULT_GRASP_WINDOW_S,
            settle_s: safety::payload_tolerance::settle::DEFAULT_SETTLE_S,
            expire_s: safety::payload_tolerance::settle::DEFAULT_EXPIRE_S,
        }
    }
}

impl UnknownPayloadConfig {
    /// The timing of an operator's declaration.
    pub fn timing(&self) -> safety::GraspTiming {
        safety::GraspTiming {
            grasp_window_s: self.grasp_window_s,
            settle_s: self.settle_s,
            expire_s: self.expire_s,
        }
    }
}

/// Operator socket settings.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct OperatorConfig {
    /// Unix socket path (default `/run/fri-service/operator.sock`, [`DEFAULT_SOCKET`]).
    pub socket: PathBuf,
    /// The stop socket: accepts only `stop`, with its own connections, so that no other client
    /// can occupy the stop path (default: beside `socket`, `.stop` before its extension, e.g.
    /// `/tmp/fri-service/operator.stop.sock`; same mode and peer-credential policy).
    pub stop_socket: Option<PathBuf>,
    /// User ids allowed to connect besides root and the service's own user (default none).
    pub allowed_uids: Vec<u32>,
    /// Group ids allowed to connect (default none).
    pub allowed_gids: Vec<u32>,
    /// User ids whose requests may forward a ROS 2 caller (the `ros2` field), besides the
    /// service's own user: the bridge's user when it runs as another (default none).
    pub ros2_bridge_uids: Vec<u32>,
    /// Longest accepted request line, bytes (default 65536).
    pub max_line_bytes: usize,
    /// Most simultaneous clients (default 64).
    pub max_clients: usize,
    /// A connection with no request in flight that sends nothing for this long is closed, s
    /// (default 30; 1 to 3600).
    pub idle_timeout_s: f64,
}

impl Default for OperatorConfig {
    fn default() -> Self {
        Self {
            socket: PathBuf::from(DEFAULT_SOCKET),
            stop_socket: None,
            allowed_uids: Vec::new(),
            allowed_gids: Vec::new(),
            ros2_bridge_uids: Vec::new(),
            max_line_bytes: 65536,
            max_clients: 64,
            idle_timeout_s: 30.0,
        }
    }
}

/// The state directory when systemd names none (no `StateDirectory=`).
pub const DEFAULT_STATE_DIR: &str = "/var/lib/fri-service";

/// The default state directory: systemd's `$STATE_DIRECTORY` (its first entry, when absolute)
/// when the service runs under `StateDirectory=`, else [`DEFAULT_STATE_DIR`].
pub fn default_state_dir() -> PathBuf {
    state_dir_from(std::env::var_os("STATE_DIRECTORY"))
}

/// [`default_state_dir`] for the value `env` of `STATE_DIRECTORY`.
fn state_dir_from(env: Option<std::ffi::OsString>) -> PathBuf {
    use std::os::unix::ffi::OsStrExt;
    env.and_then(|v| {
        // systemd joins several directories with `:`; the first is the service's own.
        let first = v.as_bytes().split(|b| *b == b':').next()?;
        let path = PathBuf::from(std::ffi::OsStr::from_bytes(first));
        path.is_absolute().then_some(path)
    })
    .unwrap_or_else(|| PathBuf::from(DEFAULT_STATE_DIR))
}

impl OperatorConfig {
    /// The stop socket's path: `stop_socket`, or beside `socket`.
    pub fn stop_socket_path(&self) -> PathBuf {
        self.stop_socket
            .clone()
            .unwrap_or_else(|| stop_socket_beside(&self.socket))
    }
}

/// Persistent state settings.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct StateConfig {
    /// Directory for applied payload, tare, calibration, monitor settings and the instance lock
    /// (default [`default_state_dir`]: `$STATE_DIRECTORY`, else `/var/lib/fri-service`). It and
    /// the recording directory must be owned by the service's user and writable by nobody else
    /// (docs/operator-protocol.md, "Files the service trusts").
    pub dir: PathBuf,
    /// The only directory `record` writes to (default: `recordings` inside `dir`); requests
    /// name a new file in it.
    pub record_dir: Option<PathBuf>,
}

impl Default for StateConfig {
    fn default() -> Self {
        Self {
            dir: default_state_dir(),
            record_dir: None,
        }
    }
}

impl StateConfig {
    /// The recording directory: `record_dir`, or `recordings` inside `dir`.
    pub fn record_dir(&self) -> PathBuf {
        self.record_dir
            .clone()
            .unwrap_or_else(|| self.dir.join("recordings"))
    }
}

/// iceoryx2 publication settings.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct IpcConfig {
    /// Publish at all (default true).
    pub enabled: bool,
    /// Prefix of the service names, e.g. `lwr` gives `lwr/state` (default `fri-service`).
    pub service_prefix: String,
    /// iceoryx2 global prefix isolating this installation's shared-memory files (default
    /// iceoryx2's own, `iox2_`).
    pub global_prefix: Option<String>,
}

impl Default for IpcConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            service_prefix: "fri-service".to_owned(),
            global_prefix: None,
        }
    }
}

mod per_joint;
mod validate;

pub use validate::MAX_ALLOWED_IDS;

#[cfg(test)]
mod tests;
