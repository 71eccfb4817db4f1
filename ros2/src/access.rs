//! Who may command the arm through the bridge: the commands enabled by name in `[ros2]` (none by
//! default: the bridge is read-only), the extra enablements that disarming, `resume` and moving
//! the arm need, and what authenticates the callers (a DDS Security enclave of the SROS2 keystore
//! layout, or the explicit `allow_unauthenticated_commands`).

use std::os::unix::fs::MetadataExt as _;
use std::path::{Path, PathBuf};

use fri_service::config::ConfigError;
use serde::{Deserialize, Serialize};

/// Longest request age the bridge accepts, s (`ros2.request_max_age_s` upper bound).
pub const MAX_REQUEST_AGE_S: (f64, f64) = (0.1, 60.0);
/// Range of `ros2.max_requests_in_flight`.
pub const MAX_IN_FLIGHT: (usize, usize) = (1, 64);

/// A command the bridge can serve, named as its ROS 2 service or topic (`<ns>/<name>`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CommandName {
    /// `<ns>/stop` (`std_srvs/Trigger`): hold the arm.
    Stop,
    /// `<ns>/expect_payload` (`std_srvs/Trigger`): the unknown-payload mode.
    ExpectPayload,
    /// `<ns>/collision_arm` (`std_srvs/SetBool`): arming; disarming also needs
    /// `ros2.allow_disarm`.
    CollisionArm,
    /// `<ns>/apply_payload` (`geometry_msgs/Inertia` subscription).
    ApplyPayload,
    /// `<ns>/resume` (`std_srvs/Trigger`): needs `ros2.allow_resume`.
    Resume,
    /// `<ns>/tare` (`std_srvs/Trigger`): moves the arm, needs `ros2.allow_motion`.
    Tare,
    /// `<ns>/estimate_payload` (`std_srvs/Trigger`): moves the arm, needs `ros2.allow_motion`.
    EstimatePayload,
}

impl CommandName {
    /// Every command, in the order the docs list them.
    pub const ALL: [CommandName; 7] = [
        Self::Stop,
        Self::ExpectPayload,
        Self::CollisionArm,
        Self::ApplyPayload,
        Self::Resume,
        Self::Tare,
        Self::EstimatePayload,
    ];

    /// The ROS 2 name (in the bridge's namespace) and the `ros2.commands` value.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Stop => "stop",
            Self::ExpectPayload => "expect_payload",
            Self::CollisionArm => "collision_arm",
            Self::ApplyPayload => "apply_payload",
            Self::Resume => "resume",
            Self::Tare => "tare",
            Self::EstimatePayload => "estimate_payload",
        }
    }

    /// The `ros2.allow_*` key the command needs besides its name in `ros2.commands`.
    pub fn extra_key(self) -> Option<&'static str> {
        match self {
            Self::Resume => Some("ros2.allow_resume"),
            Self::Tare | Self::EstimatePayload => Some("ros2.allow_motion"),
            _ => None,
        }
    }
}

/// The six files of an SROS2 enclave (`ros2 security create_enclave`, `tools/sros2_keystore.sh`).
pub const ENCLAVE_FILES: [&str; 6] = [
    "identity_ca.cert.pem",
    "cert.pem",
    "key.pem",
    "permissions_ca.cert.pem",
    "governance.p7s",
    "permissions.p7s",
];

/// How callers are authenticated.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Authentication {
    /// DDS Security with the enclave in this directory: only participants the keystore's
    /// identity CA certified, with permissions its permissions CA signed, reach the bridge.
    Enclave(PathBuf),
    /// No DDS Security: any participant on the domain may call the enabled commands
    /// (`ros2.allow_unauthenticated_commands = true`).
    Unauthenticated,
    /// No DDS Security and no command enabled (the default).
    ReadOnly,
}

/// The validated access settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Access {
    /// The enabled commands, in [`CommandName::ALL`] order.
    pub commands: Vec<CommandName>,
    /// `collision_arm` with `false` disarms (`ros2.allow_disarm`).
    pub allow_disarm: bool,
    /// How callers are authenticated.
    pub authentication: Authentication,
    /// Requests older than this (source timestamp against the bridge's clock) are ignored, s.
    pub max_age_s: f64,
    /// Commands in flight toward the service at once (a separate, equal budget for `stop`).
    pub max_in_flight: usize,
}

impl Access {
    /// Whether `command` is served.
    pub fn enabled(&self, command: CommandName) -> bool {
        self.commands.contains(&command)
    }

    /// Whether callers are not authenticated while commands are served.
    pub fn unauthenticated(&self) -> bool {
        self.authentication == Authentication::Unauthenticated
    }
}

/// The `[ros2]` keys this module reads, as written.
#[derive(Debug, Clone, Copy)]
pub struct AccessKeys<'a> {
    /// `ros2.commands`.
    pub commands: &'a [String],
    /// `ros2.allow_disarm`.
    pub allow_disarm: bool,
    /// `ros2.allow_resume`.
    pub allow_resume: bool,
    /// `ros2.allow_motion`.
    pub allow_motion: bool,
    /// `ros2.security_enclave`.
    pub security_enclave: Option<&'a Path>,
    /// `ros2.allow_unauthenticated_commands`.
    pub allow_unauthenticated_commands: bool,
    /// `ros2.request_max_age_s`.
    pub request_max_age_s: f64,
    /// `ros2.max_requests_in_flight`.
    pub max_requests_in_flight: usize,
}

fn invalid(key: &str, reason: String) -> ConfigError {
    ConfigError::Invalid {
        key: key.to_owned(),
        reason,
    }
}

fn allowed_values() -> String {
    CommandName::ALL
        .iter()
        .map(|c| format!("\"{}\"", c.as_str()))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Validates the access keys: known, unique command names; each extra enablement with its
/// command; commands only with an enclave or the explicit unauthenticated mode; bounds.
pub fn validate(keys: AccessKeys<'_>) -> Result<Access, ConfigError> {
    let mut commands = Vec::new();
    for name in keys.commands {
        let Some(c) = CommandName::ALL.into_iter().find(|c| c.as_str() == name) else {
            return Err(invalid(
                "ros2.commands",
                format!("unknown command `{name}`: allowed are {}", allowed_values()),
            ));
        };
        if commands.contains(&c) {
            return Err(invalid("ros2.commands", format!("`{name}` appears twice")));
        }
        commands.push(c);
    }
    commands.sort();
    for c in &commands {
        let granted = match c {
            CommandName::Resume => keys.allow_resume,
            CommandName::Tare | CommandName::EstimatePayload => keys.allow_motion,
            _ => true,
        };
        if let (Some(key), false) = (c.extra_key(), granted) {
            return Err(invalid(
                "ros2.commands",
                format!(
                    "`{}` needs `{key} = true` as well (it {})",
                    c.as_str(),
                    if *c == CommandName::Resume {
                        "releases a stop"
                    } else {
                        "moves the arm"
                    }
                ),
            ));
        }
    }
    let needs = |flag: bool, key: &str, command: CommandName| {
        if flag && !commands.contains(&command) {
            Err(invalid(
                key,
                format!(
                    "has no effect without \"{}\" in ros2.commands",
                    command.as_str()
                ),
            ))
        } else {
            Ok(())
        }
    };
    needs(
        keys.allow_disarm,
        "ros2.allow_disarm",
        CommandName::CollisionArm,
    )?;
    needs(keys.allow_resume, "ros2.allow_resume", CommandName::Resume)?;
    if keys.allow_motion
        && !commands
            .iter()
            .any(|c| matches!(c, CommandName::Tare | CommandName::EstimatePayload))
    {
        return Err(invalid(
            "ros2.allow_motion",
            "has no effect without \"tare\" or \"estimate_payload\" in ros2.commands".into(),
        ));
    }
    let authentication = match (keys.security_enclave, keys.allow_unauthenticated_commands) {
        (Some(_), true) => {
            return Err(invalid(
                "ros2.allow_unauthenticated_commands",
                "cannot be combined with ros2.security_enclave: set one of them".into(),
            ));
        }
        (Some(dir), false) => {
            check_enclave(dir).map_err(|r| invalid("ros2.security_enclave", r))?;
            Authentication::Enclave(dir.to_owned())
        }
        (None, true) if commands.is_empty() => {
            return Err(invalid(
                "ros2.allow_unauthenticated_commands",
                "has no effect: ros2.commands is empty (the bridge is read-only)".into(),
            ));
        }
        (None, true) => Authentication::Unauthenticated,
        (None, false) if commands.is_empty() => Authentication::ReadOnly,
        (None, false) => {
            return Err(invalid(
                "ros2.commands",
                "commands need DDS Security: set ros2.security_enclave to an SROS2 enclave \
                 (tools/sros2_keystore.sh), or accept commands from ANY participant on the \
                 domain with ros2.allow_unauthenticated_commands = true"
                    .into(),
            ));
        }
    };
    let (lo, hi) = MAX_REQUEST_AGE_S;
    if !(lo..=hi).contains(&keys.request_max_age_s) {
        return Err(invalid(
            "ros2.request_max_age_s",
            format!("{} is out of range {lo}..={hi} s", keys.request_max_age_s),
        ));
    }
    let (lo, hi) = MAX_IN_FLIGHT;
    if !(lo..=hi).contains(&keys.max_requests_in_flight) {
        return Err(invalid(
            "ros2.max_requests_in_flight",
            format!(
                "{} is out of range {lo}..={hi}",
                keys.max_requests_in_flight
            ),
        ));
    }
    Ok(Access {
        commands,
        allow_disarm: keys.allow_disarm,
        authentication,
        max_age_s: keys.request_max_age_s,
        max_in_flight: keys.max_requests_in_flight,
    })
}

/// Checks an enclave directory as sshd's StrictModes would: a directory owned by this process's
/// user, writable by nobody else, holding the six files (each, after links, a regular file owned
/// by this user or root and writable by nobody else; the private key readable by nobody else).
pub fn check_enclave(dir: &Path) -> Result<(), String> {
    // SAFETY: geteuid has no preconditions and cannot fail.
    let uid = unsafe { libc::geteuid() };
    let meta = std::fs::metadata(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    if !meta.is_dir() {
        return Err(format!("{} is not a directory", dir.display()));
    }
    let owned = |m: &std::fs::Metadata| m.uid() == uid || m.uid() == 0;
    if meta.uid() != uid {
        return Err(format!(
            "{} is owned by uid {}, not by this service's user (uid {uid})",
            dir.display(),
            meta.uid()
        ));
    }
    if meta.mode() & 0o022 != 0 {
        return Err(format!(
            "{} is writable by group or others (mode {:o}): chmod go-w",
            dir.display(),
            meta.mode() & 0o777
        ));
    }
    for name in ENCLAVE_FILES {
        let path = dir.join(name);
        let m = std::fs::metadata(&path).map_err(|e| {
            format!(
                "{}: {e} (an enclave holds {})",
                path.display(),
                ENCLAVE_FILES.join(", ")
            )
        })?;
        if !m.is_file() {
            return Err(format!("{} is not a regular file", path.display()));
        }
        if !owned(&m) {
            return Err(format!(
                "{} is owned by uid {}, not by this service's user (uid {uid}) or root",
                path.display(),
                m.uid()
            ));
        }
        if m.mode() & 0o022 != 0 {
            return Err(format!(
                "{} is writable by group or others (mode {:o})",
                path.display(),
                m.mode() & 0o777
            ));
        }
        if name == "key.pem" && m.mode() & 0o077 != 0 {
            return Err(format!(
                "{} (the private key) is readable by group or others (mode {:o}): chmod 600",
                path.display(),
                m.mode() & 0o777
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
