//! The bridge's configuration: the service's own TOML file (socket path, iceoryx2 names, cycle
//! time; read and validated by `fri_service::config`) and its `[ros2]` table, which the service
//! accepts without reading it.

use std::net::IpAddr;
use std::path::{Path, PathBuf};

use fri_service::config::{Config as ServiceConfig, ConfigError};
use serde::{Deserialize, Serialize};

use crate::access::{Access, AccessKeys};
use crate::description::RobotDescription;

/// The joints of the LWR 4+.
pub const JOINTS: usize = fri_api::JOINTS;
/// Largest DDS domain id ROS 2 allows (UDP ports of higher ids overflow, REP 2004 / rmw docs).
pub const MAX_DOMAIN_ID: u16 = 232;
/// Longest namespace, characters.
pub const MAX_NAMESPACE_LEN: usize = fri_ros_msgs::names::MAX_NAMESPACE_LEN;
/// Longest joint name, characters.
pub const MAX_JOINT_NAME_LEN: usize = 64;
/// Highest joint-state rate, Hz (every cycle at 1 ms).
pub const MAX_JOINT_STATES_HZ: u32 = 1000;
/// Range of the diagnostics rate, Hz.
pub const DIAGNOSTICS_HZ: (f64, f64) = (0.1, 10.0);

/// Errors loading the bridge's configuration: the service's own [`ConfigError`] (the file
/// cannot be read, is not TOML or has unknown keys, or a value is out of range); the `[ros2]`
/// keys fail with the same variants, naming the dotted key (`ros2.domain_id`).
pub type BridgeConfigError = ConfigError;

/// How ROS 2 services map onto DDS topics (must match the peer's middleware).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ServiceMappingKind {
    /// RPC over DDS "enhanced" mapping: rmw_fastrtps (the ROS 2 default) and rmw_connextdds.
    Enhanced,
    /// The mapping of rmw_cyclonedds.
    Cyclone,
    /// RPC over DDS "basic" mapping.
    Basic,
}

/// The `[ros2]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Ros2Config {
    /// Namespace of the bridge's own topics and services (default `/lwr`): `/`-separated
    /// segments of letters, digits and `_`, not starting with a digit.
    pub namespace: String,
    /// DDS domain id, 0 to 232 (default 0, as `ROS_DOMAIN_ID`).
    pub domain_id: u16,
    /// Rate of `/joint_states`, `<ns>/external_torque` and `<ns>/controller_gravity`, Hz
    /// (default 250; 1 to 1000, dividing the controller rate 1 / `fri.cycle_s`).
    pub joint_states_hz: u32,
    /// Rate of the diagnostics, Hz (default 1; 0.1 to 10).
    pub diagnostics_hz: f64,
    /// Joint names, joint 1 first (default: the revolute joints of the robot description).
    pub joint_names: Option<Vec<String>>,
    /// Network interface for DDS: an interface name (`eth0`, `lo`) or one of its IP addresses
    /// (default: every interface).
    pub interface: Option<String>,
    /// Service mapping of the peers' middleware (default `enhanced`).
    pub service_mapping: ServiceMappingKind,
    /// URDF published on `/robot_description` (default: the built-in LWR 4+ model).
    pub robot_description: Option<PathBuf>,
    /// Frame of the payload's centre of mass on `<ns>/payload` (default `lwr_dh_frame_7`, the
    /// paper's frame 7, which the built-in description adds to the model).
    pub payload_frame: String,
    /// Commands served, by name (default none: the bridge is read-only); see
    /// [`crate::access::CommandName`].
    pub commands: Vec<String>,
    /// `collision_arm` with `false` may disarm the monitor (default false: it only arms).
    pub allow_disarm: bool,
    /// `resume` may be enabled (default false).
    pub allow_resume: bool,
    /// `tare` and `estimate_payload`, which move the arm, may be enabled (default false).
    pub allow_motion: bool,
    /// SROS2 enclave directory (six files) for DDS Security (default none).
    pub security_enclave: Option<PathBuf>,
    /// Serve the enabled commands to ANY participant on the domain, without DDS Security
    /// (default false).
    pub allow_unauthenticated_commands: bool,
    /// Requests older than this are ignored, s (default 5; 0.1 to 60).
    pub request_max_age_s: f64,
    /// Commands in flight toward the service at once, and again for `stop` (default 8; 1 to 64).
    pub max_requests_in_flight: usize,
}

impl Default for Ros2Config {
    fn default() -> Self {
        Self {
            namespace: "/lwr".to_owned(),
            domain_id: 0,
            joint_states_hz: 250,
            diagnostics_hz: 1.0,
            joint_names: None,
            interface: None,
            service_mapping: ServiceMappingKind::Enhanced,
            robot_description: None,
            payload_frame: crate::description::DH_FRAME_7.to_owned(),
            commands: Vec::new(),
            allow_disarm: false,
            allow_resume: false,
            allow_motion: false,
            security_enclave: None,
            allow_unauthenticated_commands: false,
            request_max_age_s: 5.0,
            max_requests_in_flight: 8,
        }
    }
}

/// Everything the bridge runs with, validated.
#[derive(Debug, Clone)]
pub struct BridgeConfig {
    /// The service's configuration (socket, iceoryx2 names, cycle time).
    pub service: ServiceConfig,
    /// The `[ros2]` table as written.
    pub ros2: Ros2Config,
    /// The joint names in use (configured or from the description), joint 1 first.
    pub joint_names: [String; JOINTS],
    /// Publish every this many controller cycles (`1 / (joint_states_hz × fri.cycle_s)`).
    pub joint_states_every: u32,
    /// The URDF for `/robot_description`.
    pub description: RobotDescription,
    /// IP addresses DDS is restricted to (empty: every interface).
    pub addresses: Vec<IpAddr>,
    /// The interface DDS is restricted to, by name (`None`: every interface).
    pub interface: Option<String>,
    /// Who may command, and how requests are bounded.
    pub access: Access,
}

impl BridgeConfig {
    /// Reads and validates `path`: the service's keys as the service checks them, then `[ros2]`.
    pub fn load(path: &Path) -> Result<Self, BridgeConfigError> {
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
            path: path.to_owned(),
            source,
        })?;
        Self::from_toml(&text, path)
    }

    /// Parses and validates configuration text (`path` only names the file in errors; a
    /// relative `ros2.robot_description` is relative to the working directory).
    pub fn from_toml(text: &str, path: &Path) -> Result<Self, BridgeConfigError> {
        let parse = |message: String| ConfigError::Parse {
            path: path.to_owned(),
            message,
        };
        let mut service = ServiceConfig::from_toml(text).map_err(|e| match e {
            ConfigError::Parse { message, .. } => parse(message),
            other => other,
        })?;
        let ros2: Ros2Config = match service.ros2.take() {
            Some(t) => toml::Value::Table(t)
                .try_into()
                .map_err(|e: toml::de::Error| parse(format!("[ros2]: {}", e.message())))?,
            None => Ros2Config::default(),
        };
        Self::new(service, ros2)
    }

    /// Validates `ros2` against `service` and resolves names, description and addresses.
    pub fn new(service: ServiceConfig, ros2: Ros2Config) -> Result<Self, BridgeConfigError> {
        validate_namespace(&ros2.namespace)?;
        if ros2.domain_id > MAX_DOMAIN_ID {
            return Err(invalid(
                "ros2.domain_id",
                format!("{} is out of range 0..={MAX_DOMAIN_ID}", ros2.domain_id),
            ));
        }
        let joint_states_every = joint_states_every(ros2.joint_states_hz, service.fri.cycle_s)?;
        let (lo, hi) = DIAGNOSTICS_HZ;
        if !(lo..=hi).contains(&ros2.diagnostics_hz) {
            return Err(invalid(
                "ros2.diagnostics_hz",
                format!("{} is out of range {lo}..={hi} Hz", ros2.diagnostics_hz),
            ));
        }
        validate_frame("ros2.payload_frame", &ros2.payload_frame)?;
        let description = match &ros2.robot_description {
            Some(p) => RobotDescription::from_file(p)
                .map_err(|e| invalid("ros2.robot_description", e.to_string()))?,
            None => RobotDescription::builtin()
                .map_err(|e| invalid("ros2.robot_description", e.to_string()))?,
        };
        let names = match &ros2.joint_names {
            Some(n) => n.clone(),
            None => description.revolute_joints(),
        };
        let joint_names = validate_joint_names(
            names,
            if ros2.joint_names.is_some() {
                "ros2.joint_names"
            } else {
                "ros2.robot_description"
            },
        )?;
        let (interface, addresses) = match &ros2.interface {
            Some(i) => {
                let (name, addresses) = crate::interface::resolve(i)
                    .map_err(|e| invalid("ros2.interface", e.to_string()))?;
                (Some(name), addresses)
            }
            None => (None, Vec::new()),
        };
        let access = crate::access::validate(AccessKeys {
            commands: &ros2.commands,
            allow_disarm: ros2.allow_disarm,
            allow_resume: ros2.allow_resume,
            allow_motion: ros2.allow_motion,
            security_enclave: ros2.security_enclave.as_deref(),
            allow_unauthenticated_commands: ros2.allow_unauthenticated_commands,
            request_max_age_s: ros2.request_max_age_s,
            max_requests_in_flight: ros2.max_requests_in_flight,
        })?;
        Ok(Self {
            service,
            ros2,
            joint_names,
            joint_states_every,
            description,
            addresses,
            interface,
            access,
        })
    }

    /// The service's iceoryx2 names.
    pub fn ipc_names(&self) -> fri_service::ipc::IpcNames {
        fri_service::ipc::IpcNames {
            service_prefix: self.service.iceoryx2.service_prefix.clone(),
            global_prefix: self.service.iceoryx2.global_prefix.clone(),
        }
    }

    /// `name` in the bridge's namespace, e.g. `/lwr/payload`.
    pub fn in_namespace(&self, name: &str) -> String {
        fri_ros_msgs::names::in_namespace(&self.ros2.namespace, name)
    }
}

fn invalid(key: &str, reason: String) -> ConfigError {
    ConfigError::Invalid {
        key: key.to_owned(),
        reason,
    }
}

/// Cycles between two joint-state messages; the rate must divide the controller rate.
fn joint_states_every(hz: u32, cycle_s: f64) -> Result<u32, BridgeConfigError> {
    let key = "ros2.joint_states_hz";
    if !(1..=MAX_JOINT_STATES_HZ).contains(&hz) {
        return Err(invalid(
            key,
            format!("{hz} is out of range 1..={MAX_JOINT_STATES_HZ} Hz"),
        ));
    }
    let controller_hz = 1.0 / cycle_s;
    let every = controller_hz / f64::from(hz);
    let rounded = every.round();
    if rounded < 1.0 {
        return Err(invalid(
            key,
            format!("{hz} Hz is faster than the controller's {controller_hz} Hz (fri.cycle_s)"),
        ));
    }
    if (every - rounded).abs() > 1e-6 * every {
        return Err(invalid(
            key,
            format!(
                "{hz} Hz does not divide the controller's {controller_hz} Hz (fri.cycle_s): \
                 use 1..={MAX_JOINT_STATES_HZ} Hz giving a whole number of cycles"
            ),
        ));
    }
    Ok(rounded as u32)
}

fn validate_namespace(ns: &str) -> Result<(), BridgeConfigError> {
    fri_ros_msgs::names::check_namespace(ns).map_err(|reason| invalid("ros2.namespace", reason))
}

fn validate_frame(key: &str, frame: &str) -> Result<(), BridgeConfigError> {
    if frame.is_empty()
        || frame.len() > MAX_JOINT_NAME_LEN
        || !fri_ros_msgs::names::is_name_segment(frame)
    {
        return Err(invalid(
            key,
            format!(
                "`{frame}`: 1 to {MAX_JOINT_NAME_LEN} letters, digits and `_`, not starting \
                 with a digit"
            ),
        ));
    }
    Ok(())
}

fn validate_joint_names(
    names: Vec<String>,
    key: &str,
) -> Result<[String; JOINTS], BridgeConfigError> {
    let n = names.len();
    let names: [String; JOINTS] = names
        .try_into()
        .map_err(|_| invalid(key, format!("{n} joint names, the LWR 4+ has {JOINTS}")))?;
    for (i, name) in names.iter().enumerate() {
        validate_frame(key, name)?;
        if names[..i].contains(name) {
            return Err(invalid(key, format!("joint name `{name}` appears twice")));
        }
    }
    Ok(names)
}

#[cfg(test)]
mod tests;
