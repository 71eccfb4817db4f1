//! Service configuration: the TOML file given to `fri-service run --config FILE.toml`.
//!
//! Every section and key is optional and falls back to the documented default; unknown keys are
//! rejected (serde `deny_unknown_fields`), and [`Config::validate`] rejects bad values with the
//! key's dotted name and the reason, so a typo never silently runs the robot with defaults.
//! The commented example lives at `daemon/config/fri-service.example.toml`.

use std::net::{IpAddr, SocketAddr};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use fri_api::bounds::{self, Range};
pub use fri_api::{DEFAULT_SOCKET, JOINTS};

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
    pub observer: ObserverSettings,
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
}

impl Default for RobotConfig {
    fn default() -> Self {
        Self {
            model: "lwr4".to_owned(),
        }
    }
}

/// The `[observer]` section: collision observer (momentum residual, paper eq. 48) gains,
/// thresholds and arming (the service's settings; `safety::ObserverConfig` is the observer's own).
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct ObserverSettings {
    /// Observer gains K_I per joint, 1/s (default `safety::DEFAULT_GAIN` = 400 on every joint).
    pub gains: [f64; JOINTS],
    /// Detection thresholds per joint, Nm (default 6, as in the paper's Fig. 6).
    pub thresholds: [f64; JOINTS],
    /// Whether the collision monitor is armed at start (default true).
    pub armed: bool,
}

impl Default for ObserverSettings {
    fn default() -> Self {
        Self {
            gains: [safety::DEFAULT_GAIN; JOINTS],
            thresholds: [6.0; JOINTS],
            armed: true,
        }
    }
}

/// `[reaction] policy`: what the service does on a detected collision (mapped onto
/// `safety::ReactionPolicy` by the service; `report` does not react).
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum ReactionMode {
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

    /// Checks every value's range; the error names the first bad key, its value and the range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let f = &self.fri;
        in_range("fri.cycle_s", f.cycle_s, bounds::CYCLE_S)?;
        let cycle = f.cycle_s;
        if let Some(port) = f.controller_port {
            check(
                "fri.controller_port",
                port != 0,
                "0 is not a port; must be 1…65535",
            )?;
        }
        // A resync shorter than a few cycles would take every lost datagram for a restart; a
        // longer one than 10 s leaves a restarted controller unanswered for too long.
        in_range(
            "fri.resync_after_s",
            f.resync_after_s,
            Range::new((10.0 * cycle).max(0.01), 10.0, "s"),
        )?;
        // The LWR's slowest joint limit is 1.92 rad/s; the controller treats a larger step per
        // cycle as a set-point jump.
        in_range(
            "fri.max_joint_step",
            f.max_joint_step,
            Range::new(1e-6, 1.5 * cycle, "rad"),
        )
        .map_err(|e| with_note(e, "the upper bound is 1.5 rad/s × fri.cycle_s"))?;
        check(
            "robot.model",
            self.robot.model == "lwr4",
            "only the built-in `lwr4` model is supported by the service",
        )?;
        let o = &self.observer;
        for j in 0..JOINTS {
            in_range_at("observer.gains", j, o.gains[j], bounds::gain(cycle))
                .map_err(|e| with_note(e, "the upper bound is 2 / fri.cycle_s"))?;
        }
        for j in 0..JOINTS {
            in_range_at(
                "observer.thresholds",
                j,
                o.thresholds[j],
                bounds::threshold(j),
            )
            .map_err(|e| {
                with_note(
                    e,
                    "the upper bound is a quarter of the joint's torque limit",
                )
            })?;
        }
        in_range(
            "reaction.pause_s",
            self.reaction.pause_s,
            Range::new(0.0, 60.0, "s"),
        )?;
        let m = &self.motion;
        for j in 0..JOINTS {
            // At most the joint's rated speed and the speed the set-point step limit allows.
            let top = bounds::rated_speed(j).min(f.max_joint_step / cycle * (1.0 + 1e-9));
            in_range_at(
                "motion.max_velocity",
                j,
                m.max_velocity[j],
                Range::new(0.01, top, "rad/s"),
            )
            .map_err(|e| {
                with_note(
                    e,
                    "the upper bound is the joint's rated speed and fri.max_joint_step / fri.cycle_s",
                )
            })?;
            in_range_at(
                "motion.max_acceleration",
                j,
                m.max_acceleration[j],
                Range::new(0.01, 10.0, "rad/s²"),
            )?;
            in_range_at(
                "motion.max_jerk",
                j,
                m.max_jerk[j],
                Range::new(0.1, 1000.0, "rad/s³"),
            )?;
        }
        in_range(
            "motion.max_around_distance_rad",
            m.max_around_distance_rad,
            bounds::MAX_AROUND_DISTANCE_RAD,
        )?;
        let e = &self.estimation;
        in_range(
            "estimation.settle_velocity",
            e.settle_velocity,
            Range::new(1e-4, 0.1, "rad/s"),
        )?;
        in_range(
            "estimation.settle_torque_std",
            e.settle_torque_std,
            Range::new(1e-3, 5.0, "Nm"),
        )?;
        in_range(
            "estimation.settle_timeout_s",
            e.settle_timeout_s,
            Range::new(0.01, 60.0, "s"),
        )?;
        in_range(
            "estimation.settle_window_s",
            e.settle_window_s,
            Range::new(cycle, e.settle_timeout_s.max(cycle), "s"),
        )
        .map_err(|err| with_note(err, "from fri.cycle_s up to estimation.settle_timeout_s"))?;
        in_range(
            "estimation.average_s",
            e.average_s,
            Range::new(cycle, 60.0, "s"),
        )?;
        in_range(
            "estimation.pattern_step_deg",
            e.pattern_step_deg,
            bounds::STEP_DEG,
        )?;
        count_in_range("estimation.pattern_poses", e.pattern_poses, bounds::POSES)?;
        check(
            "operator.socket",
            !self.operator.socket.as_os_str().is_empty(),
            "must not be empty",
        )?;
        let op = &self.operator;
        count_in_range(
            "operator.max_line_bytes",
            op.max_line_bytes,
            Range::new(256.0, 16.0 * 1024.0 * 1024.0, "bytes"),
        )?;
        count_in_range(
            "operator.max_clients",
            op.max_clients,
            Range::new(1.0, 4096.0, ""),
        )?;
        in_range(
            "operator.idle_timeout_s",
            op.idle_timeout_s,
            Range::new(1.0, 3600.0, "s"),
        )?;
        let ids = Range::new(0.0, MAX_ALLOWED_IDS as f64, "entries");
        count_in_range("operator.allowed_uids", op.allowed_uids.len(), ids)?;
        count_in_range("operator.allowed_gids", op.allowed_gids.len(), ids)?;
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

/// Most entries of `operator.allowed_uids` and `operator.allowed_gids` each.
pub const MAX_ALLOWED_IDS: usize = 256;

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

/// The key of element `index` of an array key: joints are numbered 1..n for people.
fn key_at(key: &str, index: usize) -> String {
    format!("{key}[{index}] (joint {})", index + 1)
}

fn invalid(key: String, reason: String) -> ConfigError {
    ConfigError::Invalid { key, reason }
}

/// `value` of `key` inside `range`; the reason reads "v unit is outside min…max unit".
fn in_range(key: &str, value: f64, range: Range) -> Result<(), ConfigError> {
    range
        .check("", value)
        .map_err(|e| invalid(key.to_owned(), reason(&e)))
}

fn in_range_at(key: &str, index: usize, value: f64, range: Range) -> Result<(), ConfigError> {
    range
        .check("", value)
        .map_err(|e| invalid(key_at(key, index), reason(&e)))
}

fn count_in_range(key: &str, value: usize, range: Range) -> Result<(), ConfigError> {
    range
        .check_count("", value as u64)
        .map_err(|e| invalid(key.to_owned(), reason(&e)))
}

/// `Range::check` with an empty name gives " = v is outside …"; the key is shown separately.
fn reason(message: &str) -> String {
    message.trim_start_matches(" = ").to_owned()
}

/// Appends why the range is what it is.
fn with_note(e: ConfigError, note: &str) -> ConfigError {
    match e {
        ConfigError::Invalid { key, reason } => ConfigError::Invalid {
            key,
            reason: format!("{reason} ({note})"),
        },
        other => other,
    }
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
        assert_eq!(c.reaction.policy, ReactionMode::Stop);
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

    fn invalid(text: &str) -> (String, String) {
        match Config::from_toml(text) {
            Err(ConfigError::Invalid { key, reason }) => (key, reason),
            other => panic!("expected Invalid for {text:?}, got {other:?}"),
        }
    }

    #[test]
    fn every_numeric_key_out_of_range_is_rejected_naming_the_key_and_range() {
        let seven = |v: &str| format!("[{v}, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]");
        let cases = [
            (
                "[fri]\ncycle_s = 1e300\n".to_owned(),
                "fri.cycle_s",
                "0.001…0.1 s",
            ),
            (
                "[fri]\ncontroller_port = 0\n".to_owned(),
                "fri.controller_port",
                "1…65535",
            ),
            (
                "[fri]\nresync_after_s = 0.001\n".to_owned(),
                "fri.resync_after_s",
                "0.01…10 s",
            ),
            (
                "[fri]\nmax_joint_step = 1e300\n".to_owned(),
                "fri.max_joint_step",
                "1e-6…0.0015 rad",
            ),
            (
                format!("[observer]\ngains = {}\n", seven("1e308")),
                "observer.gains[0] (joint 1)",
                "1e308 1/s is outside 1…2000 1/s",
            ),
            (
                "[observer]\nthresholds = [6.0, 6.0, 6.0, 1e300, 6.0, 6.0, 6.0]\n".to_owned(),
                "observer.thresholds[3] (joint 4)",
                "1e300 Nm is outside 0.1…25 Nm",
            ),
            (
                "[observer]\nthresholds = [6.0, 6.0, 6.0, 6.0, 6.0, 6.0, 0.05]\n".to_owned(),
                "observer.thresholds[6] (joint 7)",
                "0.05 Nm is outside 0.1…9.5 Nm",
            ),
            (
                "[reaction]\npause_s = 1e300\n".to_owned(),
                "reaction.pause_s",
                "0…60 s",
            ),
            (
                format!("[motion]\nmax_velocity = {}\n", seven("0.001")),
                "motion.max_velocity[0] (joint 1)",
                "0.001 rad/s is outside 0.01…0.2 rad/s",
            ),
            (
                format!("[motion]\nmax_acceleration = {}\n", seven("1e9")),
                "motion.max_acceleration[0] (joint 1)",
                "0.01…10 rad/s²",
            ),
            (
                format!("[motion]\nmax_jerk = {}\n", seven("1e9")),
                "motion.max_jerk[0] (joint 1)",
                "0.1…1000 rad/s³",
            ),
            (
                "[motion]\nmax_around_distance_rad = 1e300\n".to_owned(),
                "motion.max_around_distance_rad",
                "0.01…1 rad",
            ),
            (
                "[estimation]\nsettle_velocity = 1e300\n".to_owned(),
                "estimation.settle_velocity",
                "0.0001…0.1 rad/s",
            ),
            (
                "[estimation]\nsettle_torque_std = 1e300\n".to_owned(),
                "estimation.settle_torque_std",
                "0.001…5 Nm",
            ),
            (
                "[estimation]\nsettle_timeout_s = 1e300\n".to_owned(),
                "estimation.settle_timeout_s",
                "0.01…60 s",
            ),
            (
                "[estimation]\nsettle_window_s = 0.0\n".to_owned(),
                "estimation.settle_window_s",
                "0.001…1 s",
            ),
            (
                "[estimation]\naverage_s = 1e300\n".to_owned(),
                "estimation.average_s",
                "0.001…60 s",
            ),
            (
                "[estimation]\npattern_step_deg = 0.5\n".to_owned(),
                "estimation.pattern_step_deg",
                "1…30 deg",
            ),
            (
                "[estimation]\npattern_poses = 1000\n".to_owned(),
                "estimation.pattern_poses",
                "2…100",
            ),
            (
                "[operator]\nmax_line_bytes = 10\n".to_owned(),
                "operator.max_line_bytes",
                "256…16777216 bytes",
            ),
            (
                "[operator]\nmax_clients = 0\n".to_owned(),
                "operator.max_clients",
                "1…4096",
            ),
            (
                format!("[operator]\nallowed_uids = {:?}\n", vec![1000u32; 300]),
                "operator.allowed_uids",
                "0…256 entries",
            ),
            (
                format!("[operator]\nallowed_gids = {:?}\n", vec![1000u32; 300]),
                "operator.allowed_gids",
                "0…256 entries",
            ),
        ];
        for (text, key, range) in cases {
            let (k, reason) = invalid(&text);
            assert_eq!(k, key, "{text}");
            assert!(reason.contains(range), "{text}: {reason}");
            assert!(
                reason.contains("is outside") || key == "fri.controller_port",
                "{reason}"
            );
        }
    }

    #[test]
    fn ranges_follow_the_configured_cycle() {
        // At 10 ms the gain limit is 200 1/s and the resync floor 0.1 s.
        let (k, reason) = invalid(
            "[fri]\ncycle_s = 0.01\nmax_joint_step = 0.002\n[motion]\nmax_velocity = \
             [0.18, 0.18, 0.18, 0.18, 0.18, 0.18, 0.18]\n[observer]\ngains = \
             [400.0, 100.0, 100.0, 100.0, 100.0, 100.0, 100.0]\n",
        );
        assert_eq!(k, "observer.gains[0] (joint 1)");
        assert!(reason.contains("1…200 1/s"), "{reason}");
        let (k, _) =
            invalid("[fri]\ncycle_s = 0.01\nmax_joint_step = 0.002\nresync_after_s = 0.05\n");
        assert_eq!(k, "fri.resync_after_s");
        let ok = Config::from_toml(
            "[fri]\ncontroller_port = 49938\nresync_after_s = 0.1\n[motion]\nmax_around_distance_rad = 0.2\n",
        )
        .unwrap();
        assert_eq!(ok.fri.controller_port, Some(49938));
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
