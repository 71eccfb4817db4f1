//! Who asked for a change. Every safety-relevant change (arming, thresholds, payload, stop,
//! resume, tare, calibration) carries its origin into the audit log, the `audit` event and
//! `status`, so an operator can always tell who switched what.

use std::fmt;

use serde::{Deserialize, Serialize};

/// Longest ROS 2 participant name a request may carry, characters (a DDS GUID as hex with
/// separators is 35).
pub const MAX_PARTICIPANT_LEN: usize = 64;

/// The origin of a request or of a change of the service's state.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum Origin {
    /// A client of the operator socket, as the kernel identified it (`SO_PEERCRED`).
    Operator {
        /// The client's user id.
        uid: u32,
        /// The client's process id.
        pid: i32,
    },
    /// A ROS 2 participant, through the bridge: the participant's DDS GUID as the bridge saw
    /// it (authenticated by DDS Security when the bridge runs with a keystore), and the bridge's
    /// own credentials on the operator socket.
    Ros2 {
        /// The requesting participant's GUID (`xxxxxxxx.xxxxxxxx.xxxxxxxx.xxxxxxxx`, hex).
        participant: String,
        /// Whether DDS Security authenticated the participant (false: the bridge runs with
        /// `ros2.allow_unauthenticated_commands`).
        authenticated: bool,
        /// The bridge's user id.
        uid: u32,
        /// The bridge's process id.
        pid: i32,
    },
    /// The configuration file, at start.
    Configuration,
    /// State restored from the state directory at start.
    Restored,
    /// The service itself: a collision reaction, a mode that expired.
    Service,
}

impl Origin {
    /// Whether `participant` is a name a request may carry: 1 to [`MAX_PARTICIPANT_LEN`]
    /// characters of hex digits, `.` and `:`.
    pub fn valid_participant(participant: &str) -> bool {
        (1..=MAX_PARTICIPANT_LEN).contains(&participant.len())
            && participant
                .chars()
                .all(|c| c.is_ascii_hexdigit() || c == '.' || c == ':')
    }
}

impl fmt::Display for Origin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Origin::Operator { uid, pid } => write!(f, "operator uid {uid} (pid {pid})"),
            Origin::Ros2 {
                participant,
                authenticated,
                uid,
                pid,
            } => write!(
                f,
                "ROS 2 participant {participant} ({}; bridge uid {uid}, pid {pid})",
                if *authenticated {
                    "authenticated"
                } else {
                    "UNAUTHENTICATED"
                }
            ),
            Origin::Configuration => f.write_str("configuration"),
            Origin::Restored => f.write_str("restored state"),
            Origin::Service => f.write_str("service"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn participant_names_are_bounded_hex() {
        assert!(Origin::valid_participant(
            "010f2c4d.00001234.00000001.000001c1"
        ));
        assert!(!Origin::valid_participant(""));
        assert!(!Origin::valid_participant("robot\nadmin"));
        assert!(!Origin::valid_participant(
            &"a".repeat(MAX_PARTICIPANT_LEN + 1)
        ));
    }

    #[test]
    fn displays_who() {
        let o = Origin::Ros2 {
            participant: "01.02".into(),
            authenticated: false,
            uid: 1000,
            pid: 7,
        };
        assert_eq!(
            o.to_string(),
            "ROS 2 participant 01.02 (UNAUTHENTICATED; bridge uid 1000, pid 7)"
        );
        let json = serde_json::to_string(&Origin::Operator { uid: 0, pid: 1 }).unwrap_or_default();
        assert_eq!(json, r#"{"kind":"operator","uid":0,"pid":1}"#);
    }
}
