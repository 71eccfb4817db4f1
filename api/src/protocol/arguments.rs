//! Range checks of every numeric operator argument, run on the request's JSON before it becomes a
//! [`super::Command`], so the error names the field, its value and its allowed range
//! (serde's own messages name neither). The table is documented in `docs/operator-protocol.md`.
//!
//! String arguments have their own rules where they are used (`record`'s file name: 1 to 255
//! safe characters, `crate::recordings`).
//!
//! Checks that need the robot's state (a pattern centre's distance from the measured pose, its
//! margin to the limits for the chosen step) or the configuration (the gain limit at the
//! configured cycle) run again where the command is executed.

use serde_json::{Map, Value};

use super::error::{ErrorCode, OperatorError};
use crate::bounds::{self, JOINTS, Range};

/// Whether an argument is a real number or a count.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// Any finite number inside the range.
    Number,
    /// A non-negative integer inside the range.
    Count,
}

/// One numeric argument: the commands having it, its name, how many elements (`None`: a
/// scalar) and the range of element `i`.
struct Argument {
    commands: &'static [&'static str],
    field: &'static str,
    elements: Option<usize>,
    kind: Kind,
    range: fn(usize) -> Range,
}

const PATTERN: &[&str] = &["tare", "estimate-payload"];

/// Every numeric argument of the protocol.
const ARGUMENTS: &[Argument] = &[
    Argument {
        commands: &["sample"],
        field: "duration_s",
        elements: None,
        kind: Kind::Number,
        range: |_| bounds::SAMPLE_DURATION_S,
    },
    Argument {
        commands: PATTERN,
        field: "around",
        elements: Some(JOINTS),
        kind: Kind::Number,
        range: bounds::joint_position,
    },
    Argument {
        commands: PATTERN,
        field: "poses",
        elements: None,
        kind: Kind::Count,
        range: |_| bounds::POSES,
    },
    Argument {
        commands: PATTERN,
        field: "step_deg",
        elements: None,
        kind: Kind::Number,
        range: |_| bounds::STEP_DEG,
    },
    Argument {
        commands: &["apply-payload"],
        field: "mass",
        elements: None,
        kind: Kind::Number,
        range: |_| bounds::MASS,
    },
    Argument {
        commands: &["apply-payload"],
        field: "com",
        elements: Some(3),
        kind: Kind::Number,
        range: |_| bounds::COM,
    },
    Argument {
        commands: &["expect-payload"],
        field: "max_mass",
        elements: None,
        kind: Kind::Number,
        range: |_| bounds::UNKNOWN_PAYLOAD_MASS,
    },
    Argument {
        commands: &["expect-payload"],
        field: "max_radius",
        elements: None,
        kind: Kind::Number,
        range: |_| bounds::UNKNOWN_PAYLOAD_RADIUS,
    },
    Argument {
        commands: &["collision"],
        field: "thresholds",
        elements: Some(JOINTS),
        kind: Kind::Number,
        range: bounds::threshold,
    },
    Argument {
        commands: &["collision"],
        field: "gains",
        elements: Some(JOINTS),
        kind: Kind::Number,
        // The tightest cycle-independent bound; the configured cycle's is checked on use.
        range: |_| bounds::gain(bounds::MIN_CYCLE_S),
    },
    Argument {
        commands: &["collision"],
        field: "pause_s",
        elements: None,
        kind: Kind::Number,
        range: |_| bounds::PAUSE_S,
    },
    Argument {
        commands: &["record"],
        field: "duration_s",
        elements: None,
        kind: Kind::Number,
        range: |_| bounds::LOG_DURATION_S,
    },
    Argument {
        commands: &["record"],
        field: "count",
        elements: None,
        kind: Kind::Count,
        range: |_| bounds::RECORD_COUNT,
    },
    Argument {
        commands: &["record"],
        field: "excite_deg",
        elements: None,
        kind: Kind::Number,
        range: |_| bounds::EXCITE_DEG,
    },
    Argument {
        commands: &["collision-calibrate"],
        field: "duration_s",
        elements: None,
        kind: Kind::Number,
        range: |_| bounds::CALIBRATION_DURATION_S,
    },
    Argument {
        commands: &["collision-calibrate"],
        field: "budget_per_hour",
        elements: None,
        kind: Kind::Number,
        range: |_| bounds::FALSE_ALARM_BUDGET,
    },
    Argument {
        commands: &["collision-install"],
        field: "median_thresholds",
        elements: Some(JOINTS),
        kind: Kind::Number,
        range: bounds::threshold,
    },
    Argument {
        commands: &["collision-install"],
        field: "period_s",
        elements: None,
        kind: Kind::Number,
        range: |_| bounds::CYCLE_S,
    },
    Argument {
        commands: &["collision-install"],
        field: "gains",
        elements: Some(JOINTS),
        kind: Kind::Number,
        // The tightest cycle-independent bound; the configured cycle's is checked on use.
        range: |_| bounds::gain(bounds::MIN_CYCLE_S),
    },
    Argument {
        commands: &["collision-install"],
        field: "arm_offset",
        elements: Some(JOINTS),
        kind: Kind::Number,
        range: bounds::joint_torque,
    },
    Argument {
        commands: &["watch"],
        field: "state_every",
        elements: None,
        kind: Kind::Count,
        range: |_| bounds::STATE_EVERY,
    },
];

fn invalid(message: String) -> OperatorError {
    OperatorError::new(ErrorCode::InvalidArguments, message)
}

/// Checks the arguments of `cmd` in `args` (the request object without `id`); absent and `null`
/// arguments are left to the defaults.
pub fn check(cmd: &str, args: &Map<String, Value>) -> Result<(), OperatorError> {
    for a in ARGUMENTS.iter().filter(|a| a.commands.contains(&cmd)) {
        match args.get(a.field) {
            None | Some(Value::Null) => {}
            Some(v) => check_argument(a, v)?,
        }
    }
    Ok(())
}

fn check_argument(a: &Argument, value: &Value) -> Result<(), OperatorError> {
    let Some(n) = a.elements else {
        return check_element(a, a.field, 0, value);
    };
    let what = if n == JOINTS {
        "one per joint, joint 1 first"
    } else {
        "x, y, z"
    };
    match value {
        Value::Array(items) if items.len() == n => {
            for (i, item) in items.iter().enumerate() {
                let name = format!("{}[{i}]", a.field);
                check_element(a, &name, i, item).map_err(|mut e| {
                    if n == JOINTS {
                        e.message = format!("{} (joint {})", e.message, i + 1);
                    }
                    e
                })?;
            }
            Ok(())
        }
        _ => Err(invalid(format!(
            "{} must be an array of {n} numbers ({what})",
            a.field
        ))),
    }
}

fn check_element(
    a: &Argument,
    name: &str,
    index: usize,
    value: &Value,
) -> Result<(), OperatorError> {
    let range = (a.range)(index);
    let kind = match a.kind {
        Kind::Number => "a number",
        Kind::Count => "an integer",
    };
    let Some(x) = value.as_f64() else {
        return Err(invalid(format!("{name} must be {kind} in {range}")));
    };
    range.check(name, x).map_err(OperatorError::out_of_range)?;
    if a.kind == Kind::Count && value.as_u64().is_none() {
        return Err(invalid(format!(
            "{name} = {} must be an integer in {range}",
            bounds::number(x)
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cause::Cause;
    use serde_json::json;

    #[test]
    fn an_out_of_range_value_carries_field_value_and_range_as_its_cause() {
        let Value::Object(map) = json!({"thresholds": [6.0, 6.0, 6.0, 6.0, 6.0, 6.0, 1e9]}) else {
            panic!("not an object");
        };
        let e = check("collision", &map).expect_err("1e9 Nm is out of range");
        assert!(e.message.contains("(joint 7)"), "{}", e.message);
        match e.cause.as_deref() {
            Some(Cause::OutOfRange {
                field,
                value,
                max,
                unit,
                ..
            }) => {
                assert_eq!(field, "thresholds[6]");
                assert_eq!(*value, 1e9);
                assert!(*max < 1e9);
                assert_eq!(unit, "Nm");
            }
            other => panic!("cause {other:?}"),
        }
    }

    fn message(cmd: &str, args: Value) -> String {
        let Value::Object(map) = args else {
            return String::new();
        };
        match check(cmd, &map) {
            Ok(()) => String::new(),
            Err(e) => {
                assert_eq!(e.code, ErrorCode::InvalidArguments);
                e.message
            }
        }
    }

    #[test]
    fn every_table_entry_rejects_a_value_outside_its_range_naming_the_field() {
        for a in ARGUMENTS {
            let range = (a.range)(0);
            let bad = json!(range.max * 10.0 + 1e6);
            let value = match a.elements {
                None => bad,
                Some(n) => {
                    let mut items: Vec<Value> = (0..n).map(|i| json!((a.range)(i).min)).collect();
                    items[0] = bad;
                    Value::Array(items)
                }
            };
            for cmd in a.commands {
                let m = message(cmd, json!({ a.field: value.clone() }));
                assert!(m.starts_with(a.field), "{cmd} {}: {m}", a.field);
                assert!(m.contains("is outside"), "{cmd} {}: {m}", a.field);
            }
        }
    }

    #[test]
    fn in_range_absent_and_null_arguments_pass() {
        assert_eq!(message("tare", json!({"poses": 10, "step_deg": 7.0})), "");
        assert_eq!(message("tare", json!({"around": null})), "");
        assert_eq!(
            message(
                "collision",
                json!({"thresholds": [6, 6, 6, 6, 6, 6, 5], "gains": vec![400; 7]})
            ),
            ""
        );
        assert_eq!(
            message("apply-payload", json!({"mass": 3.0, "com": [0, 0, 0.1]})),
            ""
        );
        assert_eq!(message("status", json!({})), "");
    }

    #[test]
    fn the_issue_values_are_rejected_with_field_value_and_range() {
        assert_eq!(
            message(
                "collision",
                json!({"thresholds": [6, 6, 6, 1e300, 6, 6, 6]})
            ),
            "thresholds[3] = 1e300 Nm is outside 0.1…25 Nm (joint 4)"
        );
        assert_eq!(
            message("collision", json!({"gains": vec![1e308; 7]})),
            "gains[0] = 1e308 1/s is outside 1…500 1/s (joint 1)"
        );
        let m = message("estimate-payload", json!({"around": vec![1e300; 7]}));
        assert!(
            m.starts_with("around[0] = 1e300 rad is outside -2.96"),
            "{m}"
        );
        assert_eq!(
            message("tare", json!({"poses": 2.5})),
            "poses = 2.5 must be an integer in 2…100"
        );
        assert_eq!(
            message("watch", json!({"state_every": 0})),
            "state_every = 0 cycles is outside 1…100000 cycles"
        );
        assert_eq!(
            message("apply-payload", json!({"com": [0, 0]})),
            "com must be an array of 3 numbers (x, y, z)"
        );
        assert_eq!(
            message("sample", json!({"duration_s": "long"})),
            "duration_s must be a number in 0.001…60 s"
        );
    }
}
