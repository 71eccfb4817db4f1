//! Service configuration: the TOML file given to `fri-service run --config FILE.toml`.
//!
//! Every section and key is optional and falls back to the documented default; unknown keys are
//! rejected (serde `deny_unknown_fields`), and [`Config::validate`] rejects bad values with the
//! key's dotted name and the reason, so a typo never silently runs the robot with defaults.
//! The commented example lives at `config/fri-service.example.toml`.

use std::net::{IpAddr, SocketAddr};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// Number of joints of the supported arm (KUKA LWR 4+).
pub const JOINTS: usize = 7;

/// Default operator socket path, shared by `fri-service` and `fri-ctl --socket`.
pub const DEFAULT_SOCKET: &str = "/tmp/fri-service/operator.sock";

/// Errors while loading or validating the configuration.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file could not be read.
    #[error("cannot read config file {path}: {source}")]
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
    pub observer: ObserverConfig,
    /// What the service does when a collision is detected.
    pub reaction: ReactionConfig,
    /// Limits for moves the service commands itself (estimation poses, returns).
    pub motion: MotionConfig,
    /// Static-sample settling detection and averaging for `sample`, `tare`, `estimate-payload`.
    pub estimation: EstimationConfig,
    /// Operator socket.
    pub operator: OperatorConfig,
    /// Persistent state (applied payload, tare, calibration).
    pub state: StateConfig,
    /// iceoryx2 publication.
    pub iceoryx2: IpcConfig,
}

/// FRI UDP endpoint settings.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct FriConfig {
    /// Local address and UDP port the service listens on (default 0.0.0.0:49938).
    pub bind: SocketAddr,
    /// Only accept datagrams from this controller IP address (default: any).
    pub controller: Option<IpAddr>,
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
}

impl Default for RobotConfig {
    fn default() -> Self {
        Self {
            model: "lwr4".to_owned(),
        }
    }
}

/// Collision observer (momentum residual, paper eq. 48) settings.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ObserverConfig {
    /// Observer gains K_I per joint, 1/s (default `safety::DEFAULT_GAIN` = 400 on every joint).
    pub gains: [f64; JOINTS],
    /// Detection thresholds per joint, Nm (default 6, as in the paper's Fig. 6).
    pub thresholds: [f64; JOINTS],
    /// Whether the collision monitor is armed at start (default true).
    pub armed: bool,
}

impl Default for ObserverConfig {
    fn default() -> Self {
        Self {
            gains: [safety::DEFAULT_GAIN; JOINTS],
            thresholds: [6.0; JOINTS],
            armed: true,
        }
    }
}

/// Reaction to a detected collision.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum ReactionPolicy {
    /// Only report the event.
    Report,
    /// Stop (hold position) and wait for the operator's `resume`.
    Stop,
    /// Stop, wait `pause_s`, then resume automatically (the paper: 2 s).
    Pause,
}

/// What the service does on a collision.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ReactionConfig {
    /// Reaction policy (default `stop`).
    pub policy: ReactionPolicy,
    /// Pause duration for the `pause` policy, s (default 2).
    pub pause_s: f64,
}

impl Default for ReactionConfig {
    fn default() -> Self {
        Self {
            policy: ReactionPolicy::Stop,
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
}

impl Default for MotionConfig {
    fn default() -> Self {
        Self {
            max_velocity: [0.18; JOINTS],
            max_acceleration: [1.0; JOINTS],
            max_jerk: [5.0; JOINTS],
        }
    }
}

/// Settling detection and averaging of static samples.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct EstimationConfig {
    /// Settled when every joint speed stays below this, rad/s (default 0.002).
    pub settle_velocity: f64,
    /// Settled when the torque standard deviation of every joint over the settle window is below
    /// this, Nm (default 0.15).
    pub settle_torque_std: f64,
    /// Window over which settling is judged, s (default 0.1).
    pub settle_window_s: f64,
    /// Upper bound of the wait for settling after a move, s (default 1, the paper's wait).
    pub settle_timeout_s: f64,
    /// Averaging window of one static sample, s (default 0.5).
    pub average_s: f64,
    /// Increment of the paper's pose pattern, degrees (default 7).
    pub pattern_step_deg: f64,
    /// Number of poses of the pattern (default 10, as in the paper's Sec. VI-A).
    pub pattern_poses: usize,
}

impl Default for EstimationConfig {
    fn default() -> Self {
        Self {
            settle_velocity: 0.002,
            settle_torque_std: 0.15,
            settle_window_s: 0.1,
            settle_timeout_s: 1.0,
            average_s: 0.5,
            pattern_step_deg: 7.0,
            pattern_poses: 10,
        }
    }
}

/// Operator socket settings.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct OperatorConfig {
    /// Unix socket path (default `/tmp/fri-service/operator.sock`).
    pub socket: PathBuf,
    /// User ids allowed to connect besides root and the service's own user (default none).
    pub allowed_uids: Vec<u32>,
    /// Group ids allowed to connect (default none).
    pub allowed_gids: Vec<u32>,
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
            allowed_uids: Vec::new(),
            allowed_gids: Vec::new(),
            max_line_bytes: 65536,
            max_clients: 64,
            idle_timeout_s: 30.0,
        }
    }
}

/// Persistent state settings.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct StateConfig {
    /// Directory for applied payload, tare and calibration (default `/tmp/fri-service/state`).
    pub dir: PathBuf,
    /// The only directory `record` writes to (default: `recordings` inside `dir`); requests
    /// name a new file in it.
    pub record_dir: Option<PathBuf>,
}

impl Default for StateConfig {
    fn default() -> Self {
        Self {
            dir: PathBuf::from("/tmp/fri-service/state"),
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

impl Config {
    /// Reads, parses and validates a TOML configuration file.
    pub fn load(path: &Path) -> Result<Self, ConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            path: path.to_owned(),
            source,
        })?;
        Self::from_toml(&text).map_err(|e| match e {
            ConfigError::Parse { message, .. } => ConfigError::Parse {
                path: path.to_owned(),
                message,
            },
            other => other,
        })
    }

    /// Parses and validates configuration text (the path in errors is empty).
    pub fn from_toml(text: &str) -> Result<Self, ConfigError> {
        let config: Config = toml::from_str(text).map_err(|e| ConfigError::Parse {
            path: PathBuf::new(),
            message: e.to_string(),
        })?;
        config.validate()?;
        Ok(config)
    }

    /// Checks every value's range; the error names the first bad key and why.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let c = &self.fri.cycle_s;
        check(
            "fri.cycle_s",
            c.is_finite() && (0.001..=0.1).contains(c),
            "must be between 0.001 and 0.1 s",
        )?;
        check(
            "robot.model",
            self.robot.model == "lwr4",
            "only the built-in `lwr4` model is supported by the service",
        )?;
        positive_all("observer.gains", &self.observer.gains)?;
        positive_all("observer.thresholds", &self.observer.thresholds)?;
        let p = self.reaction.pause_s;
        check(
            "reaction.pause_s",
            p.is_finite() && (0.0..=60.0).contains(&p),
            "must be between 0 and 60 s",
        )?;
        positive_all("motion.max_velocity", &self.motion.max_velocity)?;
        positive_all("motion.max_acceleration", &self.motion.max_acceleration)?;
        positive_all("motion.max_jerk", &self.motion.max_jerk)?;
        // The LWR's slowest joint limit is 1.92 rad/s; the controller treats a larger step per
        // cycle as a set-point jump.
        let s = self.fri.max_joint_step;
        check(
            "fri.max_joint_step",
            s.is_finite() && s > 0.0 && s <= 1.5 * self.fri.cycle_s,
            "must be in (0, 1.5 rad/s × fri.cycle_s]",
        )?;
        for (i, v) in self.motion.max_velocity.iter().enumerate() {
            check_at(
                "motion.max_velocity",
                i,
                *v * self.fri.cycle_s <= s * (1.0 + 1e-9),
                "times fri.cycle_s must not exceed fri.max_joint_step (the set-point step limit)",
            )?;
        }
        let e = &self.estimation;
        positive("estimation.settle_velocity", e.settle_velocity)?;
        positive("estimation.settle_torque_std", e.settle_torque_std)?;
        positive("estimation.settle_window_s", e.settle_window_s)?;
        positive("estimation.settle_timeout_s", e.settle_timeout_s)?;
        check(
            "estimation.settle_window_s",
            e.settle_window_s <= e.settle_timeout_s,
            "must not exceed estimation.settle_timeout_s",
        )?;
        positive("estimation.average_s", e.average_s)?;
        check(
            "estimation.pattern_step_deg",
            e.pattern_step_deg.is_finite()
                && e.pattern_step_deg > 0.0
                && e.pattern_step_deg <= 30.0,
            "must be in (0, 30] degrees",
        )?;
        check(
            "estimation.pattern_poses",
            (2..=100).contains(&e.pattern_poses),
            "must be between 2 and 100",
        )?;
        check(
            "operator.socket",
            !self.operator.socket.as_os_str().is_empty(),
            "must not be empty",
        )?;
        check(
            "operator.max_line_bytes",
            (256..=16 * 1024 * 1024).contains(&self.operator.max_line_bytes),
            "must be between 256 and 16777216 bytes",
        )?;
        check(
            "operator.max_clients",
            (1..=4096).contains(&self.operator.max_clients),
            "must be between 1 and 4096",
        )?;
        let idle = self.operator.idle_timeout_s;
        check(
            "operator.idle_timeout_s",
            idle.is_finite() && (1.0..=3600.0).contains(&idle),
            "must be between 1 and 3600 s",
        )?;
        check(
            "state.dir",
            !self.state.dir.as_os_str().is_empty(),
            "must not be empty",
        )?;
        check(
            "state.record_dir",
            self.state
                .record_dir
                .as_ref()
                .is_none_or(|d| !d.as_os_str().is_empty()),
            "must not be empty (leave it out for `recordings` inside state.dir)",
        )?;
        check(
            "iceoryx2.service_prefix",
            !self.iceoryx2.service_prefix.is_empty()
                && self.iceoryx2.service_prefix.len() <= 64
                && self
                    .iceoryx2
                    .service_prefix
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || "-_/".contains(c)),
            "must be 1-64 characters of [A-Za-z0-9-_/]",
        )?;
        if let Some(prefix) = &self.iceoryx2.global_prefix {
            check(
                "iceoryx2.global_prefix",
                !prefix.is_empty()
                    && prefix.len() <= 32
                    && prefix
                        .chars()
                        .all(|c| c.is_ascii_alphanumeric() || c == '_'),
                "must be 1-32 characters of [A-Za-z0-9_]",
            )?;
        }
        Ok(())
    }
}

fn check(key: &str, ok: bool, reason: &str) -> Result<(), ConfigError> {
    if ok {
        Ok(())
    } else {
        Err(ConfigError::Invalid {
            key: key.to_owned(),
            reason: reason.to_owned(),
        })
    }
}

fn check_at(key: &str, index: usize, ok: bool, reason: &str) -> Result<(), ConfigError> {
    // Joints are numbered 1..n for people.
    check(
        &format!("{key}[{}] (joint {})", index, index + 1),
        ok,
        reason,
    )
}

fn positive(key: &str, value: f64) -> Result<(), ConfigError> {
    check(
        key,
        value.is_finite() && value > 0.0,
        "must be a positive finite number",
    )
}

fn positive_all(key: &str, values: &[f64]) -> Result<(), ConfigError> {
    for (i, v) in values.iter().enumerate() {
        check_at(
            key,
            i,
            v.is_finite() && *v > 0.0,
            "must be a positive finite number",
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn invalid_key(text: &str) -> String {
        match Config::from_toml(text) {
            Err(ConfigError::Invalid { key, .. }) => key,
            other => panic!("expected Invalid, got {other:?}"),
        }
    }

    #[test]
    fn empty_file_gives_documented_defaults() {
        let c = Config::from_toml("").unwrap();
        assert_eq!(c.fri.bind, "0.0.0.0:49938".parse().unwrap());
        assert_eq!(c.fri.cycle_s, 0.001);
        assert_eq!(c.observer.thresholds, [6.0; 7]);
        assert_eq!(c.reaction.policy, ReactionPolicy::Stop);
        assert_eq!(c.estimation.settle_timeout_s, 1.0);
        assert_eq!(c.operator.socket, PathBuf::from(DEFAULT_SOCKET));
        assert_eq!(
            c.state.record_dir(),
            PathBuf::from("/tmp/fri-service/state/recordings")
        );
        let c = Config::from_toml("[state]\ndir = \"/var/lib/fri\"\n").unwrap();
        assert_eq!(
            c.state.record_dir(),
            PathBuf::from("/var/lib/fri/recordings")
        );
        let c = Config::from_toml("[state]\nrecord_dir = \"/data/rec\"\n").unwrap();
        assert_eq!(c.state.record_dir(), PathBuf::from("/data/rec"));
    }

    #[test]
    fn example_file_parses_and_matches_defaults() {
        let text = include_str!("../config/fri-service.example.toml");
        let c = Config::from_toml(text).unwrap();
        assert_eq!(c, Config::default());
    }

    #[test]
    fn unknown_key_is_rejected_with_its_name() {
        let err = Config::from_toml("[fri]\nbnid = \"0.0.0.0:1\"\n").unwrap_err();
        let text = err.to_string();
        assert!(text.contains("bnid"), "{text}");
    }

    #[test]
    fn unknown_section_is_rejected() {
        assert!(matches!(
            Config::from_toml("[fri2]\n"),
            Err(ConfigError::Parse { .. })
        ));
    }

    #[test]
    fn bad_values_name_the_key() {
        assert_eq!(invalid_key("[fri]\ncycle_s = 0.5\n"), "fri.cycle_s");
        assert_eq!(invalid_key("[robot]\nmodel = \"puma\"\n"), "robot.model");
        assert_eq!(
            invalid_key("[motion]\nmax_jerk = [5.0, 5.0, -1.0, 5.0, 5.0, 5.0, 5.0]\n"),
            "motion.max_jerk[2] (joint 3)"
        );
        assert_eq!(
            invalid_key("[motion]\nmax_velocity = [0.5, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1]\n"),
            "motion.max_velocity[0] (joint 1)"
        );
        assert_eq!(
            invalid_key("[estimation]\nsettle_window_s = 2.0\n"),
            "estimation.settle_window_s"
        );
        assert_eq!(
            invalid_key("[operator]\nmax_line_bytes = 10\n"),
            "operator.max_line_bytes"
        );
        assert_eq!(
            invalid_key("[state]\nrecord_dir = \"\"\n"),
            "state.record_dir"
        );
        assert_eq!(
            invalid_key("[operator]\nidle_timeout_s = 0.5\n"),
            "operator.idle_timeout_s"
        );
        assert_eq!(
            invalid_key("[operator]\nidle_timeout_s = nan\n"),
            "operator.idle_timeout_s"
        );
        assert_eq!(
            invalid_key("[iceoryx2]\nglobal_prefix = \"a b\"\n"),
            "iceoryx2.global_prefix"
        );
    }

    #[test]
    fn wrong_length_array_is_a_parse_error() {
        let err = Config::from_toml("[observer]\ngains = [1.0, 2.0]\n").unwrap_err();
        assert!(matches!(err, ConfigError::Parse { .. }), "{err}");
    }

    #[test]
    fn missing_file_is_a_read_error() {
        let err = Config::load(Path::new("/nonexistent/fri.toml")).unwrap_err();
        assert!(matches!(err, ConfigError::Read { .. }));
    }
}
