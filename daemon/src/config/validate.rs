//! Loading and validation: every key checked against its bound, errors naming the dotted key
//! and the allowed range.

use std::path::Path;

use fri_api::bounds::{self, Range};

use super::*;

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
        if let Some(path) = &self.robot.calibration {
            check(
                "robot.calibration",
                path.file_name().is_some() && !path.as_os_str().is_empty(),
                "must name a file (an identified-arm TOML file, `fri-ctl offline identify --out`)",
            )?;
        }
        let o = &self.observer;
        for j in 0..JOINTS {
            in_range_at("observer.gains", j, o.gains[j], bounds::gain(cycle))
                .map_err(|e| {
                    with_note(
                        e,
                        "the upper bound is 0.5 / fri.cycle_s: K_I·T ≤ 0.5 keeps the sampled observer a filter",
                    )
                })?;
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
        for j in 0..JOINTS {
            in_range_at(
                "observer.calibration_ceiling_nm",
                j,
                o.calibration_ceiling_nm[j],
                bounds::threshold(j),
            )
            .map_err(|e| with_note(e, "a ceiling within the thresholds' own range"))?;
        }
        in_range("reaction.pause_s", self.reaction.pause_s, bounds::PAUSE_S)?;
        let u = &self.unknown_payload;
        in_range(
            "unknown_payload.max_mass_kg",
            u.max_mass_kg,
            bounds::UNKNOWN_PAYLOAD_MASS,
        )?;
        in_range(
            "unknown_payload.max_radius_m",
            u.max_radius_m,
            bounds::UNKNOWN_PAYLOAD_RADIUS,
        )?;
        in_range(
            "unknown_payload.grasp_window_s",
            u.grasp_window_s,
            bounds::GRASP_WINDOW_S,
        )?;
        in_range("unknown_payload.settle_s", u.settle_s, bounds::SETTLE_S)?;
        in_range("unknown_payload.expire_s", u.expire_s, bounds::EXPIRE_S)?;
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
        if let Some(step) = e.pattern_step_deg {
            in_range("estimation.pattern_step_deg", step, bounds::STEP_DEG)?;
        }
        count_in_range("estimation.pattern_poses", e.pattern_poses, bounds::POSES)?;
        in_range(
            "estimation.drift_rate",
            e.drift_rate,
            Range::new(0.0, 0.1, "Nm/√s"),
        )?;
        in_range(
            "estimation.drift_prior_weight",
            e.drift_prior_weight,
            Range::new(0.0, 1000.0, "increments"),
        )?;
        in_range(
            "estimation.untared_offset_std",
            e.untared_offset_std,
            Range::new(1e-3, 5.0, "Nm"),
        )?;
        in_range(
            "estimation.max_com_distance_m",
            e.max_com_distance_m,
            Range::new(0.01, 1.0, "m"),
        )?;
        in_range(
            "estimation.max_mass_std_kg",
            e.max_mass_std_kg,
            Range::new(0.001, 5.0, "kg"),
        )?;
        in_range(
            "estimation.max_com_std_m",
            e.max_com_std_m,
            Range::new(0.001, 1.0, "m"),
        )?;
        in_range(
            "estimation.controller_model_mass_std_kg",
            e.controller_model_mass_std_kg,
            Range::new(0.0, 1.0, "kg"),
        )?;
        check(
            "operator.socket",
            !self.operator.socket.as_os_str().is_empty(),
            "must not be empty",
        )?;
        let op = &self.operator;
        check(
            "operator.stop_socket",
            op.stop_socket
                .as_ref()
                .is_none_or(|p| !p.as_os_str().is_empty()),
            "must not be empty",
        )?;
        check(
            "operator.stop_socket",
            op.stop_socket_path() != op.socket,
            "must differ from operator.socket",
        )?;
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
        count_in_range("operator.ros2_bridge_uids", op.ros2_bridge_uids.len(), ids)?;
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
        if let Some(v) = self.ros2.as_ref().and_then(|t| t.get(ROS2_UNAUTHENTICATED)) {
            check(
                "ros2.allow_unauthenticated_commands",
                v.is_bool(),
                "must be true or false",
            )?;
        }
        Ok(())
    }

    /// `[ros2] allow_unauthenticated_commands` (default false): the bridge forwards commands of
    /// participants DDS Security did not authenticate, and the service accepts them.
    pub fn ros2_unauthenticated_commands(&self) -> bool {
        self.ros2
            .as_ref()
            .and_then(|t| t.get(ROS2_UNAUTHENTICATED))
            .and_then(toml::Value::as_bool)
            .unwrap_or(false)
    }
}

/// The one `[ros2]` key the service reads itself.
const ROS2_UNAUTHENTICATED: &str = "allow_unauthenticated_commands";

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
        .map_err(|e| invalid(key.to_owned(), reason(&e.to_string())))
}

fn in_range_at(key: &str, index: usize, value: f64, range: Range) -> Result<(), ConfigError> {
    range
        .check("", value)
        .map_err(|e| invalid(key_at(key, index), reason(&e.to_string())))
}

fn count_in_range(key: &str, value: usize, range: Range) -> Result<(), ConfigError> {
    range
        .check_count("", value as u64)
        .map_err(|e| invalid(key.to_owned(), reason(&e.to_string())))
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
