//! The control protocol: a request line (JSON) into an [`OperatorCommand`], a reply line out.

use serde::{Deserialize, Serialize};

use crate::contact::ContactProfile;
use crate::simulation::OperatorCommand;

/// A request as written on the socket: `{"cmd": "attach", "mass_kg": 1.5, "com_m": [0, 0, 0.1]}`,
/// `{"cmd": "detach"}`, `{"cmd": "push", "link": 4, "point_m": [0, 0, 0.1], "profile": {"kind":
/// "half_sine", "peak_force_n": [0, 60, 0], "duration_s": 0.3}}`, `{"cmd": "monitor"}`,
/// `{"cmd": "restart"}`.
#[derive(Debug, Deserialize)]
#[serde(tag = "cmd", rename_all = "snake_case", deny_unknown_fields)]
enum Request {
    Attach {
        mass_kg: f64,
        com_m: [f64; 3],
    },
    Detach {},
    Push {
        link: usize,
        #[serde(default)]
        point_m: [f64; 3],
        profile: ContactProfile,
    },
    Monitor {},
    Restart {},
}

/// The answer to one request line.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Reply {
    /// Whether the request was carried out.
    pub ok: bool,
    /// What happened (ok) or why not (error), in words.
    pub message: String,
    /// Simulation time at which it was carried out, s (ok only).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub t_s: Option<f64>,
}

impl Reply {
    /// A refusal saying why.
    pub fn error(message: impl Into<String>) -> Self {
        Self {
            ok: false,
            message: message.into(),
            t_s: None,
        }
    }

    /// The reply as one line (newline included).
    pub fn to_line(&self) -> String {
        let mut line = serde_json::to_string(self).unwrap_or_else(|_| {
            // Serialising a struct of a bool, a string and a number cannot fail; stay total.
            String::from(r#"{"ok":false,"message":"reply could not be encoded"}"#)
        });
        line.push('\n');
        line
    }
}

/// Parses and validates one request line; the error names the field and its range.
pub fn parse_request(line: &str) -> Result<OperatorCommand, String> {
    let request: Request = serde_json::from_str(line.trim()).map_err(|e| {
        format!("not a valid request: {e} (see docs/mock-robot.md, Control socket)")
    })?;
    let command = match request {
        Request::Attach { mass_kg, com_m } => OperatorCommand::Attach { mass_kg, com_m },
        Request::Detach {} => OperatorCommand::Detach,
        Request::Push {
            link,
            point_m,
            profile,
        } => OperatorCommand::Push {
            link,
            point_m,
            profile,
        },
        Request::Monitor {} => OperatorCommand::MonitorMode,
        Request::Restart {} => OperatorCommand::Restart,
    };
    command.validate().map_err(|e| e.to_string())?;
    Ok(command)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_parse_into_commands() {
        assert_eq!(
            parse_request(r#"{"cmd":"attach","mass_kg":1.5,"com_m":[0,0,0.1]}"#),
            Ok(OperatorCommand::Attach {
                mass_kg: 1.5,
                com_m: [0.0, 0.0, 0.1]
            })
        );
        assert_eq!(
            parse_request(r#"{"cmd":"detach"}"#),
            Ok(OperatorCommand::Detach)
        );
        assert_eq!(
            parse_request(r#"{"cmd":"monitor"}"#),
            Ok(OperatorCommand::MonitorMode)
        );
        assert_eq!(
            parse_request(r#" {"cmd":"restart"} "#),
            Ok(OperatorCommand::Restart)
        );
        let push = parse_request(
            r#"{"cmd":"push","link":4,"profile":{"kind":"half_sine","peak_force_n":[0,60,0],"duration_s":0.3}}"#,
        );
        assert!(
            matches!(push, Ok(OperatorCommand::Push { link: 4, point_m, .. }) if point_m == [0.0; 3])
        );
    }

    #[test]
    fn errors_name_the_field_and_the_range() {
        let e = parse_request(r#"{"cmd":"attach","mass_kg":-1,"com_m":[0,0,0.1]}"#).unwrap_err();
        assert!(
            e.contains("mass_kg: -1 is out of range") && e.contains("at most 14 kg"),
            "{e}"
        );
        let e = parse_request(r#"{"cmd":"attach","mass_kg":1,"com_m":[0,0,9]}"#).unwrap_err();
        assert!(e.contains("com_m") && e.contains("±0.5 m"), "{e}");
        let e = parse_request(r#"{"cmd":"attach","mass_kg":1}"#).unwrap_err();
        assert!(e.contains("missing field `com_m`"), "{e}");
        let e = parse_request(r#"{"cmd":"attach","mass_kg":1,"com_m":[0,0,0],"x":1}"#).unwrap_err();
        assert!(e.contains("unknown field `x`"), "{e}");
        let e = parse_request(r#"{"cmd":"launch"}"#).unwrap_err();
        assert!(e.contains("unknown variant `launch`"), "{e}");
        let e = parse_request(
            r#"{"cmd":"push","link":9,"profile":{"kind":"half_sine","peak_force_n":[0,60,0],"duration_s":0.3}}"#,
        )
        .unwrap_err();
        assert!(
            e.contains("link: 9 is out of range; links are 1..=7"),
            "{e}"
        );
        let e = parse_request(
            r#"{"cmd":"push","link":3,"profile":{"kind":"half_sine","peak_force_n":[0,6000,0],"duration_s":0.3}}"#,
        )
        .unwrap_err();
        assert!(
            e.contains("profile.peak_force_n") && e.contains("500 N"),
            "{e}"
        );
        let e = parse_request(
            r#"{"cmd":"push","link":3,"profile":{"kind":"ramp","direction":[0,0,0],"rate_n_per_s":10,"max_force_n":20,"duration_s":1}}"#,
        )
        .unwrap_err();
        assert!(e.contains("profile.direction"), "{e}");
        let e = parse_request(r#"{"cmd":"attach","mass_kg":1e999,"com_m":[0,0,0]}"#).unwrap_err();
        assert!(e.contains("not a valid request"), "{e}");
    }
}
